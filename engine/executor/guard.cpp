#include "engine/executor/guard.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::executor {

const char* to_string(GuardStrategy s) {
  switch (s) {
    case GuardStrategy::paper: return "paper";
    case GuardStrategy::predictive: return "predictive";
  }
  return "?";
}

GuardStrategy guard_strategy_from_string(const std::string& s) {
  if (s == "paper") return GuardStrategy::paper;
  if (s == "predictive") return GuardStrategy::predictive;
  throw InputError("--strategy", 0, fmt::format("unknown strategy '{}' (known: paper, predictive)", s));
}

void GuardOptions::validate() const {
  auto check = [](bool ok, const char* field, double v, const char* rule) {
    if (!ok) throw InputError(fmt::format("GuardOptions::{}", field), 0, fmt::format("{} {}", v, rule));
  };
  check(std::isfinite(tolerance_mm) && tolerance_mm >= 0 && tolerance_mm <= 100, "tolerance_mm", tolerance_mm,
        "must be in [0, 100] mm");
  check(std::isfinite(latency_s) && latency_s >= 0 && latency_s <= 1, "latency_s", latency_s, "must be in [0, 1] s");
  check(std::isfinite(standoff_mm) && standoff_mm >= 0 && standoff_mm <= 10, "standoff_mm", standoff_mm,
        "must be in [0, 10] mm");
  check(std::isfinite(braking_fraction) && braking_fraction > 0 && braking_fraction <= 1, "braking_fraction",
        braking_fraction, "must be in (0, 1]");
  check(std::isfinite(acceleration_mm_per_s2) && acceleration_mm_per_s2 >= 0 && acceleration_mm_per_s2 <= 1e6,
        "acceleration_mm_per_s2", acceleration_mm_per_s2, "must be in [0, 1e6] mm/s^2 (0: the machine's)");
}

Guard::Guard(const ProhibitedRegion& region, const GuardOptions& options, const MachineSetup& machine, double period_s)
    : region_(region), o_(options) {
  o_.validate();
  if (!(std::isfinite(period_s) && period_s > 0 && period_s <= 0.1))
    throw InputError("Guard", 0, fmt::format("servo period {} s must be in (0, 0.1]", period_s));
  dt_ = period_s;
  A_ = o_.acceleration_mm_per_s2 > 0 ? o_.acceleration_mm_per_s2 : machine.max_acceleration_mm_per_s2;
  Ab_ = A_ * o_.braking_fraction;
  s_ = std::min(o_.standoff_mm, 0.5 * o_.tolerance_mm);
  lag_ticks_ = static_cast<int>(std::lround(o_.latency_s / dt_));
  read_latency_ = 0;
  for (const auto& sig : machine.signals) read_latency_ = std::max(read_latency_, sig.reading_latency_ticks);
  read_latency_ = std::clamp(read_latency_, 0, 64);
  ring_ = static_cast<std::size_t>(lag_ticks_ + read_latency_ + 4);
  measured_.assign(ring_, Eigen::Vector2d::Zero());
  setpoint_.assign(ring_, Eigen::Vector2d::Zero());
  measured_ok_.assign(ring_, 1);
}

void Guard::reset(const Eigen::Vector2d& start_mm) {
  std::fill(measured_.begin(), measured_.end(), start_mm);
  std::fill(setpoint_.begin(), setpoint_.end(), start_mm);
  std::fill(measured_ok_.begin(), measured_ok_.end(), 1);
  tick_ = 0;
  next_answer_ = 1;
  last_answer_tick_ = 0;
  have_answer_ = true;  // the machine stands at the start, known to the PC
  answer_mm_ = answer_g_mm_ = g_ = start_mm;
  v_.setZero();
  a_.setZero();
  holding_ = stop_latched_ = false;
  counters_ = {};
}

double Guard::braking_speed(double clearance_mm) const noexcept {
  if (!(clearance_mm > 0)) return 0.0;
  // Largest v with v T + v^2 / (2 A_b) <= h: one more period at v, then braking at A_b.
  return Ab_ * (-dt_ + std::sqrt(dt_ * dt_ + 2.0 * clearance_mm / Ab_));
}

Eigen::Vector2d Guard::predictive_velocity(const Eigen::Vector2d& p, const Eigen::Vector2d& v_in) const noexcept {
  Eigen::Vector2d v = v_in;
  if (v.squaredNorm() == 0.0) return v;
  const RegionDistance q0 = region_.query(p);
  if (!std::isfinite(q0.signed_distance_mm)) return Eigen::Vector2d::Zero();
  const double vl0 = braking_speed(q0.signed_distance_mm - s_);
  const auto limit = [&v](const Eigen::Vector2d& n, double vl) {
    const double vn = v.dot(n);
    if (vn < -vl) v += (-vl - vn) * n;  // remove the normal part beyond what can still stop
  };
  limit(q0.normal, vl0);
  double sp = v.norm();
  if (sp == 0.0) return v;
  // Where braking from now would end, plus the standoff: a feature met there (the other side
  // of a pocket's corner) is handled before the table slides into it.
  const auto ahead = [&](const Eigen::Vector2d& vel) {
    const double s = vel.norm();
    return Eigen::Vector2d(p + vel / s * (s * dt_ + s * s / (2.0 * Ab_) + s_));
  };
  const RegionDistance q1 = region_.query(ahead(v));
  if (std::isfinite(q1.signed_distance_mm) && (q1.contour != q0.contour || q1.span != q0.span)) {
    // Clearance of p from the tangent line of that feature (exact for a line span).
    const double vl1 = braking_speed((p - q1.nearest_mm).dot(q1.normal) - s_);
    for (int k = 0; k < 2; ++k) {
      limit(q1.normal, vl1);
      limit(q0.normal, vl0);
    }
    // A wedge the command cannot satisfy on both sides: stop.
    if (v.dot(q1.normal) < -vl1 - 1e-9) return Eigen::Vector2d::Zero();
  }
  sp = v.norm();
  if (sp == 0.0) return v;
  // Last check along the velocity finally chosen: if braking would still end inside the region
  // (a curved or third feature), fall back to the ball rule, safe whatever the shape: the speed
  // is such that the table stops within the clearance of p.
  const RegionDistance q2 = region_.query(ahead(v));
  if (!(q2.signed_distance_mm >= 0.0) && sp > vl0) v *= vl0 / sp;
  return v;
}

void Guard::filter(Demand& d, const Eigen::Vector2d& measured_mm, const Eigen::Vector2d&) noexcept {
  ++tick_;
  ++counters_.ticks;
  const std::size_t slot = static_cast<std::size_t>(tick_) % ring_;
  const bool measured_ok = std::isfinite(measured_mm.x()) && std::isfinite(measured_mm.y());
  measured_[slot] = measured_ok ? measured_mm : Eigen::Vector2d::Zero();
  measured_ok_[slot] = measured_ok;

  // The link: an answer arrives every L (one round trip), carrying the position of L ago.
  bool new_answer = false;
  if (tick_ >= next_answer_ && !drop_) {
    const long ts = std::max(0L, tick_ - lag_ticks_);
    const std::size_t s = static_cast<std::size_t>(ts) % ring_;
    if (measured_ok_[s]) {
      answer_mm_ = measured_[s];
      // The setpoint in force when that position was measured: the one of the tick before.
      answer_g_mm_ = setpoint_[static_cast<std::size_t>(std::max(0L, ts - 1)) % ring_];
      have_answer_ = true;
      new_answer = true;
      last_answer_tick_ = tick_;
      ++counters_.answers;
    }
    next_answer_ = tick_ + std::max(1, lag_ticks_);
  }
  // Budget: no answer for longer than one answer period (plus a tick of slack) means the
  // position in hand is older than L allows: stop.
  const long answer_period = std::max(1, lag_ticks_);
  const bool stale = !have_answer_ || tick_ - last_answer_tick_ > answer_period + 1;

  Eigen::Vector2d v_in = d.kind == Demand::Kind::track
                             ? Eigen::Vector2d(d.track.v_ff_mm_per_s[0], d.track.v_ff_mm_per_s[1])
                             : d.speed_mm_per_s;
  const bool failsafe = stale || !measured_ok || !std::isfinite(v_in.x()) || !std::isfinite(v_in.y());
  if (!std::isfinite(v_in.x()) || !std::isfinite(v_in.y())) v_in.setZero();

  Eigen::Vector2d target = v_in;
  if (failsafe) {
    target.setZero();
    ++counters_.failsafe_ticks;
  } else if (o_.strategy == GuardStrategy::paper) {
    if (new_answer) {
      const RegionDistance q = region_.query(answer_mm_);
      const bool pushing = v_in.dot(q.normal) < -1e-9;
      if (!std::isfinite(q.signed_distance_mm)) {
        stop_latched_ = true;
      } else if (q.signed_distance_mm <= o_.tolerance_mm && pushing) {
        if (!stop_latched_) ++counters_.stops_sent;
        stop_latched_ = true;
      } else if (stop_latched_ && !pushing) {
        stop_latched_ = false;
      }
    }
    if (stop_latched_) target.setZero();
  } else {
    const Eigen::Vector2d p = answer_mm_ + (g_ - answer_g_mm_);
    target = predictive_velocity(p, v_in);
  }
  if ((target - v_in).squaredNorm() > 1e-18) ++counters_.limited_ticks;

  // The axes follow the command within the machine's acceleration.
  Eigen::Vector2d dv = target - v_;
  const double dv_max = A_ * dt_;
  const double dvn = dv.norm();
  if (dvn > dv_max) dv *= dv_max / dvn;
  v_ += dv;
  a_ = dv / dt_;
  g_ += v_ * dt_;
  setpoint_[slot] = g_;

  const bool was_holding = holding_;
  holding_ = failsafe || stop_latched_ ||
             (o_.strategy == GuardStrategy::predictive && v_in.norm() > 1e-6 && target.norm() < 1e-6 * v_in.norm());
  if (holding_ && !was_holding && o_.strategy == GuardStrategy::predictive) ++counters_.stops_sent;

  if (d.kind == Demand::Kind::track) {
    // Like the jog source, the setpoint lags by the controller's reading latency.
    const long tr = std::max(0L, tick_ - read_latency_);
    const Eigen::Vector2d r = setpoint_[static_cast<std::size_t>(tr) % ring_];
    for (int i = 0; i < 2; ++i) {
      d.track.r_mm[i] = r[i];
      d.track.v_ff_mm_per_s[i] = v_[i];
      d.track.a_ff_mm_per_s2[i] = a_[i];
    }
  } else {
    d.speed_mm_per_s = v_;
  }
  d.commanded_mm = g_;
}

}  // namespace machplan::executor
