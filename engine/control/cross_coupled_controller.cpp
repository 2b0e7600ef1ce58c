#include "engine/control/cross_coupled_controller.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/control/internal/setting_check.h"

namespace machplan::control {

namespace {
// Curvature beyond this (a radius under 0.1 mm) is a corner, not a contour the quadratic
// model describes; the estimate keeps the direction and caps the curvature.
constexpr double kMaxCurvaturePerMm = 10.0;
constexpr double kRestSpeedMmPerS = 1e-6;
}  // namespace

void ContourGains::validate() const {
  const auto check = [](double v, const char* field) {
    require_field(finite_nonneg(v), field, v, "must be finite and >= 0");
  };
  check(kp_per_s, "kp_per_s");
  check(ki_per_s2, "ki_per_s2");
  check(kd, "kd");
}

ContourEstimate estimate_contour_error(const ControllerInput& in) noexcept {
  ContourEstimate est;
  const double ex = in.r_mm[0] - in.y_mm[0], ey = in.r_mm[1] - in.y_mm[1];
  double sin_t = 0, cos_t = 0, kappa = 0;
  bool have_geometry = false;
  if (in.path) {
    const Segment& s = *in.path;
    if (!s.is_arc()) {
      const double dx = s.end.x() - s.start.x(), dy = s.end.y() - s.start.y();
      const double len = std::hypot(dx, dy);
      if (len > 1e-9) {
        cos_t = dx / len;
        sin_t = dy / len;
        // Signed distance from y to the segment's line (the line through r when r is on it).
        est.eps_mm = (in.y_mm[0] - s.start.x()) * sin_t - (in.y_mm[1] - s.start.y()) * cos_t;
        have_geometry = true;
      }
    } else {
      const double rx = in.r_mm[0] - s.center.x(), ry = in.r_mm[1] - s.center.y();
      const double rho = std::hypot(rx, ry);
      if (rho > 1e-9) {
        const double turn = s.sweep >= 0 ? 1.0 : -1.0;  // +1 turning left (counter-clockwise)
        cos_t = -turn * ry / rho;                        // tangent at r
        sin_t = turn * rx / rho;
        kappa = std::min(1.0 / rho, kMaxCurvaturePerMm) * turn;
        const double dist = std::hypot(in.y_mm[0] - s.center.x(), in.y_mm[1] - s.center.y());
        est.eps_mm = turn * (dist - s.radius);  // the radius error, outward positive when turning left
        have_geometry = true;
      }
    }
    if (have_geometry) {
      est.cx = sin_t - kappa * ex / 2;
      est.cy = cos_t + kappa * ey / 2;
      est.valid = true;
      return est;
    }
  }
  // No path: the reference's own direction and curvature.
  const double vx = in.v_ff_mm_per_s[0], vy = in.v_ff_mm_per_s[1];
  const double speed = std::hypot(vx, vy);
  if (!(speed > kRestSpeedMmPerS)) return est;
  cos_t = vx / speed;
  sin_t = vy / speed;
  kappa = (vx * in.a_ff_mm_per_s2[1] - vy * in.a_ff_mm_per_s2[0]) / (speed * speed * speed);
  kappa = std::clamp(kappa, -kMaxCurvaturePerMm, kMaxCurvaturePerMm);
  est.cx = sin_t - kappa * ex / 2;
  est.cy = cos_t + kappa * ey / 2;
  est.eps_mm = -ex * est.cx + ey * est.cy;
  est.valid = true;
  return est;
}

void CrossCoupledController::configure(const std::array<PidGains, kAxes>& axial, const ContourGains& contour,
                                       const std::array<double, kAxes>& output_limit_mm_per_s, double period_s,
                                       const std::array<ObserverModel, kAxes>& observer) {
  contour.validate();
  double u_max = 0;
  for (int i = 0; i < kAxes; ++i) {
    axis_[i].configure(axial[i], output_limit_mm_per_s[i], period_s, observer[i]);
    u_max = std::max(u_max, output_limit_mm_per_s[i]);
  }
  w_ = contour;
  T_ = period_s;
  s_max_ = contour.ki_per_s2 > 0 ? u_max / contour.ki_per_s2 : 0.0;
  reset();
}

void CrossCoupledController::reset() {
  for (AxialPid& a : axis_) a.reset();
  sum_ = eps_prev_ = correction_ = 0.0;
  first_ = true;
  est_ = {};
}

void CrossCoupledController::update(const ControllerInput& raw, ControllerOutput& out) noexcept {
  // What both loops act on: the axial observers' estimates or predictions (pid_controller.h).
  observed_input(axis_, raw, in_);
  const ControllerInput& in = in_;
  est_ = estimate_contour_error(in);
  double u_c = 0.0;
  if (est_.valid) {
    const double eps = est_.eps_mm;
    const double de = first_ ? 0.0 : (eps - eps_prev_) / T_;
    first_ = false;
    eps_prev_ = eps;
    u_c = w_.kp_per_s * eps + w_.ki_per_s2 * sum_ + w_.kd * de;
  } else {
    first_ = true;  // the contour loop restarts when motion resumes
  }
  correction_ = u_c;
  const std::array<double, kAxes> extra{-est_.cx * u_c, est_.cy * u_c};
  bool any_saturated = false;
  for (int i = 0; i < kAxes; ++i) {
    out.u_mm_per_s[i] = axis_[i].update(in.r_mm[i], in.v_ff_mm_per_s[i], in.a_ff_mm_per_s2[i], in.y_mm[i], extra[i]);
    any_saturated = any_saturated || axis_[i].saturated();
  }
  if (est_.valid && w_.ki_per_s2 > 0 && !any_saturated) sum_ = std::clamp(sum_ + T_ * est_.eps_mm, -s_max_, s_max_);
}

}  // namespace machplan::control
