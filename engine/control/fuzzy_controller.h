// Fuzzy-logic axial controller (after Jee and Koren, "Fuzzy Logic Controller for Friction
// Compensation in Feed Drives"): two inputs, the following error E and its change dE, seven
// triangular sets on each, a 7 x 7 rule base, weighted-average defuzzification.
//
// One axis, once per servo period T:
//
//     e[k]  = r[k] - y[k],         de[k] = (e[k] - e[k-1]) / T     (0 on the first tick)
//     x1    = clamp(Ke e, -1, 1),  x2 = clamp(Kde de, -1, 1)       scaling to the universe
//     mu_i(x) = max(0, 1 - 3 |x - i/3|),  i = -3 .. 3              NB NM NS ZE PS PM PB
//     rule (i, j): IF x1 is A_i AND x2 is B_j THEN U is C_{clamp(i + j, -3, 3)}
//     F     = sum_ij mu_i(x1) mu_j(x2) c(i + j) / sum_ij mu_i(x1) mu_j(x2)
//            (product AND; the triangles sum to 1, so the denominator is 1)
//     u[k]  = clamp(Kvff v_r + Ta a_r + Ku F + I[k], -u_max, u_max)
//     I[k+1] = clamp(I[k] + T Ki Ku F, -u_max, u_max)   (optional, Ki = 0 by default; frozen
//             while u is at its limit and F pushes further: conditional integration)
//
// Output singletons c(-3 .. 3) = -1, -0.75, -0.45, 0, 0.45, 0.75, 1: closer together away from
// zero, so the controller's slope is steepest for small errors (1.35 Ku Ke per mm near zero
// against Ku Ke on average). That is the friction compensation: a small error at a reversal,
// where Coulomb friction holds the axis, already draws a large share of the command, while
// large errors (a start, a corner) are met with a gentler slope and a bounded output Ku.
// The rule base is the usual diagonal one: the output grows with E + dE, so dE > 0 (error
// growing) adds command and dE < 0 (error shrinking) takes it back, like a PD whose gains fall
// off at the edges of the universe.
//
// Tunable gains: the input scalings Ke (1/mm) and Kde (s/mm), the output scaling Ku (mm/s), the
// feed-forward options Kvff and Ta, and Ki (1/s), which integrates the fuzzy output (a fuzzy
// PD + I: the integrator's rate is bounded by Ku Ki because F is, so a stuck axis winds it up
// far less than a PID's integral of the raw error). Small-signal equivalents: Kp = 1.35 Ku Ke,
// Kd = 1.35 Ku Kde, Ki_pid = Ki Kp.
//
// Real time: update() evaluates at most 2 x 2 rules per axis (only two sets of each input are
// non-zero), O(1), allocates nothing and never throws.
#pragma once

#include <array>
#include <cmath>

#include "engine/control/controller.h"

namespace machplan::control {

struct FuzzyGains {
  double ke_per_mm = 0.1;          // Ke
  double kde_s_per_mm = 2e-4;      // Kde
  double ku_mm_per_s = 1000.0;     // Ku
  double velocity_ff = 0.0;        // Kvff
  double acceleration_ff_s = 0.0;  // Ta, s
  double ki_per_s = 0.0;           // Ki: integral of the fuzzy output, 1/s
  double following_error_limit_mm = 2.0;
  // Throws InputError naming field, value and rule.
  void validate() const;
};

// The normalised fuzzy map F(x1, x2) in [-1, 1] of the file comment (inputs clamped to [-1, 1]).
double fuzzy_surface(double x1, double x2) noexcept;

class FuzzyController final : public Controller {
 public:
  void configure(const std::array<FuzzyGains, kAxes>& gains, const std::array<double, kAxes>& output_limit_mm_per_s,
                 double period_s);
  const char* name() const override { return "flc"; }
  void reset() override;
  void update(const ControllerInput& in, ControllerOutput& out) noexcept override;
  double following_error_mm(int axis) const noexcept override { return ax_[axis].error; }
  bool following_error_exceeded(int axis) const noexcept override {
    return std::abs(ax_[axis].error) > ax_[axis].g.following_error_limit_mm;
  }
  bool saturated(int axis) const noexcept override { return ax_[axis].saturated; }

 private:
  struct Axis {
    FuzzyGains g;
    double u_max = 1.0, error = 0.0, e_prev = 0.0, integral = 0.0;
    bool first = true, saturated = false;
  };
  std::array<Axis, kAxes> ax_{};
  double T_ = 1e-3;
};

}  // namespace machplan::control
