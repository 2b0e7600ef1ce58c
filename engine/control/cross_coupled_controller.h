// Cross-coupled contour controller (Koren, "Cross-Coupled Biaxial Computer Control for
// Manufacturing Systems"; the variable-gain form of Koren and Lo): axial loops on X and Y plus
// a loop on the CONTOUR error, the error component normal to the path, whose correction is
// shared between the axes by gains that follow the path's direction and curvature.
//
// Contour error model, with E = r - y the axial errors, theta the path's direction at the
// reference point r and kappa its signed curvature (+1/rho turning left, -1/rho turning right,
// 0 on a line):
//
//     Cx = sin(theta) - kappa Ex / 2,     Cy = cos(theta) + kappa Ey / 2
//     eps_model = -Ex Cx + Ey Cy
//
// eps is positive when the tool lies to the right of the direction of travel. On a line the
// model is exact (the signed distance from y to the line through r); on a circle it is the
// radius error |y - c| - rho to second order in E. The controller estimates eps in real time
// from the path and uses the model's Cx, Cy to distribute the correction:
//
//     line  (ControllerInput::path a line): eps = signed distance from y to the segment's line;
//           theta = the segment's direction, kappa = 0;
//     arc   (path an arc of centre c, radius rho): eps = +-(|y - c| - rho) (+ turning left),
//           the radius error; theta = the tangent at r's angle about c, kappa = +-1/rho;
//     none  (no path given): theta and kappa of the reference's own motion,
//           theta = atan2(v_y, v_x), kappa = (v x a) / |v|^3 from the feed-forward velocity
//           and acceleration, and eps = eps_model; at rest (|v| < 1e-6 mm/s) there is no
//           contour loop. The bundled planned source gives the path (the segment the tool is
//           on: at a corner the error is measured against the piece being cut, not the one the
//           setpoint has reached); other sources need not.
//
// Control law, per servo period T (W a PID on eps, the axial loops AxialPid of
// pid_controller.h, normally P with optional feed-forward):
//
//     U[k]   = Wp eps[k] + Wi S[k] + Wd (eps[k] - eps[k-1]) / T,   S[k+1] = S[k] + T eps[k]
//     u_x[k] = axial_x(r_x, v_x, a_x, y_x) - Cx U[k]
//     u_y[k] = axial_y(r_y, v_y, a_y, y_y) + Cy U[k]
//
// The signs make the correction move the tool against eps (d eps = -(Cx^2 + Cy^2) U T per
// unit of loop gain). The correction enters each axial loop before its output limit, so it
// takes part in that loop's anti-windup; S is frozen while either axis is saturated
// (conditional integration) and bounded by the drive range over Wi.
//
// Real time: update() is O(1) (one sqrt, one atan2-free tangent from the path or the
// feed-forward), allocates nothing and never throws.
#pragma once

#include "engine/control/controller.h"
#include "engine/control/pid_controller.h"

namespace machplan::control {

struct ContourGains {
  double kp_per_s = 150.0;    // Wp: mm/s of correction per mm of contour error
  double ki_per_s2 = 0.0;     // Wi
  double kd = 0.0;            // Wd: mm/s per mm/s of contour error rate
  // Throws InputError naming field, value and rule.
  void validate() const;
};

// The contour error model of one instant (exposed for tests and for the trace).
struct ContourEstimate {
  double eps_mm = 0.0;    // estimated contour error (positive: tool right of the path)
  double cx = 0.0, cy = 0.0;
  bool valid = false;     // false at rest without a path: no contour loop
};

// Contour error and gains at reference r with measured y, following `in.path` when given,
// else the feed-forward velocity and acceleration (see the file comment).
ContourEstimate estimate_contour_error(const ControllerInput& in) noexcept;

class CrossCoupledController final : public Controller {
 public:
  // `observer`: the drive model of each axial loop's position observer (pid_controller.h);
  // the contour error is estimated from the observed positions too.
  void configure(const std::array<PidGains, kAxes>& axial, const ContourGains& contour,
                 const std::array<double, kAxes>& output_limit_mm_per_s, double period_s,
                 const std::array<ObserverModel, kAxes>& observer = {});
  const char* name() const override { return "ccc"; }
  void reset() override;
  void update(const ControllerInput& in, ControllerOutput& out) noexcept override;
  double following_error_mm(int axis) const noexcept override { return axis_[axis].last_error_mm(); }
  bool following_error_exceeded(int axis) const noexcept override { return axis_[axis].following_error_exceeded(); }
  bool saturated(int axis) const noexcept override { return axis_[axis].saturated(); }
  // The latest estimate and correction U, mm/s.
  const ContourEstimate& last_estimate() const noexcept { return est_; }
  double last_correction_mm_per_s() const noexcept { return correction_; }

 private:
  std::array<AxialPid, kAxes> axis_{};
  ControllerInput in_;  // what the loops act on this period
  ContourGains w_;
  double T_ = 1e-3, s_max_ = 0.0;
  double sum_ = 0.0, eps_prev_ = 0.0, correction_ = 0.0;
  bool first_ = true;
  ContourEstimate est_;
};

}  // namespace machplan::control
