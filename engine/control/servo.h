// The position loop of one axis: PID on the following error plus velocity and acceleration
// feed-forward, with output saturation, anti-windup and a following-error limit.
//
// Control law, evaluated once per servo period T at tick k:
//
//     e[k] = r[k] - y[k]                                 following error, mm
//     u[k] = Kvff v_r[k] + Kaff a_r[k] + u_b[k]          feed-forward, mm/s
//          + Kp e[k] + I[k] + Kd (e[k] - e[k-1]) / T     feedback, mm/s
//     I[k+1] = I[k] + Ki T e[k]    unless u[k] is saturated and e[k] pushes further into
//                                   the limit (conditional integration), and |I| <= u_max
//     output = clamp(u[k], -u_max, +u_max)
//
// r, v_r, a_r are the setpoint's position, velocity and acceleration; y is the measured
// position. u is a SPEED COMMAND in mm/s as the drive understands it at its nominal scaling;
// the executor turns it into a DAC code. With a first-order drive (speed loop time constant
// tau, gain g) the ideal feed-forward is Kvff = 1/g and Kaff = tau/g: then the drive follows
// the setpoint exactly and the PID only fights disturbances. Our machines use the drive's
// NOMINAL gain (Kvff = 1): a real gain of 0.7 then leaves 30 % of the speed to the integral
// term, which takes it up within a few 1/Ki; the accuracy tests run this way on purpose.
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
  double velocity_ff = 1.0;             // Kvff, dimensionless
  double acceleration_ff_s = 0.0;       // Kaff, s
  double following_error_limit_mm = 2.0;
  double backlash_compensation_mm = 0.0;
  double backlash_compensation_time_s = 0.004;
  // Throws std::invalid_argument naming field, value and rule.
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
    integral_ = 0.0;
    e_prev_ = 0.0;
    first_ = true;
    last_error_ = 0.0;
    last_output_ = 0.0;
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

    const double u_ff = g_.velocity_ff * v_r + g_.acceleration_ff_s * a_r + ub;
    const double u_unsat = u_ff + g_.kp_per_s * e + integral_ + g_.kd * de;
    const double u = std::clamp(u_unsat, -u_max_, u_max_);
    const bool pushing_into_limit = (u_unsat > u_max_ && e > 0) || (u_unsat < -u_max_ && e < 0);
    if (!pushing_into_limit) integral_ = std::clamp(integral_ + g_.ki_per_s2 * T_ * e, -u_max_, u_max_);
    last_output_ = u;
    return u;
  }

  double last_error_mm() const { return last_error_; }
  double last_output_mm_per_s() const { return last_output_; }
  double integral_mm_per_s() const { return integral_; }
  bool following_error_exceeded() const { return std::abs(last_error_) > g_.following_error_limit_mm; }
  const ServoGains& gains() const { return g_; }

 private:
  ServoGains g_;
  double u_max_ = 1.0, T_ = 1e-3;
  double integral_ = 0.0, e_prev_ = 0.0, last_error_ = 0.0, last_output_ = 0.0;
  bool first_ = true;
  int direction_ = 0;
  double comp_left_mm_ = 0.0;
};

}  // namespace machplan::control
