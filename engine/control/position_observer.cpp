#include "engine/control/position_observer.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/control/internal/setting_check.h"

namespace machplan::control {

namespace {
constexpr double kRestMmPerS = 1e-9;
double sgn(double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0); }
}  // namespace

void ObserverModel::validate() const {
  const auto check = [](bool ok, const char* field, double v, const char* rule) { require_field(ok, field, v, rule); };
  check(std::isfinite(period_s) && period_s > 0, "period_s", period_s, "must be > 0");
  check(std::isfinite(gain) && gain > 0, "gain", gain, "must be > 0");
  check(std::isfinite(tau_s) && tau_s >= 0, "tau_s", tau_s, "must be >= 0 (0: unknown)");
  check(std::isfinite(quantum_mm) && quantum_mm >= 0, "quantum_mm", quantum_mm, "must be >= 0");
  check(std::isfinite(coulomb_mm_per_s) && coulomb_mm_per_s >= 0, "coulomb_mm_per_s", coulomb_mm_per_s, "must be >= 0");
  check(delay_ticks >= 0 && delay_ticks <= kMaxDelayTicks, "delay_ticks", delay_ticks, "must be 0 .. 31");
  check(std::isfinite(backlash_mm) && backlash_mm >= 0, "backlash_mm", backlash_mm, "must be >= 0");
  check(std::isfinite(speed_limit_mm_per_s) && speed_limit_mm_per_s >= 0, "speed_limit_mm_per_s", speed_limit_mm_per_s,
        "must be >= 0 (0: unbounded)");
}

void PositionObserver::configure(const ObserverModel& model, double bandwidth_per_s) {
  model.validate();
  require_field(std::isfinite(bandwidth_per_s) && bandwidth_per_s >= 0, "bandwidth_per_s", bandwidth_per_s,
                "rad/s must be finite and >= 0 (0: off)");
  m_ = model;
  on_ = bandwidth_per_s > 0;
  a_ = m_.tau_s > 0 ? std::exp(-m_.period_s / m_.tau_s) : 0.0;
  const double p = std::exp(-bandwidth_per_s * m_.period_s);
  alpha_ = 1.0 - p * p;
  beta_ = (1.0 - p) * (1.0 - p);
  reset();
}

void PositionObserver::reset() noexcept {
  started_ = false;
  x_ = motor_ = v_ = d_ = 0.0;
  u_.fill(0.0);
  head_ = 0;
}

void PositionObserver::model_step(double u, State& s) const noexcept {
  const double w = m_.gain * u + d_;
  const double fc = m_.coulomb_mm_per_s;
  if (std::abs(s.v) <= kRestMmPerS && std::abs(w) <= fc) {
    s.v = 0.0;  // sticking: friction holds the axis
    return;
  }
  const double wf = w - fc * (std::abs(s.v) > kRestMmPerS ? sgn(s.v) : sgn(w));
  const double v_next = wf + (s.v - wf) * a_;
  s.motor += wf * m_.period_s + (s.v - wf) * m_.tau_s * (1.0 - a_);
  // Friction alone cannot reverse the motion: crossing zero under it stops the axis.
  s.v = (sgn(v_next) != sgn(s.v) && std::abs(s.v) > kRestMmPerS && std::abs(w) <= fc) ? 0.0 : v_next;
  // The table follows the motor only once the motor has crossed the gap.
  const double half = 0.5 * m_.backlash_mm;
  s.x = std::clamp(s.x, s.motor - half, s.motor + half);
}

double PositionObserver::predict() const noexcept {
  if (!on_ || !started_) return x_;
  constexpr int N = ObserverModel::kMaxDelayTicks + 1;
  State s{x_, motor_, v_};
  for (int j = m_.delay_ticks - 1; j >= 0; --j) model_step(u_[(head_ - j + N) % N], s);
  return s.x;
}

double PositionObserver::update(double y) noexcept {
  if (!on_) return y;
  if (!started_ || !std::isfinite(x_) || !std::isfinite(motor_)) {
    // The first reading (or a state a non-finite input spoiled): start at rest on it, the motor
    // mid-gap.
    started_ = true;
    x_ = motor_ = y;
    v_ = d_ = 0.0;
    return y;
  }
  constexpr int N = ObserverModel::kMaxDelayTicks + 1;
  State s{x_, motor_, v_};
  model_step(u_[(head_ - m_.delay_ticks + N) % N], s);
  const double e = y - s.x;
  double x = s.x + alpha_ * e;
  if (m_.quantum_mm > 0) x = std::clamp(x, y - 0.5 * m_.quantum_mm, y + 0.5 * m_.quantum_mm);
  // The correction moves motor and table together: it is the model's drift, not the gap.
  motor_ = s.motor + (x - s.x);
  x_ = x;
  v_ = s.v;
  d_ += beta_ * e / m_.period_s;
  if (m_.speed_limit_mm_per_s > 0) d_ = std::clamp(d_, -m_.speed_limit_mm_per_s, m_.speed_limit_mm_per_s);
  if (!std::isfinite(x_)) x_ = motor_ = y;
  return x_;
}

void PositionObserver::command(double u) noexcept {
  constexpr int N = ObserverModel::kMaxDelayTicks + 1;
  head_ = (head_ + 1) % N;
  u_[head_] = std::isfinite(u) ? u : 0.0;
}

}  // namespace machplan::control
