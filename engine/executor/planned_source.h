// Setpoint source of the planned mode: the feed planner's Trajectory of each move step,
// sampled every servo period (the real-time interpolator).
//
// The measurement the controller compares with is `reading_latency` periods old, so the
// position setpoint is sampled that far back; the command acts `command_latency + 1` periods
// from now, so the feed-forward is sampled that far ahead. Both are samples of the same
// rest-to-rest trajectory (clamped at its ends), so they are exact across step boundaries
// too: between moves the source keeps sampling the last trajectory, which holds its end.
//
// For the controllers it also gives the segment the TOOL is on, of the path the setpoints
// follow (the planner's executed path, with its blended corners; the programmed one for
// trajectories that do not round corners): the one nearest the measured position, found by a
// cursor that only moves forward, a bounded number of segments per period. At a corner the
// lagging tool keeps its segment until it has turned, so a contour controller measures its
// error against the piece it is cutting, not the one the setpoint has reached. And
// ControllerInput::kMaxPreviewTicks setpoints ahead of r.
#pragma once

#include <algorithm>
#include <array>
#include <vector>

#include "engine/executor/setpoint_source.h"
#include "engine/executor/time_scale.h"

namespace machplan::executor {

class PlannedSource final : public SetpointSource {
 public:
  const char* name() const override { return "planned"; }
  void prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) override;
  double estimate_s() const override { return estimate_s_; }
  void begin_move(std::size_t step, const Eigen::Vector2d& measured_mm) noexcept override;
  void advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs& op) noexcept override;
  bool move_done() const noexcept override;
  void demand(Demand& d) const noexcept override;
  int source_line() const noexcept override;
  bool supports_rate() const noexcept override { return true; }
  void set_rate(double target) noexcept override { target_ = target; }
  double rate() const noexcept override { return scale_.k(); }
  bool motion_left_s(double feed_rate, double rapid_rate, double& feed_s, double& rapid_s) const noexcept override;
  double path_distance_mm(const Eigen::Vector2d& p) const noexcept override;
  void motion_now(Eigen::Vector2d& v_mm_per_s, Eigen::Vector2d& a_mm_per_s2) const noexcept override;
  // Paused motion moves the path time back (or on) along the planned path at the machine's
  // paused-motion speed, ramped at kPausedAcceleration, and on into the neighbouring moves'
  // trajectories: the setpoints stay on the planned path.
  void pause_move(double delta_mm, bool within_cut) noexcept override {
    pause_left_mm_ += delta_mm;
    pause_within_cut_ = within_cut;
  }
  void pause_jog(double speed_fraction) noexcept override { pause_jog_ = std::clamp(speed_fraction, -1.0, 1.0); }
  bool pause_moving() const noexcept override { return pause_left_mm_ != 0.0 || pause_jog_ != 0.0 || pause_v_ != 0.0; }
  double take_paused_mm() noexcept override {
    const double r = paused_mm_;
    paused_mm_ = 0.0;
    return r;
  }
  std::size_t move_step() const noexcept override { return cur_ ? step_ : kNoStep; }
  int plan_ahead(std::array<double, hardware::kAxes>* mm, int n) const noexcept override;
  static constexpr double kPausedAcceleration = 200.0;  // mm/s^2

 private:
  SourceContext ctx_;
  Eigen::Vector2d hold_mm_ = Eigen::Vector2d::Zero();
  const motion::Trajectory* cur_ = nullptr;  // the move being (or last) executed
  const motion::Stretch* stretch_ = nullptr;  // the path it follows (executed, else programmed)
  mutable std::size_t segment_ = 0;           // cursor: the segment the tool is on
  Eigen::Vector2d measured_mm_ = Eigen::Vector2d::Zero();  // as given to advance()
  std::size_t step_ = 0;
  double t_ = 0.0;                             // path time of the move: the plan's time, s
  TimeScale scale_;                            // how fast t_ runs (hold, overrides)
  double target_ = 1.0;
  double estimate_s_ = 0.0;
  // Paused motion: the distance asked and not yet moved, the speed asked (a fraction), the
  // signed speed now (mm/s), what was moved since take_paused_mm, and whether it may leave the
  // cut it is in.
  double pause_left_mm_ = 0.0, pause_jog_ = 0.0, pause_v_ = 0.0, paused_mm_ = 0.0;
  bool pause_within_cut_ = false;
  void step_paused() noexcept;
  // The path time one period after `t` at the rate asked for, `scale` stepped along.
  double next_time(TimeScale& scale, double t) const noexcept;
  // plan_ahead's periods, a ring from ahead_head_: each with the state the source will be in
  // then. When the source has taken the first of them as planned (the same move, rate asked
  // and state), the others still hold and one more is planned at the end: one sample a period
  // instead of n.
  struct AheadSlot {
    std::array<double, hardware::kAxes> mm{};
    double t = 0.0;
    TimeScale scale;
  };
  mutable std::array<AheadSlot, hardware::Outputs::kMaxAhead> ahead_{};
  mutable int ahead_head_ = 0, ahead_n_ = 0;
  mutable const motion::Trajectory* ahead_move_ = nullptr;
  mutable double ahead_target_ = 0.0;
  void plan_slot(AheadSlot& s) const noexcept;
  double slide(double dir, double ds, bool& crossed) noexcept;
  bool enter_neighbour(double dir) noexcept;
  void enter_move(std::size_t step) noexcept;

  // For motion_left_s, the motion from each step to the job's end: its rapids' time, its feed
  // moves' time and, of that, the time they cruise by the rate the axes allow there
  // (TimeScale::speed_ceiling; bin b from 1 + b kCeilingBin on). Sampled before the run, every
  // kCeilingSampleS of plan time at most. An estimate for a display: the ramps of the rate
  // into and out of a faster cruise are not counted.
  static constexpr int kCeilingBins = 21;
  static constexpr double kCeilingBin = 0.05, kCeilingSampleS = 0.005;
  struct MotionTime {
    double rapid_s = 0.0, feed_s = 0.0;
    std::array<double, kCeilingBins> cruise_s{};
  };
  std::vector<MotionTime> from_step_;
  void prepare_motion_times();
  static double feed_time_s(const MotionTime& m, double rate) noexcept;
};

}  // namespace machplan::executor
