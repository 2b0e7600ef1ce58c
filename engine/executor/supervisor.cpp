#include "engine/executor/supervisor.h"

#include <algorithm>
#include <cmath>

#include "engine/common/error.h"

namespace machplan::executor {

const char* to_string(FaultKind k) {
  switch (k) {
    case FaultKind::following_error: return "following_error";
    case FaultKind::encoder_glitch: return "encoder_glitch";
    case FaultKind::counter_wrap_misread: return "counter_wrap_misread";
    case FaultKind::estop: return "estop";
    case FaultKind::lost_backend: return "lost_backend";
    case FaultKind::watchdog: return "watchdog";
    case FaultKind::arc_start_failed: return "arc_start_failed";
    case FaultKind::arc_lost: return "arc_lost";
    case FaultKind::torch_height_timeout: return "torch_height_timeout";
    case FaultKind::axis_stalled: return "axis_stalled";
    case FaultKind::drive_saturated: return "drive_saturated";
    case FaultKind::torch_breakaway: return "torch_breakaway";
    case FaultKind::probe_miss: return "probe_miss";
    case FaultKind::probe_switch_stuck: return "probe_switch_stuck";
    case FaultKind::stop_requested: return "stop_requested";
    case FaultKind::operator_stop: return "operator_stop";
  }
  return "?";
}

void SupervisorOptions::validate() const {
  require_field(std::isfinite(rest_window_s) && rest_window_s > 0 && rest_window_s <= 10, "rest_window_s", rest_window_s,
                "must be in (0, 10] s");
  require_field(std::isfinite(stop_settle_s) && stop_settle_s > 0 && stop_settle_s <= 60, "stop_settle_s", stop_settle_s,
                "must be in (0, 60] s");
  require_field(std::isfinite(stall_min_speed_mm_per_s) && stall_min_speed_mm_per_s > 0 && stall_min_speed_mm_per_s <= 1000,
                "stall_min_speed_mm_per_s", stall_min_speed_mm_per_s, "must be in (0, 1000] mm/s");
  require_field(std::isfinite(stall_check_travel_mm) && stall_check_travel_mm > 0 && stall_check_travel_mm <= 1000,
                "stall_check_travel_mm", stall_check_travel_mm, "must be in (0, 1000] mm");
  require_field(std::isfinite(stall_min_fraction) && stall_min_fraction >= 0 && stall_min_fraction < 1,
                "stall_min_fraction", stall_min_fraction, "must be in [0, 1)");
  require_field(std::isfinite(saturation_window_s) && saturation_window_s > 0 && saturation_window_s <= 60,
                "saturation_window_s", saturation_window_s, "must be in (0, 60] s");
  require_field(std::isfinite(saturation_share) && saturation_share > 0 && saturation_share <= 1, "saturation_share",
                saturation_share, "must be in (0, 1]");
}

void Supervisor::configure(const MachineSetup& m, const SupervisorOptions& o, double period_s,
                           const std::array<double, hardware::kAxes>& quantum_mm) {
  o.validate();
  m_ = m;
  o_ = o;
  dt_ = period_s;
  quantum_mm_ = quantum_mm;
  for (int i = 0; i < hardware::kAxes; ++i) {
    check_travel_mm_[i] = std::max(o_.stall_check_travel_mm, 8.0 * quantum_mm_[i]);
    check_travel_tracking_mm_[i] = std::max(check_travel_mm_[i], 2.0 * m.servo[i].following_error_limit_mm);
  }
}

void Supervisor::reset(const Eigen::Vector2d& position_mm) {
  faulted_ = false;
  axis_ = -1;
  value_ = 0.0;
  where_ = {};
  last_known_mm_ = position_mm;
  arc_low_s_ = 0.0;
  stall_dir_.fill(0);
  stall_cmd_mm_.fill(0.0);
  for (int i = 0; i < hardware::kAxes; ++i) stall_from_mm_[i] = position_mm[i];
  sat_share_ = 0.0;
  state_ = State::running;
  at_rest_ = true;
}

void Supervisor::raise(FaultKind kind, int axis, double value, const Where& w) noexcept {
  if (faulted_) return;
  faulted_ = true;
  kind_ = kind;
  axis_ = axis;
  value_ = value;
  where_ = w;
}

bool Supervisor::arc_lost(bool moving_plasma_cut, bool arc_ok) noexcept {
  if (!moving_plasma_cut) return false;
  arc_low_s_ = arc_ok ? 0.0 : arc_low_s_ + dt_;
  return arc_low_s_ > m_.torch.arc_loss_debounce_s;
}

int Supervisor::stalled_axis(const Eigen::Vector2d& u, const Eigen::Vector2d& y, bool tracking) noexcept {
  for (int i = 0; i < hardware::kAxes; ++i) {
    const int dir = u[i] > o_.stall_min_speed_mm_per_s ? 1 : (u[i] < -o_.stall_min_speed_mm_per_s ? -1 : 0);
    if (dir == 0 || dir != stall_dir_[i]) {
      // A new stretch of commanded motion starts (or none): measure from here.
      stall_dir_[i] = dir;
      stall_cmd_mm_[i] = 0.0;
      stall_from_mm_[i] = y[i];
      continue;
    }
    stall_cmd_mm_[i] += std::abs(u[i]) * dt_;
    if (stall_cmd_mm_[i] < (tracking ? check_travel_tracking_mm_[i] : check_travel_mm_[i])) continue;
    const double moved = dir * (y[i] - stall_from_mm_[i]);
    if (moved < o_.stall_min_fraction * stall_cmd_mm_[i]) return i;
    stall_cmd_mm_[i] = 0.0;
    stall_from_mm_[i] = y[i];
  }
  return -1;
}

bool Supervisor::saturated_off_contour(bool cutting, bool any_saturated, double contour_error_mm) noexcept {
  const double alpha = std::min(1.0, dt_ / o_.saturation_window_s);
  sat_share_ += alpha * ((any_saturated ? 1.0 : 0.0) - sat_share_);
  return cutting && sat_share_ > o_.saturation_share && contour_error_mm > m_.contour_error_limit_mm;
}

void Supervisor::begin_stop(const Eigen::Vector2d& u, TorchSequencer& torch, hardware::Outputs& out) noexcept {
  torch.kill(out);  // torch off in this very period, height to retract
  u0_ = u;
  stop_t_ = 0.0;
  state_ = State::ramp;
}

Eigen::Vector2d Supervisor::stop_tick(const Eigen::Vector2d& y, bool trusted) noexcept {
  switch (state_) {
    case State::running: return Eigen::Vector2d::Zero();
    case State::ramp: {
      stop_t_ += dt_;
      const double s0 = u0_.norm();
      const double s = std::max(0.0, s0 - m_.max_acceleration_mm_per_s2 * stop_t_);
      if (s > 0.0) return u0_ * (s / s0);
      state_ = State::settle;
      settle_t_ = rest_s_ = 0.0;
      rest_mm_ = y;
      return Eigen::Vector2d::Zero();
    }
    case State::settle: {
      settle_t_ += dt_;
      bool rest = false;
      if (trusted) {
        bool still = true;
        for (int i = 0; i < hardware::kAxes; ++i) still = still && std::abs(y[i] - rest_mm_[i]) <= 1.5 * quantum_mm_[i];
        rest_s_ = still ? rest_s_ + dt_ : 0.0;
        if (!still) rest_mm_ = y;
        rest = rest_s_ >= o_.rest_window_s;
        if (!rest && settle_t_ > 4 * o_.stop_settle_s) {
          at_rest_ = false;
          rest = true;
        }
      } else {
        rest = settle_t_ >= o_.stop_settle_s;
      }
      if (rest) state_ = State::disable;
      return Eigen::Vector2d::Zero();
    }
    case State::disable: return Eigen::Vector2d::Zero();
  }
  return Eigen::Vector2d::Zero();
}

}  // namespace machplan::executor
