// Axial P / PID controller with optional velocity and acceleration feed-forward and
// back-calculation anti-windup. Each axis runs the same law with its own gains; the path in
// ControllerInput is not used.
//
// Control law of one axis, once per servo period T at tick k:
//
//     e[k]   = r[k] - y[k]                                           following error, mm
//     D[k]   = (Tf D[k-1] + Kd (e[k] - e[k-1])) / (Tf + T)          filtered derivative term
//     v[k]   = Kvff v_r[k] + Ta a_r[k] + Fc sat(v_r[k] / v_b)        feed-forward, mm/s
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
//
// Real time: update() is O(1) per axis, allocates nothing and never throws.
#pragma once

#include <algorithm>
#include <cmath>

#include "engine/control/controller.h"

namespace machplan::control {

struct PidGains {
  double kp_per_s = 60.0;            // Kp: mm/s of command per mm of error
  double ki_per_s2 = 0.0;            // Ki: mm/s per (mm s)
  double kd = 0.0;                   // Kd: mm/s per mm/s of error rate
  double velocity_ff = 0.0;          // Kvff, dimensionless
  double acceleration_ff_s = 0.0;    // Ta, s
  double friction_ff_mm_per_s = 0.0;       // Fc, mm/s
  double friction_ff_band_mm_per_s = 0.5;  // v_b, mm/s (> 0)
  double tracking_time_s = 0.0;      // Tt of the back-calculation; 0: Ti = Kp / Ki
  double derivative_filter_s = 0.001;  // Tf, s (> 0)
  double following_error_limit_mm = 2.0;
  // Throws std::invalid_argument naming field, value and rule.
  void validate() const;
};

// One axis of the law above; also the axial loop inside the contour and ZPETC controllers.
class AxialPid {
 public:
  // Validates `g`; `output_limit_mm_per_s` = u_max, `period_s` = T.
  void configure(const PidGains& g, double output_limit_mm_per_s, double period_s);
  void reset() noexcept {
    integral_ = derivative_ = e_prev_ = last_error_ = 0.0;
    first_ = true;
    saturated_ = false;
  }
  // One tick. `extra_mm_per_s` is added to the command before the limit (a cross-coupled
  // correction); it takes part in the anti-windup like any other term.
  double update(double r_mm, double v_r, double a_r, double y_mm, double extra_mm_per_s = 0.0) noexcept {
    const double e = r_mm - y_mm;
    if (!first_) derivative_ = (g_.derivative_filter_s * derivative_ + g_.kd * (e - e_prev_)) / (g_.derivative_filter_s + T_);
    first_ = false;
    e_prev_ = e;
    last_error_ = e;
    const double friction = g_.friction_ff_mm_per_s * std::clamp(v_r / g_.friction_ff_band_mm_per_s, -1.0, 1.0);
    const double v = g_.velocity_ff * v_r + g_.acceleration_ff_s * a_r + friction + g_.kp_per_s * e + integral_ +
                     derivative_ + extra_mm_per_s;
    const double u = std::clamp(v, -u_max_, u_max_);
    saturated_ = u != v;
    if (g_.ki_per_s2 > 0)
      integral_ = std::clamp(integral_ + T_ * (g_.ki_per_s2 * e + (u - v) / tt_), -u_max_, u_max_);
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
  double integral_ = 0.0, derivative_ = 0.0, e_prev_ = 0.0, last_error_ = 0.0;
  bool first_ = true, saturated_ = false;
};

class PidController final : public Controller {
 public:
  // `name` is what name() returns ("p" or "pid": the factory's kind); it must outlive this.
  explicit PidController(const char* name = "pid") : name_(name) {}
  void configure(const std::array<PidGains, kAxes>& gains, const std::array<double, kAxes>& output_limit_mm_per_s,
                 double period_s) {
    for (int i = 0; i < kAxes; ++i) axis_[i].configure(gains[i], output_limit_mm_per_s[i], period_s);
  }
  const char* name() const override { return name_; }
  void reset() override {
    for (AxialPid& a : axis_) a.reset();
  }
  void update(const ControllerInput& in, ControllerOutput& out) noexcept override {
    for (int i = 0; i < kAxes; ++i)
      out.u_mm_per_s[i] = axis_[i].update(in.r_mm[i], in.v_ff_mm_per_s[i], in.a_ff_mm_per_s2[i], in.y_mm[i]);
  }
  double following_error_mm(int axis) const noexcept override { return axis_[axis].last_error_mm(); }
  bool following_error_exceeded(int axis) const noexcept override { return axis_[axis].following_error_exceeded(); }
  bool saturated(int axis) const noexcept override { return axis_[axis].saturated(); }
  const AxialPid& axis(int i) const { return axis_[i]; }

 private:
  const char* name_;
  std::array<AxialPid, kAxes> axis_{};
};

}  // namespace machplan::control
