// The position loop of one axis: PID on the following error plus velocity and acceleration
// feed-forward, with output saturation, anti-windup and a following-error limit.
//
// Control law, evaluated once per servo period T at tick k:
//
//     e[k] = r[k] - y[k]                                 following error, mm
//     u[k] = theta[k] (v_r[k] + Ta a_r[k]) + u_b[k]      feed-forward, mm/s
//          + Kp e[k] + I[k] + Kd (e[k] - e[k-1]) / T     feedback, mm/s
//     I[k+1] = I[k] + Ki T e[k]    unless u[k] is saturated and e[k] pushes further into
//                                   the limit (conditional integration), and |I| <= u_max
//     theta[k+1] = clamp(theta[k] + gamma T e[k] / v_r[k], 0.25, 4)   when |v_r| >= v_a,
//     theta[0] = Kvff
//     output = clamp(u[k], -u_max, +u_max)
//
// r, v_r, a_r are the setpoint's position, velocity and acceleration; y is the measured
// position. u is a SPEED COMMAND in mm/s as the drive understands it at its nominal scaling;
// the executor turns it into a DAC code. With a first-order drive (speed loop time constant
// tau, gain g) the ideal feed-forward is theta = 1/g and Ta = tau: then the drive follows
// the setpoint exactly and the PID only fights disturbances.
//
// Why theta adapts. Our machines start from the drive's NOMINAL gain (Kvff = 1). A real gain
// of 0.7 then leaves 30 % of the speed to the feedback. Left to the PID, that costs a
// following error of 0.3 v / (0.7 Kp) along the path, harmless on a line but not on a circle:
// the integral of a lag that turns with the path points outward (the integral of the tangent
// is the radius), and the loop answers with a radial error. So the feed-forward gain learns
// the drive's gain by the normalised gradient rule above (gamma = `ff_adaptation_per_s2`):
// e / v_r is positive while the axis lags a moving setpoint, and theta grows until the lag is
// gone. Under proportional feedback the lag is e = (1 - g theta) v_r / (g Kp), so theta
// approaches 1/g at the rate gamma / Kp whatever the speed; dividing by v_r (rather than
// multiplying, the plain MIT rule) makes both axes of a slanted line learn at the same pace,
// which keeps their lags in proportion and the tool on the line. It learns only while
// |v_r| >= v_a (`ff_adaptation_min_speed_mm_per_s`: below it friction, not gain, dominates
// the error) and the output is not saturated, and it keeps what it learned from one move to
// the next. gamma = 0 gives the fixed law with theta = Kvff. This is the paper's feed
// calibration factor found by the machine itself instead of by a stopwatch.
//
// u_b is backlash compensation: when the reference velocity changes sign the motor must cross
// the gap b before the load moves, so a pulse of extra speed carrying b (spread over
// `backlash_compensation_time_s`) is added in the new direction. It only needs b, which
// calibration measures; it is off when backlash_compensation_mm is 0.
//
// Following error: |e| > following_error_limit_mm is reported by `following_error_exceeded()`;
// the caller decides what to do (the executor stops the machine).
//
// Real time: update() is O(1), allocates nothing and never throws.
#pragma once

#include <algorithm>
#include <cmath>

namespace machplan::control {

struct ServoGains {
  double kp_per_s = 60.0;               // Kp: mm/s of command per mm of error
  double ki_per_s2 = 600.0;             // Ki: mm/s per (mm s)
  double kd = 0.0;                      // Kd: mm/s per mm/s of error rate
  double velocity_ff = 1.0;             // Kvff: theta's start, dimensionless
  double acceleration_ff_s = 0.0;       // Ta, s
  double ff_adaptation_per_s2 = 0.0;    // gamma, 1/s^2; 0: theta stays at Kvff
  double ff_adaptation_min_speed_mm_per_s = 10.0;  // v_a
  double following_error_limit_mm = 2.0;
  double backlash_compensation_mm = 0.0;
  double backlash_compensation_time_s = 0.004;
  // Throws InputError naming field, value and rule.
  void validate() const;
};

class AxisServo {
 public:
  // `output_limit_mm_per_s`: the command the DAC can express (u_max). `period_s`: T.
  void configure(const ServoGains& gains, double output_limit_mm_per_s, double period_s) {
    g_ = gains;
    u_max_ = output_limit_mm_per_s;
    T_ = period_s;
    reset();
  }
  void reset() {
    theta_ = g_.velocity_ff;
    integral_ = 0.0;
    e_prev_ = 0.0;
    first_ = true;
    last_error_ = 0.0;
    last_output_ = 0.0;
    saturated_ = false;
    direction_ = 0;
    comp_left_mm_ = 0.0;
  }

  // One servo tick; returns the saturated speed command, mm/s.
  double update(double r_mm, double v_r, double a_r, double y_mm) {
    const double e = r_mm - y_mm;
    const double de = first_ ? 0.0 : (e - e_prev_) / T_;
    first_ = false;
    e_prev_ = e;
    last_error_ = e;

    double ub = 0.0;
    if (g_.backlash_compensation_mm > 0.0) {
      const double deadband = 1e-3;  // mm/s: below this the reference is "at rest"
      const int dir = v_r > deadband ? 1 : (v_r < -deadband ? -1 : 0);
      if (dir != 0 && dir != direction_) {
        // A reversal (or the first motion, whose side of the gap is unknown: no pulse then).
        if (direction_ != 0) comp_left_mm_ = dir * g_.backlash_compensation_mm;
        direction_ = dir;
      }
      if (comp_left_mm_ != 0.0) {
        const double rate = g_.backlash_compensation_mm / g_.backlash_compensation_time_s;
        const double step = std::clamp(comp_left_mm_, -rate * T_, rate * T_);
        ub = step / T_;
        comp_left_mm_ -= step;
      }
    }

    const double u_ff = theta_ * (v_r + g_.acceleration_ff_s * a_r) + ub;
    const double u_unsat = u_ff + g_.kp_per_s * e + integral_ + g_.kd * de;
    const double u = std::clamp(u_unsat, -u_max_, u_max_);
    const bool saturated = u_unsat != u;
    const bool pushing_into_limit = (u_unsat > u_max_ && e > 0) || (u_unsat < -u_max_ && e < 0);
    if (!pushing_into_limit) integral_ = std::clamp(integral_ + g_.ki_per_s2 * T_ * e, -u_max_, u_max_);
    if (g_.ff_adaptation_per_s2 > 0 && !saturated && std::abs(v_r) >= g_.ff_adaptation_min_speed_mm_per_s)
      theta_ = std::clamp(theta_ + g_.ff_adaptation_per_s2 * T_ * e / v_r, 0.25, 4.0);
    last_output_ = u;
    saturated_ = saturated;
    return u;
  }

  double last_error_mm() const { return last_error_; }
  double last_output_mm_per_s() const { return last_output_; }
  double integral_mm_per_s() const { return integral_; }
  double feed_forward_gain() const { return theta_; }  // theta
  bool following_error_exceeded() const { return std::abs(last_error_) > g_.following_error_limit_mm; }
  bool saturated() const { return saturated_; }  // the last output was clipped to +-u_max
  const ServoGains& gains() const { return g_; }

 private:
  ServoGains g_;
  double u_max_ = 1.0, T_ = 1e-3;
  double theta_ = 1.0;
  double integral_ = 0.0, e_prev_ = 0.0, last_error_ = 0.0, last_output_ = 0.0;
  bool first_ = true, saturated_ = false;
  int direction_ = 0;
  double comp_left_mm_ = 0.0;
};

}  // namespace machplan::control
