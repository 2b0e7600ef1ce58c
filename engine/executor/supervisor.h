// Fault detection and the controlled stop.
//
// Detection, every period (each check is O(1)):
//   * lost backend, watchdog tripped, E-stop, encoder glitch and counter wrap misread (verdicts
//     of the feedback adapter), the torch's breakaway switch (a collision with the plate), a
//     stop requested from another thread or by a signal;
//   * arc lost while a plasma cut moves (arc OK low for longer than arc_loss_debounce_s);
//   * following error (the controller's, for tracking sources);
//   * no progress: an axis commanded to move that does not. Per axis, while the speed command
//     stays above `stall_min_speed_mm_per_s` in one direction, the commanded travel is summed;
//     once it reaches `stall_check_travel_mm` (at least 8 encoder counts) the measured travel
//     must be at least `stall_min_fraction` of it, else the axis is stalled (a jam, a drive
//     that does not answer). This runs under every setpoint source, so the open-loop paper
//     modes, which have no following error, stop on a jammed axis too. Under a tracking source
//     the speed asked is the setpoint's and the check travel at least twice the following-error
//     limit, so a jam there is reported as the following error it causes first;
//   * saturated drive off the contour: while cutting, the share of periods in which a drive
//     command was clipped (an exponential average over `saturation_window_s`) above
//     `saturation_share` together with a contour error above the machine's
//     contour_error_limit_mm (a loop driven into bang-bang by absurd gains, a drive too weak
//     for the feed) is a fault: the cut would be scrap.
// The first fault wins; later ones are not recorded.
//
// The controlled stop (after any fault, or a stop request): in the same period the torch goes
// off and retracts (TorchSequencer::kill); the commanded speed vector is ramped to zero at the
// machine's acceleration limit keeping its direction; the command is then held at zero until
// the axes are at rest (measured positions within one count for `rest_window_s`, or for
// `stop_settle_s` when the feedback is no longer trusted; at most 4 x stop_settle_s), then the
// drives are disabled and the run ends. A lost backend cannot be commanded at all: the run ends
// at once and the backend's own watchdog must stop the machine.
#pragma once

#include <array>

#include <Eigen/Core>

#include "engine/executor/machine_setup.h"
#include "engine/executor/torch_sequencer.h"
#include "engine/hardware/backend.h"

namespace machplan::executor {

enum class FaultKind {
  following_error,
  encoder_glitch,
  counter_wrap_misread,
  estop,
  lost_backend,
  watchdog,
  arc_start_failed,
  arc_lost,
  torch_height_timeout,
  axis_stalled,
  drive_saturated,
  torch_breakaway,  // the torch touched the plate (its breakaway switch opened, or the float switch closed while it fired): a collision
  probe_miss,       // the probe found no sheet within its travel
  probe_switch_stuck,  // a probe sensor was closed before the torch went down
  stop_requested,
  operator_stop   // the operator's stop button (or a `stop` event): the job ends, not a machine fault
};
const char* to_string(FaultKind k);

struct SupervisorOptions {
  double rest_window_s = 0.05;
  double stop_settle_s = 0.5;
  double stall_min_speed_mm_per_s = 0.5;
  double stall_check_travel_mm = 1.0;
  double stall_min_fraction = 0.25;
  double saturation_window_s = 0.25;
  double saturation_share = 0.5;
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

class Supervisor {
 public:
  enum class State { running, ramp, settle, disable };

  void configure(const MachineSetup& m, const SupervisorOptions& o, double period_s,
                 const std::array<double, hardware::kAxes>& quantum_mm);
  void reset(const Eigen::Vector2d& position_mm);

  // --- detection ---------------------------------------------------------------------------
  // Records the first fault. The caller supplies where the job was.
  struct Where {
    double t_s = 0.0;
    int step = -1;
    int source_line = 0;
    Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();
  };
  void raise(FaultKind kind, int axis, double value, const Where& w) noexcept;
  bool faulted() const noexcept { return faulted_; }
  // The position is trusted up to here (kept as the fault's last known position).
  void note_trusted(const Eigen::Vector2d& position_mm) noexcept { last_known_mm_ = position_mm; }
  // Arc OK while a plasma cut moves; returns true when it was lost for too long.
  bool arc_lost(bool moving_plasma_cut, bool arc_ok) noexcept;
  double arc_low_s() const noexcept { return arc_low_s_; }
  // Progress of every axis against its command; returns the stalled axis or -1.
  // `u`: the speed each axis is asked for (the setpoint's when `tracking`, else the command).
  int stalled_axis(const Eigen::Vector2d& u_mm_per_s, const Eigen::Vector2d& measured_mm, bool tracking) noexcept;
  // Saturation while cutting with the given contour error; true when it is a fault.
  bool saturated_off_contour(bool cutting, bool any_saturated, double contour_error_mm) noexcept;
  double saturation_share() const noexcept { return sat_share_; }

  // --- controlled stop ---------------------------------------------------------------------
  // Torch off and retract now; ramp from the present speed command `u`.
  void begin_stop(const Eigen::Vector2d& u_mm_per_s, TorchSequencer& torch, hardware::Outputs& out) noexcept;
  // The normal end of a job: disable the drives with the next exchange.
  void finish() noexcept { state_ = State::disable; }
  // One period of the stop; returns the speed command. `trusted`: the feedback can be believed.
  Eigen::Vector2d stop_tick(const Eigen::Vector2d& measured_mm, bool trusted) noexcept;
  State state() const noexcept { return state_; }
  bool stopping() const noexcept { return state_ != State::running; }
  bool stopped_at_rest() const noexcept { return at_rest_; }
  void set_not_at_rest() noexcept { at_rest_ = false; }

  // The fault recorded (valid when faulted()).
  FaultKind kind() const noexcept { return kind_; }
  int axis() const noexcept { return axis_; }
  double value() const noexcept { return value_; }
  const Where& where() const noexcept { return where_; }
  const Eigen::Vector2d& last_known_mm() const noexcept { return last_known_mm_; }

 private:
  MachineSetup m_;
  SupervisorOptions o_;
  double dt_ = 0.001;
  std::array<double, hardware::kAxes> quantum_mm_{};
  std::array<double, hardware::kAxes> check_travel_mm_{}, check_travel_tracking_mm_{};
  // Fault.
  bool faulted_ = false;
  FaultKind kind_ = FaultKind::estop;
  int axis_ = -1;
  double value_ = 0.0;
  Where where_;
  Eigen::Vector2d last_known_mm_ = Eigen::Vector2d::Zero();
  // Arc loss.
  double arc_low_s_ = 0.0;
  // Stall.
  std::array<int, hardware::kAxes> stall_dir_{};
  std::array<double, hardware::kAxes> stall_cmd_mm_{}, stall_from_mm_{};
  // Saturation.
  double sat_share_ = 0.0;
  // Stop.
  State state_ = State::running;
  Eigen::Vector2d u0_ = Eigen::Vector2d::Zero(), rest_mm_ = Eigen::Vector2d::Zero();
  double stop_t_ = 0.0, settle_t_ = 0.0, rest_s_ = 0.0;
  bool at_rest_ = true;
};

}  // namespace machplan::executor
