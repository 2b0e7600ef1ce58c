// Axial P / PID controller with optional velocity and acceleration feed-forward and
// back-calculation anti-windup. Each axis runs the same law with its own gains; the path in
// ControllerInput is not used.
//
// Control law of one axis, once per servo period T at tick k:
//
//     e[k]   = r[k] - y[k]                                           following error, mm
//     D[k]   = (Tf D[k-1] + Kd (e[k] - e[k-1])) / (Tf + T)          filtered derivative term
//     s[k]   = sat(v_r[k] / v_b)                                     direction of the reference
//     h[k]   = s[k] when it lies beyond h[k-1] (same sign, larger,    side of the backlash gap
//              or the other sign), else h[k-1];  h = 0 at the start
//     v[k]   = Kvff v_r[k] + Ta a_r[k] + Fc s[k]                     feed-forward, mm/s
//            + (b / 2) (h[k] - h[k-1]) / T                           backlash feed-forward
//            + Kp e[k] + I[k] + D[k]                                 feedback, mm/s
//     u[k]   = clamp(v[k], -u_max, +u_max)                           the command
//     I[k+1] = I[k] + T (Ki e[k] + (u[k] - v[k]) / Tt)               back-calculation
//
// Anti-windup is BACK-CALCULATION (Astrom and Hagglund): while the command is clipped the
// integrator is pulled back by the clipped amount divided by the tracking time Tt, so it
// settles where the unclipped command just meets the limit and recovers as soon as the error
// falls, instead of unwinding a store it filled while the drive could not follow. Tt defaults
// to Ti = Kp / Ki (`tracking_time_s` = 0); a shorter Tt resets harder. (The executor's first
// servo, AxisServo in servo.h, uses conditional integration; this one is the textbook PID the
// tuner compares, kept apart so that AxisServo's numbers stay what calibration was fitted with.)
//
// With Ki = Kd = 0 and no feed-forward this is the plain axial P controller, u = Kp e, the
// hand-tuned baseline of a type-1 loop: on a ramp of speed v it lags by v / (g Kp) (g the
// drive's gain). Kvff = 1/g and Ta = the drive's velocity-loop time constant make a
// first-order drive follow the setpoint exactly (velocity and acceleration feed-forward); the
// factory exposes them as options of "p" and "pid" rather than as another controller.
// Fc is Coulomb friction feed-forward: the speed the drive loses to Coulomb friction (what
// calibration or the tuner finds), added in the direction of the reference velocity; sat() is
// a ramp over the band v_b (`friction_ff_band_mm_per_s`) so that it does not chatter at rest
// or at a reversal. It pre-empts the error that friction would otherwise cause at every
// reversal, which the feedback only answers once the error is there.
// b is backlash feed-forward: when the reference reverses (its direction s turning from -1 to
// +1 over the same band v_b) the motor is moved b further, across the gap between screw and
// table, which the table's own encoder otherwise sees as the table standing still while the
// reference moves away; b/2 at the first start from rest (the table then sits mid-gap, as the
// simulator starts it). A stop and a start in the same direction move nothing: the motor is
// still on the side of the gap it pushed on.
//
// Position observer (position_observer.h), off unless `observer_per_s` > 0: the loop then acts
// on the observer's prediction of the position at the instant its command takes effect, from
// the counts and the commands it sent, against the setpoint of that instant (observed_input()
// below, then update(), once per period).
//
// Real time: update() is O(1) per axis, allocates nothing and never throws.
#pragma once

#include <algorithm>
#include <cmath>

#include "engine/control/controller.h"
#include "engine/control/position_observer.h"

namespace machplan::control {

struct PidGains {
  double kp_per_s = 60.0;            // Kp: mm/s of command per mm of error
  double ki_per_s2 = 0.0;            // Ki: mm/s per (mm s)
  double kd = 0.0;                   // Kd: mm/s per mm/s of error rate
  double velocity_ff = 0.0;          // Kvff, dimensionless
  double acceleration_ff_s = 0.0;    // Ta, s
  double friction_ff_mm_per_s = 0.0;       // Fc, mm/s
  double friction_ff_band_mm_per_s = 0.5;  // v_b, mm/s (> 0)
  double backlash_ff_mm = 0.0;             // b, mm
  double tracking_time_s = 0.0;      // Tt of the back-calculation; 0: Ti = Kp / Ki
  double derivative_filter_s = 0.001;  // Tf, s (> 0)
  double observer_per_s = 0.0;       // bandwidth of the position observer, rad/s; 0: off
  double following_error_limit_mm = 2.0;
  // Throws InputError naming field, value and rule.
  void validate() const;
};

// One axis of the law above; also the axial loop inside the contour and ZPETC controllers.
class AxialPid {
 public:
  // Validates `g`; `output_limit_mm_per_s` = u_max, `period_s` = T; `observer` is the
  // drive model of the position observer (its period and speed limit are set to T and u_max),
  // used when g.observer_per_s > 0.
  void configure(const PidGains& g, double output_limit_mm_per_s, double period_s, ObserverModel observer = {});
  void reset() noexcept {
    integral_ = derivative_ = e_prev_ = last_error_ = side_ = 0.0;
    first_ = true;
    saturated_ = false;
    observer_.reset();
  }
  // The position this loop acts on, from this period's reading: the observer's estimate, or
  // the reading itself with the observer off. Call once per period, before update().
  double observe(double y_mm) noexcept { return observer_.update(y_mm); }
  // With the observer on: the periods from the reading's instant to the one at which this
  // period's command acts (the model's D), and the position predicted for that instant.
  int prediction_ticks() const noexcept { return observer_.enabled() ? delay_ticks_ : 0; }
  double predicted_mm() const noexcept { return observer_.predict(); }
  // One tick. `extra_mm_per_s` is added to the command before the limit (a cross-coupled
  // correction); it takes part in the anti-windup like any other term.
  double update(double r_mm, double v_r, double a_r, double y_mm, double extra_mm_per_s = 0.0) noexcept {
    const double e = r_mm - y_mm;
    if (!first_) derivative_ = (g_.derivative_filter_s * derivative_ + g_.kd * (e - e_prev_)) / (g_.derivative_filter_s + T_);
    first_ = false;
    e_prev_ = e;
    last_error_ = e;
    const double dir = std::clamp(v_r / g_.friction_ff_band_mm_per_s, -1.0, 1.0);
    // The side of the gap the motor pushes on follows the reference outwards only: a stop
    // leaves it where it was, a start the other way moves it across.
    const double side = (dir > 0 && dir > side_) || (dir < 0 && dir < side_) ? dir : side_;
    const double backlash = 0.5 * g_.backlash_ff_mm * (side - side_) / T_;
    side_ = side;
    const double v = g_.velocity_ff * v_r + g_.acceleration_ff_s * a_r + g_.friction_ff_mm_per_s * dir + backlash +
                     g_.kp_per_s * e + integral_ + derivative_ + extra_mm_per_s;
    const double u = std::clamp(v, -u_max_, u_max_);
    saturated_ = u != v;
    if (g_.ki_per_s2 > 0)
      integral_ = std::clamp(integral_ + T_ * (g_.ki_per_s2 * e + (u - v) / tt_), -u_max_, u_max_);
    observer_.command(u);
    return u;
  }
  double last_error_mm() const noexcept { return last_error_; }
  double integral_mm_per_s() const noexcept { return integral_; }
  bool saturated() const noexcept { return saturated_; }
  bool following_error_exceeded() const noexcept { return std::abs(last_error_) > g_.following_error_limit_mm; }
  const PidGains& gains() const noexcept { return g_; }

 private:
  PidGains g_;
  double u_max_ = 1.0, T_ = 1e-3, tt_ = 1.0;
  int delay_ticks_ = 0;
  double integral_ = 0.0, derivative_ = 0.0, e_prev_ = 0.0, last_error_ = 0.0, side_ = 0.0;
  bool first_ = true, saturated_ = false;
  PositionObserver observer_;
};

// The input the axial loops act on, from the executor's: each axis's measured position through
// its observer (observe()); where the observer is on and the source previews far enough, the
// position predicted for the instant this period's command acts, against the setpoint of that
// same instant (a Smith predictor: the loop no longer waits out the latencies to see what its
// own commands did). Call once per period.
inline void observed_input(std::array<AxialPid, kAxes>& axes, const ControllerInput& raw, ControllerInput& in) noexcept {
  in = raw;
  for (int i = 0; i < kAxes; ++i) {
    in.y_mm[i] = axes[i].observe(raw.y_mm[i]);
    const int d = axes[i].prediction_ticks();
    if (d > 0 && d <= raw.preview_ticks) {
      in.y_mm[i] = axes[i].predicted_mm();
      in.r_mm[i] = raw.r_preview_mm[static_cast<std::size_t>(d - 1)][i];
    }
  }
}

class PidController final : public Controller {
 public:
  // `name` is what name() returns ("p" or "pid": the factory's kind); it must outlive this.
  explicit PidController(const char* name = "pid") : name_(name) {}
  void configure(const std::array<PidGains, kAxes>& gains, const std::array<double, kAxes>& output_limit_mm_per_s,
                 double period_s, const std::array<ObserverModel, kAxes>& observer = {}) {
    for (int i = 0; i < kAxes; ++i) axis_[i].configure(gains[i], output_limit_mm_per_s[i], period_s, observer[i]);
  }
  const char* name() const override { return name_; }
  void reset() override {
    for (AxialPid& a : axis_) a.reset();
  }
  void update(const ControllerInput& raw, ControllerOutput& out) noexcept override {
    observed_input(axis_, raw, in_);
    for (int i = 0; i < kAxes; ++i)
      out.u_mm_per_s[i] = axis_[i].update(in_.r_mm[i], in_.v_ff_mm_per_s[i], in_.a_ff_mm_per_s2[i], in_.y_mm[i]);
  }
  double following_error_mm(int axis) const noexcept override { return axis_[axis].last_error_mm(); }
  bool following_error_exceeded(int axis) const noexcept override { return axis_[axis].following_error_exceeded(); }
  bool saturated(int axis) const noexcept override { return axis_[axis].saturated(); }
  const AxialPid& axis(int i) const { return axis_[i]; }

 private:
  const char* name_;
  std::array<AxialPid, kAxes> axis_{};
  ControllerInput in_;  // what the loops act on this period
};

}  // namespace machplan::control
