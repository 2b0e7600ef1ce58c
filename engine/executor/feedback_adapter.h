// Between the executor and a backend's raw signals, in both directions.
//
// In: positions (and speeds) of every axis from what the backend reads.
//   speed_dac backends: wrapping down counters with direction bits, decoded here by one
//     CounterDecoder per axis (engine/control/counter_decoder.h). A reading no axis could
//     produce in one period (more than 1.5 x its top speed, plus two counts) is refused: the
//     encoder glitched, or the counter's two bytes were read across a carry. From then on the
//     feedback is not trusted and the last good position is kept. Counts are turned into mm with
//     the calibrated encoder scale when the machine has one (MachineSetup::calibrated_mm_per_count).
//   position backends: the position feedback in mm, taken as it is (a non-finite value is a
//     glitch).
//   The speed of each axis is the position difference over one period, smoothed by a
//   first-order filter of time constant `velocity_filter_s`.
// Out: the executor's speed command per axis (mm/s at the drive's nominal scaling).
//   speed_dac backends: rounded to the DAC code and clipped to its range (clipping is
//     reported: the drive is saturated).
//   position backends: the setpoint goes out as the position command while the executor
//     follows a source; during a controlled stop the ramped speed is integrated instead.
//
// Real time: update() and write() are O(1) per axis, allocate nothing and never throw.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "engine/control/counter_decoder.h"
#include "engine/executor/machine_setup.h"
#include "engine/hardware/backend.h"

namespace machplan::executor {

class FeedbackAdapter {
 public:
  enum class Verdict { ok, encoder_glitch, counter_wrap_misread };

  void configure(const MachineSetup& m, hardware::CommandKind kind, double period_s, double velocity_filter_s = 0.005);
  // The backend's inputs before the first period; the machine stands at `start_mm`.
  void reset(const hardware::Inputs& initial, const Eigen::Vector2d& start_mm);

  // Decodes one period's inputs. On a bad reading returns its verdict, sets `bad_axis` and
  // `jump` (counts), and stops trusting the feedback; later calls change nothing.
  Verdict update(const hardware::Inputs& in, int& bad_axis, double& jump) noexcept;

  // Speed command `u` (mm/s) into the outputs; `setpoint_mm` is the position command for
  // position backends (ignored during a stop, `integrate`). Returns true when any axis's
  // command was clipped to its range.
  bool write(const Eigen::Vector2d& u_mm_per_s, const Eigen::Vector2d& setpoint_mm, bool integrate,
             hardware::Outputs& out) noexcept;
  // The backend takes position commands (and so positions planned ahead).
  bool position_commands() const noexcept { return kind_ != hardware::CommandKind::speed_dac; }

  bool trusted() const noexcept { return trusted_; }
  const Eigen::Vector2d& position_mm() const noexcept { return pos_; }
  const Eigen::Vector2d& velocity_mm_per_s() const noexcept { return vel_; }
  // Feedback resolution per axis: one count (speed_dac), or 1 um (position backends).
  const std::array<double, hardware::kAxes>& quantum_mm() const noexcept { return quantum_; }
  // Largest count jump accepted per period on axis i (speed_dac).
  std::int64_t max_counts(int axis) const noexcept { return max_counts_[axis]; }

 private:
  MachineSetup m_;
  hardware::CommandKind kind_ = hardware::CommandKind::speed_dac;
  double dt_ = 0.001, vel_alpha_ = 1.0;
  std::array<control::CounterDecoder, hardware::kAxes> dec_{};
  std::array<std::int64_t, hardware::kAxes> max_counts_{};
  std::array<double, hardware::kAxes> quantum_{};
  Eigen::Vector2d pos_ = Eigen::Vector2d::Zero(), vel_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d cmd_mm_ = Eigen::Vector2d::Zero();  // position backends: last position command
  bool trusted_ = true;
};

}  // namespace machplan::executor
