// Setpoint source for an operator's joystick: each axis follows the deflection on the
// operator's panel (hardware::OperatorInputs::jog, -1 .. 1) times `speed_mm_per_s`, within the
// machine's acceleration and jerk limits, per axis.
//
// Per axis and period T, with target speed v* = jog * speed, speed v, acceleration a, jerk
// limit J and acceleration limit A: the speed a jerk-limited ramp of a down to zero would
// still add is a|a| / 2J; while v + a|a|/2J falls short of v* the acceleration rises by J T
// (up to A), otherwise it falls by J T (down to -A). Close to v* (within J T^2, with |a| <= J T)
// the axis locks onto v* with a = 0. Then v += a T and x += v T. The setpoint position lags
// by the reading latency like the planned source's; the feed-forward is the present v and a
// (a joystick's future is unknown). A period that would carry v past v* lands on v* with
// a = 0 instead, so the speed never exceeds what the stick asks.
//
// The source runs no job: the executor runs a jog session until the operator presses cycle
// start (the end of the manual part) or a stop is requested. A guard (a filter between this
// source and the controller) keeps the tool out of prohibited regions; this source only keeps
// the dynamics within the machine's limits.
#pragma once

#include <array>

#include "engine/executor/setpoint_source.h"

namespace machplan::executor {

struct JogOptions {
  double speed_mm_per_s = 20.0;         // speed at full deflection
  double acceleration_mm_per_s2 = 0.0;  // 0: the machine's
  double jerk_mm_per_s3 = 0.0;          // 0: the machine's
  double deadband = 0.02;               // deflections below this count as centred
  void validate() const;                // throws InputError naming the field
};

class JogSource final : public SetpointSource {
 public:
  explicit JogSource(const JogOptions& o = {}) : o_(o) {}
  const char* name() const override { return "jog"; }
  bool runs_job() const override { return false; }
  void prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) override;
  void begin_move(std::size_t, const Eigen::Vector2d&) noexcept override {}
  void advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs& op) noexcept override;
  bool move_done() const noexcept override { return true; }
  void demand(Demand& d) const noexcept override;

  Eigen::Vector2d velocity_mm_per_s() const { return {v_[0], v_[1]}; }
  Eigen::Vector2d acceleration_mm_per_s2() const { return {a_[0], a_[1]}; }

 private:
  static constexpr int kHistory = 8;  // positions kept for the reading latency
  JogOptions o_;
  double dt_ = 0.001, A_ = 0.0, J_ = 0.0, vmax_ = 0.0;
  std::array<int, control::kAxes> read_latency_{};
  std::array<double, control::kAxes> x_{}, v_{}, a_{};
  std::array<std::array<double, control::kAxes>, kHistory> past_{};
  int head_ = 0;
};

}  // namespace machplan::executor
