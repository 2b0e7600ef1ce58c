#include "engine/control/fuzzy_controller.h"

#include <algorithm>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::control {

namespace {

// Output singletons of the sets NB .. PB (see the header: denser away from zero).
constexpr std::array<double, 7> kOutput{-1.0, -0.75, -0.45, 0.0, 0.45, 0.75, 1.0};

// The two sets of an input in [-1, 1] that are non-zero: the lower one's index (0 .. 5 for
// NB .. PM) and the upper one's membership (the lower one's is 1 - that).
void fuzzify(double x, int& lower, double& upper_membership) noexcept {
  const double p = (std::clamp(x, -1.0, 1.0) + 1.0) * 3.0;  // 0 .. 6: position among the centres
  lower = std::min(static_cast<int>(p), 5);
  upper_membership = p - lower;
}

}  // namespace

double fuzzy_surface(double x1, double x2) noexcept {
  int i = 0, j = 0;
  double m1 = 0, m2 = 0;
  fuzzify(x1, i, m1);
  fuzzify(x2, j, m2);
  const std::array<double, 2> w1{1.0 - m1, m1}, w2{1.0 - m2, m2};
  double f = 0.0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      const int rule = std::clamp((i + a - 3) + (j + b - 3), -3, 3);  // C_{i+j}
      f += w1[a] * w2[b] * kOutput[rule + 3];
    }
  return f;  // the weights sum to 1: the weighted average needs no division
}

void FuzzyGains::validate() const {
  const auto require = [](bool ok, const char* field, double v, const char* rule) { require_field(ok, field, v, rule); };
  require(std::isfinite(ke_per_mm) && ke_per_mm > 0, "ke_per_mm", ke_per_mm, "must be > 0");
  require(std::isfinite(kde_s_per_mm) && kde_s_per_mm >= 0, "kde_s_per_mm", kde_s_per_mm, "must be >= 0");
  require(std::isfinite(ku_mm_per_s) && ku_mm_per_s > 0, "ku_mm_per_s", ku_mm_per_s, "must be > 0");
  require(std::isfinite(velocity_ff) && velocity_ff >= 0 && velocity_ff <= 3, "velocity_ff", velocity_ff,
          "must be in [0, 3]");
  require(std::isfinite(acceleration_ff_s) && acceleration_ff_s >= 0 && acceleration_ff_s <= 1, "acceleration_ff_s",
          acceleration_ff_s, "must be in [0, 1] s");
  require(std::isfinite(ki_per_s) && ki_per_s >= 0, "ki_per_s", ki_per_s, "must be >= 0");
  require(std::isfinite(following_error_limit_mm) && following_error_limit_mm > 0, "following_error_limit_mm",
          following_error_limit_mm, "must be > 0");
}

void FuzzyController::configure(const std::array<FuzzyGains, kAxes>& gains,
                                const std::array<double, kAxes>& output_limit_mm_per_s, double period_s) {
  require_field(period_s > 0 && std::isfinite(period_s), "period_s", period_s, "must be > 0 s");
  for (int i = 0; i < kAxes; ++i) {
    gains[i].validate();
    require_field(output_limit_mm_per_s[i] > 0 && std::isfinite(output_limit_mm_per_s[i]),
                  fmt::format("output_limit_mm_per_s[{}]", i), output_limit_mm_per_s[i], "must be > 0 mm/s");
    ax_[i].g = gains[i];
    ax_[i].u_max = output_limit_mm_per_s[i];
  }
  T_ = period_s;
  reset();
}

void FuzzyController::reset() {
  for (Axis& a : ax_) {
    a.error = a.e_prev = a.integral = 0.0;
    a.first = true;
    a.saturated = false;
  }
}

void FuzzyController::update(const ControllerInput& in, ControllerOutput& out) noexcept {
  for (int i = 0; i < kAxes; ++i) {
    Axis& a = ax_[i];
    const double e = in.r_mm[i] - in.y_mm[i];
    const double de = a.first ? 0.0 : (e - a.e_prev) / T_;
    a.first = false;
    a.e_prev = e;
    a.error = e;
    const double fu = a.g.ku_mm_per_s * fuzzy_surface(a.g.ke_per_mm * e, a.g.kde_s_per_mm * de);
    const double v = a.g.velocity_ff * in.v_ff_mm_per_s[i] + a.g.acceleration_ff_s * in.a_ff_mm_per_s2[i] + fu + a.integral;
    const double u = std::clamp(v, -a.u_max, a.u_max);
    a.saturated = std::abs(v) >= a.u_max;  // at the limit: the fuzzy output alone may reach it exactly
    const bool pushing = (v >= a.u_max && fu > 0) || (v <= -a.u_max && fu < 0);
    if (a.g.ki_per_s > 0 && !pushing)
      a.integral = std::clamp(a.integral + T_ * a.g.ki_per_s * fu, -a.u_max, a.u_max);
    out.u_mm_per_s[i] = u;
  }
}

}  // namespace machplan::control
