// Zero phase error tracking controller (Tomizuka, "Zero Phase Error Tracking Algorithm for
// Digital Control"): a feed-forward filter that inverts the closed position loop of each axis,
// so that the measured position follows the setpoint with no phase lag, fed with setpoints
// the source gives ahead of time.
//
// Closed loop being inverted. Each axis runs a proportional loop u = Kp (r* - y) around the
// drive of the machine model (models/axis/plant.h): a first-order velocity loop of time
// constant tau and gain g driving an integrator, behind L = command + reading latency periods.
// Discretised exactly with a zero-order hold at period T (a = exp(-T/tau)):
//
//     P(z^-1)  = g (b1 z^-1 + b2 z^-2) / ((1 - z^-1)(1 - a z^-1)),
//                b1 = T - tau (1 - a),  b2 = tau (1 - a) - a T
//     G(z^-1)  = Kp z^-L P / (1 + Kp z^-L P) = z^-d B(z^-1) / A(z^-1),   d = L + 1,
//     B        = Kp g (b1 + b2 z^-1),
//     A        = (1 - z^-1)(1 - a z^-1) + Kp g z^-d (b1 + b2 z^-1).
//
// The zero of B (z = -b2 / b1) lies on the negative real axis, near -1 when T is short
// against tau: inside the unit circle but so close to it that inverting it would ring at the
// Nyquist frequency. design_zpetc() handles any B:
//
//     B = B_a B_u       B_a: the zeros with |z| < cancel_radius (cancelled),
//                       B_u: the others (outside the unit circle, on it, or near it), s of them
//     ZPETC(z^-1) = A(z^-1) B_u*(z^-1) / (B_a(z^-1) B_u(1)^2),  applied to r[k + d + s]
//     B_u*(z^-1)  = B_u with its coefficients reversed (the zeros mirrored in the unit circle)
//
// so that G ZPETC = B_u(z^-1) B_u(z) / B_u(1)^2: real and positive at every frequency (zero
// phase error) and exactly 1 at DC. The uncancelled zeros' gain error remains (a slight
// attenuation of fast setpoint changes), never their phase.
//
// Preview. The filter needs r up to d + s periods ahead. ControllerInput::r_preview_mm gives
// up to kMaxPreviewTicks of them (the planned source fills it); when the source gives fewer,
// the rest is extrapolated from r with the feed-forward velocity and acceleration
// (r + h v + h^2 a / 2), a second-order guess that is exact on constant-acceleration motion.
//
// Control law of one axis per period (r* the filter's output, the loop's reference):
//
//     r*[k] = (sum_j f_j r[k + d + s - j] - sum_{i>=1} beta_i r*[k-i]) / beta_0
//     u[k]  = clamp(Kp (r*[k] - y[k]), -u_max, u_max)
//
// f = A B_u* / B_u(1)^2, beta = B_a. The filter runs on r - r0 (r0 the first setpoint after
// reset) so a machine at rest on its setpoint gets exactly zero. following_error_mm() is
// r - y, the error against the path, not against r*.
//
// Without integral action the loop does not reject disturbances: under friction the ZPETC
// loses to controllers with an integrator on lines (Koren's comparison), while on circles its
// phase-free tracking is the point.
//
// Real time: update() is O(filter length) with fixed-size buffers (at most kMaxTaps taps),
// allocates nothing and never throws; all design work happens in configure().
#pragma once

#include <cmath>
#include <vector>

#include "engine/control/controller.h"

namespace machplan::control {

// A ZPETC for G(z^-1) = z^-d B(z^-1) / A(z^-1); polynomials in z^-1, constant term first.
struct ZpetcDesign {
  std::vector<double> numerator;    // f: applied to r[k + lead - j], j = 0 ..
  std::vector<double> denominator;  // beta = B_a: applied to r*[k - i], i = 0 ..
  int lead = 0;                     // d + s
  int cancelled_zeros = 0, uncancelled_zeros = 0;
};

// Throws InputError (naming the argument) when B or A is empty, B's leading coefficient is 0,
// d < 0, cancel_radius is not in [0, 1], or B has a zero at z = 1.
ZpetcDesign design_zpetc(const std::vector<double>& b, const std::vector<double>& a, int d, double cancel_radius);

// The closed loop of the file comment: {B, A, d}.
struct DiscreteModel {
  std::vector<double> b, a;
  int d = 0;
};
// Throws InputError (naming the argument) for non-positive kp, tau, gain or period, or
// latency < 0.
DiscreteModel proportional_loop_model(double kp_per_s, double tau_s, double gain, double period_s, int latency_ticks);

struct ZpetcAxisOptions {
  double kp_per_s = 150.0;              // the feedback loop's gain
  double model_time_constant_s = 0.004; // tau of the drive model
  double model_gain = 1.0;              // g of the drive model
  int latency_ticks = 2;                // command + reading latency
  double cancel_radius = 0.9;           // zeros at least this far from 0 are not cancelled: [0, 1]
  double following_error_limit_mm = 2.0;
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

class ZpetcController final : public Controller {
 public:
  static constexpr int kMaxTaps = 24;
  // Designs each axis' filter. Throws InputError (bad options, or a filter longer than
  // kMaxTaps).
  void configure(const std::array<ZpetcAxisOptions, kAxes>& axes, const std::array<double, kAxes>& output_limit_mm_per_s,
                 double period_s);
  const char* name() const override { return "zpetc"; }
  void reset() override;
  void update(const ControllerInput& in, ControllerOutput& out) noexcept override;
  double following_error_mm(int axis) const noexcept override { return ax_[axis].error; }
  bool following_error_exceeded(int axis) const noexcept override {
    return std::abs(ax_[axis].error) > ax_[axis].opt.following_error_limit_mm;
  }
  bool saturated(int axis) const noexcept override { return ax_[axis].saturated; }
  const ZpetcDesign& design(int axis) const { return design_[axis]; }
  double last_reference_mm(int axis) const noexcept { return ax_[axis].r_star; }  // r*

 private:
  struct Axis {
    ZpetcAxisOptions opt;
    int n_num = 0, n_den = 0, lead = 0;
    std::array<double, kMaxTaps> num{}, den{};
    std::array<double, kMaxTaps> r_hist{};     // r - r0, newest first (r_hist[0] = now)
    std::array<double, kMaxTaps> out_hist{};   // r* - r0, newest first (out_hist[0] = last)
    double r0 = 0.0, u_max = 1.0, error = 0.0, r_star = 0.0;
    bool first = true, saturated = false;
  };
  std::array<Axis, kAxes> ax_{};
  std::array<ZpetcDesign, kAxes> design_{};
  double T_ = 1e-3;
};

}  // namespace machplan::control
