#include "engine/executor/time_scale.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace machplan::executor {

namespace {
constexpr double kTiny = 1e-9;
constexpr double kMaxScale = 2.0;  // 200 %
}  // namespace

double TimeScale::stop_step(const motion::Trajectory& plan, double tau, const motion::Setpoint& at) noexcept {
  const double dt = lim_.period_s;
  const Eigen::Vector2d& v = at.velocity_mm_per_s;
  const Eigen::Vector2d& a = at.acceleration_mm_per_s2;
  const double vp = v.norm();
  if (vp <= kTiny) {  // the plan stands still here: so does the tool
    k_ = kd_ = u_ = ud_ = 0.0;
    return 0.0;
  }
  const Eigen::Vector2d t = v / vp;
  const double at_plan = a.dot(t);
  const Eigen::Vector2d normal = a - at_plan * t;  // grows with k^2
  if (!stopping_) {  // the tool's path speed and tangential acceleration as the hold comes
    stopping_ = true;
    u_ = vp * k_;
    ud_ = at_plan * k_ * k_ + vp * kd_;
  }
  // The stop's limits along the path: per axis, what the normal acceleration leaves of A,
  // and J, over the axis' share of the direction.
  double A = kInf, J = kInf;
  for (int i = 0; i < 2; ++i) {
    if (std::abs(t[i]) < kTiny) continue;
    A = std::min(A, std::max(0.0, lim_.max_acceleration_mm_per_s2[i] - std::abs(normal[i]) * k_ * k_) / std::abs(t[i]));
    J = std::min(J, lim_.max_jerk_mm_per_s3 / std::abs(t[i]));
  }
  // Bang-bang jerk: down to -A, hold, then back to 0 acceleration as the speed runs out.
  const double ramp_dv = ud_ < 0 ? ud_ * ud_ / (2 * J) : 0.0;
  const double j = u_ <= ramp_dv ? J : (ud_ > -A ? -J : 0.0);
  const double ud1 = std::clamp(ud_ + j * dt, -A, std::max(ud_, 0.0));
  const double u1 = std::max(0.0, u_ + 0.5 * (ud_ + ud1) * dt);
  // k such that the plan's speed where the tool will be, times k, is that speed (one more
  // sample of the plan there); never above k, so a plan that brakes by itself is followed.
  double k = 0.0;
  if (u1 > J * dt * dt) {
    const double k_est = std::min(k_, u1 / vp);
    motion::Setpoint ahead;
    plan.sample(tau + 0.5 * (k_ + k_est) * dt, ahead);
    const double vp1 = ahead.velocity_mm_per_s.norm();
    k = vp1 > kTiny ? std::min(k_, u1 / vp1) : 0.0;
  }
  u_ = k > 0.0 ? u1 : 0.0;
  ud_ = k > 0.0 ? ud1 : 0.0;
  kd_ = k > 0.0 ? (k - k_) / dt : 0.0;
  const double advance = 0.5 * (k_ + k) * dt;
  k_ = k;
  ceiling_ = 1.0;
  return advance;
}

double TimeScale::speed_ceiling(const motion::Setpoint& at) const noexcept {
  const Eigen::Vector2d& v = at.velocity_mm_per_s;
  double cv = kMaxScale;
  for (int i = 0; i < 2; ++i)
    if (std::abs(v[i]) > kTiny) cv = std::min(cv, lim_.margin * lim_.max_velocity_mm_per_s[i] / std::abs(v[i]));
  // On an arc the normal acceleration grows with k^2.
  const double an = at.acceleration_mm_per_s2.norm();
  if (an > kTiny) cv = std::min(cv, std::sqrt(lim_.margin * lim_.max_acceleration_mm_per_s2.minCoeff() / an));
  return cv;
}

double TimeScale::step(double target, const motion::Trajectory& plan, double tau) noexcept {
  motion::Setpoint at;
  plan.sample(tau, at);
  // A hold: the time-optimal jerk-limited stop along the path, in path speed.
  if (target <= 0.0 && k_ > 0.0) return stop_step(plan, tau, at);
  stopping_ = false;
  return change_step(target, at, plan.cruise_left_s(tau));
}

double TimeScale::change_step(double target, const motion::Setpoint& at, double cruise_left_s) noexcept {
  const double dt = lim_.period_s;
  const Eigen::Vector2d& v = at.velocity_mm_per_s;
  const Eigen::Vector2d& a = at.acceleration_mm_per_s2;
  const double J = lim_.margin * lim_.max_jerk_mm_per_s3;
  const double vp = v.norm();

  // How fast k may change here: k'' from the jerk the change adds, k' from the acceleration.
  double kdd_max = kInf, kd_lo = -kInf, kd_hi = kInf;
  for (int i = 0; i < 2; ++i) {
    const double A = lim_.margin * lim_.max_acceleration_mm_per_s2[i];
    if (std::abs(v[i]) > kTiny) {
      const double budget = std::max(J - 3.0 * std::abs(a[i]) * k_ * std::abs(kd_), 0.05 * J);
      kdd_max = std::min(kdd_max, budget / std::abs(v[i]));
      double lo = (-A - a[i] * k_ * k_) / v[i], hi = (A - a[i] * k_ * k_) / v[i];
      if (lo > hi) std::swap(lo, hi);
      kd_lo = std::max(kd_lo, lo);
      kd_hi = std::min(kd_hi, hi);
    }
    // d(p'' k^2)/dt = 2 p'' k k': the change of k alone must not jerk the axis past half of J.
    if (std::abs(a[i]) > kTiny) {
      const double cap = 0.5 * J / (2.0 * std::abs(a[i]) * std::max(k_, 0.05));
      kd_lo = std::max(kd_lo, -cap);
      kd_hi = std::min(kd_hi, cap);
    }
  }
  // Holding k as it is never adds anything to the plan: k' = 0 is always allowed (the plan at
  // its own limits stays at them).
  kd_lo = std::min(kd_lo, 0.0);
  kd_hi = std::max(kd_hi, 0.0);

  // The ceiling: 1, or above it while the plan cruises, as far as the axes' speeds and the
  // time to come back to 1 before the cruise ends allow.
  double ceiling = 1.0;
  if (cruise_left_s > 0 && vp > kTiny) {
    const double cv = speed_ceiling(at);
    const double rate = std::min(std::abs(kd_lo), std::abs(kd_hi));  // k' available to come back
    const double T = cruise_left_s / std::max(k_, 1.0);              // real time left in the cruise
    double excess = 0.0;
    if (std::isfinite(kdd_max) && rate > 0) {
      const double ramp = rate / kdd_max;  // time to reach that rate
      excess = T > 2 * ramp ? rate * (T - ramp) : kdd_max * (T / 2) * (T / 2);
    }
    ceiling = std::max(1.0, std::min(cv, 1.0 + 0.9 * excess));
  }
  ceiling_ = ceiling;
  target = std::clamp(target, 0.0, ceiling);

  // Toward the target: the discrete time-optimal approach with k'' <= kdd_max.
  const double e = target - k_;
  double kd = 0.0;
  if (!std::isfinite(kdd_max)) {
    kd = e / dt;  // the plan stands still here: k may change at once
  } else {
    const double step = kdd_max * dt;
    const double des = std::copysign(std::sqrt(step * step / 4 + 2 * kdd_max * std::abs(e)) - step / 2, e);
    kd = std::clamp(des, kd_ - step, kd_ + step);
  }
  kd = std::clamp(kd, kd_lo, kd_hi);
  double k = k_ + kd * dt;
  // Arrived: k at its target with k' = 0 (the last step is within the jerk bound by the rule).
  if ((e >= 0 && k >= target) || (e <= 0 && k <= target)) {
    k = target;
    kd = 0.0;
  }
  k = std::clamp(k, 0.0, kMaxScale);
  const double advance = 0.5 * (k_ + k) * dt;
  k_ = k;
  kd_ = kd;
  return advance;
}

}  // namespace machplan::executor
