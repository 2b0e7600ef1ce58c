#include "engine/executor/guard.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::executor {

namespace {
constexpr Spelling kStrategyNames[] = {{"paper"}, {"predictive"}};
}  // namespace

const char* to_string(GuardStrategy s) { return kStrategyNames[static_cast<std::size_t>(s)].name.data(); }

Parsed<GuardStrategy> parse_guard_strategy(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kStrategyNames, text, "strategy", "strategy");
  return {static_cast<GuardStrategy>(p.value), p.note};
}

void GuardOptions::validate() const {
  require_field(std::isfinite(tolerance_mm) && tolerance_mm >= 0 && tolerance_mm <= 100, "tolerance_mm", tolerance_mm,
                "must be in [0, 100] mm");
  require_field(std::isfinite(latency_s) && latency_s >= 0 && latency_s <= 1, "latency_s", latency_s, "must be in [0, 1] s");
  require_field(std::isfinite(standoff_mm) && standoff_mm >= 0 && standoff_mm <= 10, "standoff_mm", standoff_mm,
                "must be in [0, 10] mm");
  require_field(std::isfinite(braking_fraction) && braking_fraction > 0 && braking_fraction <= 1, "braking_fraction",
                braking_fraction, "must be in (0, 1]");
  require_field(std::isfinite(tracking_limit_mm) && tracking_limit_mm > 0 && tracking_limit_mm <= 100, "tracking_limit_mm",
                tracking_limit_mm, "must be in (0, 100] mm");
  require_field(std::isfinite(acceleration_mm_per_s2) && acceleration_mm_per_s2 >= 0 && acceleration_mm_per_s2 <= 1e6,
                "acceleration_mm_per_s2", acceleration_mm_per_s2, "must be in [0, 1e6] mm/s^2 (0: the machine's)");
}

Guard::Guard(const ProhibitedRegion& region, const GuardOptions& options, const MachineSetup& machine, double period_s)
    : region_(region), o_(options) {
  o_.validate();
  if (!(std::isfinite(period_s) && period_s > 0 && period_s <= 0.1))
    throw InputError::field("period_s", fmt::format("{} s must be in (0, 0.1]: the guard's servo period", period_s));
  dt_ = period_s;
  A_ = o_.acceleration_mm_per_s2 > 0 ? o_.acceleration_mm_per_s2 : machine.max_acceleration_mm_per_s2;
  Ab_ = A_ * o_.braking_fraction;
  s_ = std::min(o_.standoff_mm, 0.5 * o_.tolerance_mm);
  lag_ticks_ = static_cast<int>(std::lround(o_.latency_s / dt_));
  read_latency_ = 0;
  for (const auto& sig : machine.signals) read_latency_ = std::max(read_latency_, sig.reading_latency_ticks);
  read_latency_ = std::clamp(read_latency_, 0, 64);
  plant_lag_ = 1;
  for (const auto& sig : machine.signals)
    plant_lag_ = std::max(plant_lag_, 1 + sig.command_latency_ticks + sig.reading_latency_ticks);
  plant_lag_ = std::clamp(plant_lag_, 1, 64);
  ring_ = static_cast<std::size_t>(lag_ticks_ + std::max(read_latency_, plant_lag_) + 4);
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
  holding_ = stop_latched_ = tracking_lost_ = false;
  counters_ = {};
}

double Guard::braking_speed(double clearance_mm) const noexcept {
  if (!(clearance_mm > 0)) return 0.0;
  // Largest v with v T + v^2 / (2 A_b) <= h: one more period at v, then braking at A_b.
  return Ab_ * (-dt_ + std::sqrt(dt_ * dt_ + 2.0 * clearance_mm / Ab_));
}

namespace {

// The direction in which the distance to the boundary grows fastest at p: from the nearest
// point toward p (away from it when p is inside). Unlike a span's normal this is right at a
// vertex too (the bisector at a pocket's corner); on the boundary itself the span's normal.
RegionDistance with_true_normal(RegionDistance q, const Eigen::Vector2d& p) {
  const Eigen::Vector2d r = p - q.nearest_mm;
  const double n = r.norm();
  if (n > 1e-9 && std::isfinite(n)) q.normal = (q.signed_distance_mm >= 0 ? 1.0 : -1.0) * r / n;
  return q;
}

// Whether b's constraint is a's: the same tangent line (b's nearest point on a's line, the
// same normal). Comparing spans is not enough: a vertex belongs to two spans, and the region
// may name either.
bool same_line(const RegionDistance& a, const RegionDistance& b) {
  return a.normal.dot(b.normal) > 1.0 - 1e-9 && std::abs((b.nearest_mm - a.nearest_mm).dot(a.normal)) < 1e-6;
}

}  // namespace

Eigen::Vector2d Guard::predictive_velocity(const Eigen::Vector2d& p, const Eigen::Vector2d& v_in) const noexcept {
  Eigen::Vector2d v = v_in;
  if (v.squaredNorm() == 0.0) return v;
  const RegionDistance q0 = with_true_normal(region_.query(p), p);
  if (!std::isfinite(q0.signed_distance_mm)) return Eigen::Vector2d::Zero();
  const double vl0 = braking_speed(q0.signed_distance_mm - s_);
  const auto limit = [&v](const Eigen::Vector2d& n, double vl) {
    const double vn = v.dot(n);
    if (vn < -vl) v += (-vl - vn) * n;  // remove the normal part beyond what can still stop
  };
  limit(q0.normal, vl0);
  // Look ahead where braking from the present speed would end, along the velocity and along
  // its part tangential to the nearest feature (the way the table slides): a feature met there
  // (the other side of a pocket's corner) is limited too, by the clearance of p from its tangent
  // line (exact for a line span), before the table slides into it. Two features at once: the
  // three alternating projections end on a velocity that satisfies both, or on none (a wedge
  // the command points into: stop).
  const double sp_in = v_in.norm();
  const double reach = sp_in * dt_ + sp_in * sp_in / (2.0 * Ab_) + s_;
  RegionDistance known[3] = {q0, q0, q0};
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::Vector2d dir = pass == 0 ? v : Eigen::Vector2d(v - v.dot(q0.normal) * q0.normal);
    const double dn = dir.norm();
    if (dn < 1e-12) continue;
    const Eigen::Vector2d p1 = p + dir / dn * reach;
    const RegionDistance q1 = with_true_normal(region_.query(p1), p1);
    if (!std::isfinite(q1.signed_distance_mm) || same_line(q0, q1)) continue;
    known[pass + 1] = q1;
    const double vl1 = braking_speed((p - q1.nearest_mm).dot(q1.normal) - s_);
    for (int k = 0; k < 2; ++k) {
      limit(q1.normal, vl1);
      limit(q0.normal, vl0);
    }
    if (v.dot(q1.normal) < -vl1 - 1e-9) return Eigen::Vector2d::Zero();
  }
  const double sp = v.norm();
  if (sp == 0.0) return v;
  // Last check along the velocity finally chosen: if braking would still end inside the region
  // at a feature not yet limited (a curve, a third feature), fall back to the ball rule, safe
  // whatever the shape: a speed at which the table stops within the clearance of p.
  const Eigen::Vector2d p2 = p + v / sp * (sp * dt_ + sp * sp / (2.0 * Ab_) + s_);
  const RegionDistance q2 = with_true_normal(region_.query(p2), p2);
  bool seen = false;
  for (const RegionDistance& k : known) seen = seen || same_line(k, q2);
  if (!seen && !(q2.signed_distance_mm >= 0.0) && sp > vl0) v *= vl0 / sp;
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
      // The setpoint that position answers to: the one sent plant_lag_ ticks before it was read.
      answer_g_mm_ = setpoint_[static_cast<std::size_t>(std::max(0L, ts - plant_lag_)) % ring_];
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
    // The commanded point is where the table will be (the controller tracks it; at rest it
    // reaches it), known now whatever the link's delay. The answers check that it does: an
    // answer farther from the setpoint of its time than the tracking limit (a jam, a slipped
    // drive) holds the axes.
    if (new_answer && (answer_mm_ - answer_g_mm_).norm() > o_.tracking_limit_mm) tracking_lost_ = true;
    if (tracking_lost_) {
      target.setZero();
      ++counters_.failsafe_ticks;
    } else {
      target = predictive_velocity(g_, v_in);
    }
  }
  if ((target - v_in).squaredNorm() > 1e-18) ++counters_.limited_ticks;

  // The axes follow the command within the machine's acceleration.
  Eigen::Vector2d dv = target - v_;
  const double dv_max = A_ * dt_;
  const double dvn = dv.norm();
  if (dvn > dv_max) dv *= dv_max / dvn;
  Eigen::Vector2d v_new = v_ + dv;
  if (o_.strategy == GuardStrategy::predictive && !failsafe && !tracking_lost_ && v_new.squaredNorm() > 0.0) {
    // The last word: the next setpoint may not lose clearance below the standoff (or below
    // what it has, if less). Where the limits above fall short (a corner met at speed, the
    // acceleration slew), the step is shortened, harder than A if it must: a brake beyond the
    // ramp is better than a cut into the part. Bounded: four halvings.
    const double floor = std::min(region_.query(g_).signed_distance_mm, s_) - 1e-4;
    if (!(region_.query(g_ + v_new * dt_).signed_distance_mm >= floor)) {
      double lo = 0.0, hi = 1.0;
      for (int k = 0; k < 4; ++k) {
        const double mid = 0.5 * (lo + hi);
        if (region_.query(g_ + mid * v_new * dt_).signed_distance_mm >= floor) lo = mid;
        else hi = mid;
      }
      v_new *= lo;
      ++counters_.emergency_ticks;
    }
  }
  a_ = (v_new - v_) / dt_;
  v_ = v_new;
  g_ += v_ * dt_;
  setpoint_[slot] = g_;

  const bool was_holding = holding_;
  holding_ = failsafe || stop_latched_ || tracking_lost_ ||
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
    // The guard's setpoint is its own: the source's path and preview no longer describe it, so
    // contour controllers fall back to the feed-forward (engine/control/controller.h).
    d.track.path = nullptr;
    d.track.preview_ticks = 0;
  } else {
    d.speed_mm_per_s = v_;
  }
  d.commanded_mm = g_;
}

}  // namespace machplan::executor
