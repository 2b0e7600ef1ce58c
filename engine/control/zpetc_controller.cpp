#include "engine/control/zpetc_controller.h"

#include <algorithm>
#include <complex>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::control {

namespace {

using Poly = std::vector<double>;
using CPoly = std::vector<std::complex<double>>;

CPoly multiply(const CPoly& p, const CPoly& q) {
  CPoly r(p.size() + q.size() - 1, 0.0);
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < q.size(); ++j) r[i + j] += p[i] * q[j];
  return r;
}

Poly multiply(const Poly& p, const Poly& q) {
  Poly r(p.size() + q.size() - 1, 0.0);
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < q.size(); ++j) r[i + j] += p[i] * q[j];
  return r;
}

Poly real_part(const CPoly& p) {
  Poly r(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) r[i] = p[i].real();
  return r;
}

// The zeros z_i of b0 + b1 z^-1 + ... + bm z^-m, i.e. the roots of b0 z^m + ... + bm.
std::vector<std::complex<double>> zeros_of(const Poly& b) {
  const int m = static_cast<int>(b.size()) - 1;
  if (m < 1) return {};
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(m, m);
  for (int j = 0; j < m; ++j) companion(0, j) = -b[j + 1] / b[0];
  for (int i = 1; i < m; ++i) companion(i, i - 1) = 1.0;
  const Eigen::VectorXcd ev = companion.eigenvalues();
  return {ev.data(), ev.data() + m};
}

}  // namespace

void ZpetcAxisOptions::validate() const {
  require_field(std::isfinite(kp_per_s) && kp_per_s > 0, "kp_per_s", kp_per_s, "must be > 0");
  require_field(std::isfinite(model_time_constant_s) && model_time_constant_s > 0, "model_time_constant_s",
                model_time_constant_s, "must be > 0 s");
  require_field(std::isfinite(model_gain) && model_gain > 0, "model_gain", model_gain, "must be > 0");
  require_field(latency_ticks >= 0 && latency_ticks <= 100, "latency_ticks", latency_ticks, "must be 0 .. 100");
  require_field(cancel_radius >= 0 && cancel_radius <= 1, "cancel_radius", cancel_radius, "must be in [0, 1]");
  require_field(std::isfinite(following_error_limit_mm) && following_error_limit_mm > 0, "following_error_limit_mm",
                following_error_limit_mm, "must be > 0 mm");
}

ZpetcDesign design_zpetc(const Poly& b_in, const Poly& a, int d, double cancel_radius) {
  Poly b = b_in;
  while (b.size() > 1 && b.back() == 0.0) b.pop_back();
  if (b.empty()) throw InputError::field("b", "the polynomial is empty");
  if (a.empty()) throw InputError::field("a", "the polynomial is empty");
  require_field(b[0] != 0.0 && std::isfinite(b[0]), "b", b[0], "is B's first coefficient: must be finite and non-zero");
  require_field(a[0] != 0.0, "a", a[0], "is A's first coefficient: must be non-zero");
  require_field(d >= 0, "d", d, "is the delay: must be >= 0");
  require_field(cancel_radius >= 0 && cancel_radius <= 1, "cancel_radius", cancel_radius, "must be in [0, 1]");
  CPoly ba{b[0]}, bu{1.0};
  ZpetcDesign z;
  for (const std::complex<double>& zi : zeros_of(b)) {
    const CPoly factor{1.0, -zi};
    if (std::abs(zi) < cancel_radius) {
      ba = multiply(ba, factor);
      ++z.cancelled_zeros;
    } else {
      bu = multiply(bu, factor);
      ++z.uncancelled_zeros;
    }
  }
  const Poly bu_r = real_part(bu);
  double bu1 = 0;
  for (double c : bu_r) bu1 += c;
  if (!(std::abs(bu1) > 1e-12)) throw InputError::field("b", "B has a zero at z = 1 (no DC gain to normalise)");
  Poly bu_star(bu_r.rbegin(), bu_r.rend());
  z.numerator = multiply(a, bu_star);
  for (double& c : z.numerator) c /= bu1 * bu1;
  z.denominator = real_part(ba);
  z.lead = d + z.uncancelled_zeros;
  return z;
}

DiscreteModel proportional_loop_model(double kp, double tau, double g, double T, int latency) {
  require_field(kp > 0 && std::isfinite(kp), "kp_per_s", kp, "must be > 0");
  require_field(tau > 0 && std::isfinite(tau), "tau_s", tau, "must be > 0");
  require_field(g > 0 && std::isfinite(g), "gain", g, "must be > 0");
  require_field(T > 0 && std::isfinite(T), "period_s", T, "must be > 0");
  require_field(latency >= 0, "latency_ticks", latency, "must be >= 0");
  const double a = std::exp(-T / tau);
  const double b1 = T - tau * (1 - a), b2 = tau * (1 - a) - a * T;
  DiscreteModel m;
  m.d = latency + 1;
  m.b = {kp * g * b1, kp * g * b2};
  m.a.assign(static_cast<std::size_t>(std::max(3, m.d + 2)), 0.0);
  const Poly open = multiply(Poly{1.0, -1.0}, Poly{1.0, -a});
  for (std::size_t i = 0; i < open.size(); ++i) m.a[i] += open[i];
  m.a[m.d] += m.b[0];
  m.a[m.d + 1] += m.b[1];
  return m;
}

void ZpetcController::configure(const std::array<ZpetcAxisOptions, kAxes>& axes,
                                const std::array<double, kAxes>& output_limit_mm_per_s, double period_s) {
  require_field(period_s > 0 && std::isfinite(period_s), "period_s", period_s, "must be > 0 s");
  for (int i = 0; i < kAxes; ++i) {
    const ZpetcAxisOptions& o = axes[i];
    o.validate();
    require_field(output_limit_mm_per_s[i] > 0 && std::isfinite(output_limit_mm_per_s[i]),
                  fmt::format("output_limit_mm_per_s[{}]", i), output_limit_mm_per_s[i], "must be > 0 mm/s");
    const DiscreteModel m = proportional_loop_model(o.kp_per_s, o.model_time_constant_s, o.model_gain, period_s,
                                                    o.latency_ticks);
    ZpetcDesign z = design_zpetc(m.b, m.a, m.d, o.cancel_radius);
    const int history = static_cast<int>(z.numerator.size()) - z.lead;
    if (static_cast<int>(z.numerator.size()) > kMaxTaps || static_cast<int>(z.denominator.size()) > kMaxTaps ||
        history > kMaxTaps)
      throw InputError::field("latency_ticks", fmt::format("{} is too long: the filter of axis {} needs {} taps (at most {})",
                                                           o.latency_ticks, i, z.numerator.size(), kMaxTaps));
    Axis& a = ax_[i];
    a.opt = o;
    a.u_max = output_limit_mm_per_s[i];
    a.n_num = static_cast<int>(z.numerator.size());
    a.n_den = static_cast<int>(z.denominator.size());
    a.lead = z.lead;
    std::copy(z.numerator.begin(), z.numerator.end(), a.num.begin());
    std::copy(z.denominator.begin(), z.denominator.end(), a.den.begin());
    design_[i] = std::move(z);
  }
  T_ = period_s;
  reset();
}

void ZpetcController::reset() {
  for (Axis& a : ax_) {
    a.r_hist.fill(0.0);
    a.out_hist.fill(0.0);
    a.r0 = a.error = a.r_star = 0.0;
    a.first = true;
    a.saturated = false;
  }
}

void ZpetcController::update(const ControllerInput& in, ControllerOutput& out) noexcept {
  for (int i = 0; i < kAxes; ++i) {
    Axis& a = ax_[i];
    const double r = in.r_mm[i];
    if (a.first) {
      a.r0 = r;  // the past is taken as rest at the first setpoint
      a.first = false;
    }
    for (int j = kMaxTaps - 1; j > 0; --j) a.r_hist[j] = a.r_hist[j - 1];
    a.r_hist[0] = r - a.r0;
    double acc = 0.0;
    for (int j = 0; j < a.n_num; ++j) {
      const int ahead = a.lead - j;  // periods after now
      double x;
      if (ahead <= 0) {
        x = a.r_hist[-ahead];
      } else if (ahead <= in.preview_ticks) {
        x = in.r_preview_mm[ahead - 1][i] - a.r0;
      } else {
        const double h = ahead * T_;
        x = r + h * in.v_ff_mm_per_s[i] + 0.5 * h * h * in.a_ff_mm_per_s2[i] - a.r0;
      }
      acc += a.num[j] * x;
    }
    for (int j = 1; j < a.n_den; ++j) acc -= a.den[j] * a.out_hist[j - 1];
    const double delta = acc / a.den[0];
    for (int j = kMaxTaps - 1; j > 0; --j) a.out_hist[j] = a.out_hist[j - 1];
    a.out_hist[0] = delta;
    a.r_star = a.r0 + delta;
    a.error = r - in.y_mm[i];
    const double v = a.opt.kp_per_s * (a.r_star - in.y_mm[i]);
    const double u = std::clamp(v, -a.u_max, a.u_max);
    a.saturated = u != v;
    out.u_mm_per_s[i] = u;
  }
}

}  // namespace machplan::control
