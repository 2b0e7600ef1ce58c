#include "engine/control/position_observer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace machplan::control {

namespace {
constexpr double kRestMmPerS = 1e-9;
double sgn(double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0); }
}  // namespace

void ObserverModel::validate() const {
  const auto check = [](bool ok, const char* field, double v, const char* rule) {
    if (!ok) throw std::invalid_argument(fmt::format("ObserverModel::{} = {}: {}", field, v, rule));
  };
  check(std::isfinite(period_s) && period_s > 0, "period_s", period_s, "must be > 0");
  check(std::isfinite(gain) && gain > 0, "gain", gain, "must be > 0");
  check(std::isfinite(tau_s) && tau_s >= 0, "tau_s", tau_s, "must be >= 0 (0: unknown)");
  check(std::isfinite(quantum_mm) && quantum_mm >= 0, "quantum_mm", quantum_mm, "must be >= 0");
  check(std::isfinite(coulomb_mm_per_s) && coulomb_mm_per_s >= 0, "coulomb_mm_per_s", coulomb_mm_per_s, "must be >= 0");
  check(delay_ticks >= 0 && delay_ticks <= kMaxDelayTicks, "delay_ticks", delay_ticks, "must be 0 .. 31");
}

void PositionObserver::configure(const ObserverModel& model, double bandwidth_per_s) {
  model.validate();
  if (!(std::isfinite(bandwidth_per_s) && bandwidth_per_s >= 0))
    throw std::invalid_argument(fmt::format("observer bandwidth {} rad/s: must be finite and >= 0 (0: off)", bandwidth_per_s));
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
  x_ = v_ = d_ = 0.0;
  u_.fill(0.0);
  head_ = 0;
}

double PositionObserver::update(double y) noexcept {
  if (!on_) return y;
  if (!started_ || !std::isfinite(x_)) {
    // The first reading (or a state a non-finite input spoiled): start at rest on it.
    started_ = true;
    x_ = y;
    v_ = d_ = 0.0;
    return y;
  }
  constexpr int N = ObserverModel::kMaxDelayTicks + 1;
  const double u = u_[(head_ - m_.delay_ticks + N) % N];
  const double w = m_.gain * u + d_;
  const double fc = m_.coulomb_mm_per_s;
  const double T = m_.period_s;
  double x_pred = x_;
  if (std::abs(v_) <= kRestMmPerS && std::abs(w) <= fc) {
    v_ = 0.0;  // sticking: friction holds the axis
  } else {
    const double wf = w - fc * (std::abs(v_) > kRestMmPerS ? sgn(v_) : sgn(w));
    const double v_next = wf + (v_ - wf) * a_;
    x_pred += wf * T + (v_ - wf) * m_.tau_s * (1.0 - a_);
    // Friction alone cannot reverse the motion: crossing zero under it stops the axis.
    v_ = (sgn(v_next) != sgn(v_) && std::abs(v_) > kRestMmPerS && std::abs(w) <= fc) ? 0.0 : v_next;
  }
  const double e = y - x_pred;
  x_ = x_pred + alpha_ * e;
  if (m_.quantum_mm > 0) x_ = std::clamp(x_, y - 0.5 * m_.quantum_mm, y + 0.5 * m_.quantum_mm);
  d_ += beta_ * e / T;
  if (!std::isfinite(x_)) x_ = y;
  return x_;
}

void PositionObserver::command(double u) noexcept {
  constexpr int N = ObserverModel::kMaxDelayTicks + 1;
  head_ = (head_ + 1) % N;
  u_[head_] = std::isfinite(u) ? u : 0.0;
}

}  // namespace machplan::control
