#include "engine/motion/axis_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/internal/speed_profile.h"

namespace machplan::motion {
namespace {

using internal::SpeedZone;
constexpr double kNoCap = std::numeric_limits<double>::infinity();
constexpr double kMinJointMove = 1e-9;         // shorter moves (mm or rad of path) are dropped
constexpr double kJointZoneMergeRel = 0.005;   // caps within 0.5 % share a zone (as feed_planner.cpp)
constexpr double kSameRate = 1e-12;       // junction rate jumps below this do not bind


// The norms of a vector's linear and rotary parts.
std::pair<double, double> linear_rotary_norms(const JointVector& v, const AxisLimits& l) {
  double lin = 0.0, rot = 0.0;
  for (int k = 0; k < l.axes(); ++k) (l.rotary(k) ? rot : lin) += v[k] * v[k];
  return {std::sqrt(lin), std::sqrt(rot)};
}

}  // namespace

JointVector five_axis(double x, double y, double z, double a, double c) {
  JointVector q;
  q << x, y, z, a, c, 0.0;
  return q;
}

void AxisLimits::validate() const {
  MACHPLAN_ASSERT(axes() >= 1 && axes() <= kJointAxes, "AxisLimits: {} axes (1 to {})", axes(), kJointAxes);
  const auto each = [this](const JointVector& v, const char* field) {
    for (int k = 0; k < axes(); ++k)
      require_field(std::isfinite(v[k]) && v[k] > 0.0, fmt::format("{}.{}", field, names[k]), v[k], "must be finite and > 0");
  };
  each(velocity, "velocity");
  each(rapid_velocity, "rapid_velocity");
  each(acceleration, "acceleration");
  each(jerk, "jerk");
  require_field(std::isfinite(corner_tolerance_mm) && corner_tolerance_mm > 0.0, "corner_tolerance_mm",
                corner_tolerance_mm, "must be finite and > 0");
  require_field(std::isfinite(corner_tolerance_rad) && corner_tolerance_rad > 0.0, "corner_tolerance_rad",
                corner_tolerance_rad, "must be finite and > 0");
}

double joint_move_length(const JointVector& delta, double tip_mm, double turn_rad, const AxisLimits& l) {
  if (tip_mm > kMinJointMove) return tip_mm;
  return l.rotary_axes != 0 ? linear_rotary_norms(delta, l).second : turn_rad;
}

MoveCaps joint_move_caps(const JointVector& u, double feed, bool tip_moves, const AxisLimits& l) {
  // min_k limit_k / |u_k| over the axes that move (infinity when none does).
  MoveCaps c{kNoCap, kNoCap, kNoCap};
  const bool rapid = feed <= 0.0;
  const JointVector& v = rapid ? l.rapid_velocity : l.velocity;
  for (int k = 0; k < l.axes(); ++k)
    if (u[k] > 0.0) {
      const double inv = 1.0 / u[k];
      c.speed = std::min(c.speed, v[k] * inv);
      c.accel = std::min(c.accel, l.acceleration[k] * inv);
      c.jerk = std::min(c.jerk, l.jerk[k] * inv);
    }
  if (!rapid && l.feed == AxisLimits::Feed::tip && tip_moves) c.speed = std::min(c.speed, feed);
  if (!rapid && l.feed == AxisLimits::Feed::axes) {
    constexpr double kDegPerRad = 180.0 / std::numbers::pi;
    const auto [lin, rot] = linear_rotary_norms(u, l);
    const double combined = std::hypot(lin, kDegPerRad * rot);
    if (combined > 0.0) c.speed = std::min(c.speed, feed / combined);
  }
  return c;
}

double junction_speed_cap(const JointVector& du_abs, double max_blend, const AxisLimits& l) {
  if (!(du_abs.maxCoeff() > kSameRate)) return kNoCap;
  // The blend within every axis's corner tolerance, and the axes' accelerations over it.
  double blend = max_blend, accel = kNoCap;
  for (int k = 0; k < l.axes(); ++k)
    if (du_abs[k] > 0.0) {
      blend = std::min(blend, 8.0 * (l.rotary(k) ? l.corner_tolerance_rad : l.corner_tolerance_mm) / du_abs[k]);
      accel = std::min(accel, l.acceleration[k] / du_abs[k]);
    }
  return std::sqrt(blend * accel);
}

JointPlan plan_joint_moves(const JointVector& start, const std::vector<JointMove>& moves, const AxisLimits& limits) {
  limits.validate();
  const auto unused = [&](const JointVector& q) { return q.tail(kJointAxes - limits.axes()).isZero(0.0); };
  MACHPLAN_ASSERT(start.allFinite() && unused(start), "plan_joint_moves: the start is not finite, or moves an axis the "
                                                      "machine does not have");
  JointPlan plan;
  plan.start_ = start;
  // The moves with their rates and caps; the jerk and acceleration caps kept beside them.
  std::vector<double> accel, jerk;
  accel.reserve(moves.size());
  jerk.reserve(moves.size());
  plan.moves_.reserve(moves.size());
  plan.move_s0_.reserve(moves.size());
  JointVector q = start;
  for (std::size_t i = 0; i < moves.size(); ++i) {
    const JointMove& m = moves[i];
    MACHPLAN_ASSERT(m.end.allFinite() && std::isfinite(m.tip_mm) && m.tip_mm >= 0.0 && std::isfinite(m.turn_rad) &&
                        m.turn_rad >= 0.0 && std::isfinite(m.feed_mm_per_s) && m.feed_mm_per_s >= 0.0 && unused(m.end),
                    "plan_joint_moves: move {} has a non-finite position or one on an axis the machine does not "
                    "have, or tip length {}, turn {} or feed {}", i,
                    m.tip_mm, m.turn_rad, m.feed_mm_per_s);
    const JointVector delta = m.end - q;
    const double len = joint_move_length(delta, m.tip_mm, m.turn_rad, limits);
    if (!(len > kMinJointMove) || !(delta.cwiseAbs().maxCoeff() > 0.0)) continue;  // goes nowhere: skipped
    JointPlan::Move mv;
    mv.s0 = plan.length_;
    mv.length = len;
    mv.start = q;
    mv.rate = delta / len;
    const MoveCaps caps = joint_move_caps(mv.rate.cwiseAbs(), m.feed_mm_per_s, m.tip_mm > kMinJointMove, limits);
    const double cap = caps.speed;
    mv.speed_cap = cap;
    mv.junction_cap = kNoCap;
    if (!plan.moves_.empty()) {
      JointPlan::Move& prev = plan.moves_.back();
      prev.junction_cap = junction_speed_cap((mv.rate - prev.rate).cwiseAbs(), std::min(prev.length, len), limits);
    }
    accel.push_back(caps.accel);
    jerk.push_back(caps.jerk);
    plan.velocity_only_s_ += len / cap;
    plan.length_ += len;
    plan.moves_.push_back(mv);
    plan.move_s0_.push_back(mv.s0);
    q = m.end;
  }
  if (plan.moves_.empty()) return plan;

  // Zones: consecutive moves whose caps agree and whose junction does not bind.
  std::vector<SpeedZone> zones;
  std::vector<double> node_cap(1, 0.0);
  for (std::size_t k = 0; k < plan.moves_.size(); ++k) {
    const JointPlan::Move& mv = plan.moves_[k];
    bool join = !zones.empty();
    if (join) {
      const SpeedZone& z = zones.back();
      const double joined_cap = std::min(z.cap, mv.speed_cap);
      join = std::abs(mv.speed_cap - z.cap) <= kJointZoneMergeRel * z.cap && plan.moves_[k - 1].junction_cap >= joined_cap;
    }
    if (!join) {
      if (k > 0) node_cap.push_back(plan.moves_[k - 1].junction_cap);
      SpeedZone z;
      z.first = k;
      z.s0 = mv.s0;
      z.cap = mv.speed_cap;
      zones.push_back(z);
    }
    SpeedZone& z = zones.back();
    z.last = k;
    z.length += mv.length;
    z.cap = std::min(z.cap, mv.speed_cap);
    z.a_line = std::min(z.a_line, accel[k]);
    z.jerk = std::min(z.jerk, jerk[k]);
  }
  node_cap.push_back(0.0);
  plan.zones_ = static_cast<int>(zones.size());
  const std::vector<double> node = internal::node_speeds(zones, node_cap);
  plan.duration_s_ = internal::build_profile(zones, node, plan.phases_);
  for (const ProfilePhase& p : plan.phases_) plan.phase_t0_.push_back(p.t0_s);
  return plan;
}

JointState JointPlan::sample(double t_s) const {
  JointState out;
  if (moves_.empty()) {
    out.position = start_;
    return out;
  }
  const ProfileState st = path_state(t_s);
  const auto it = std::upper_bound(move_s0_.begin(), move_s0_.end(), st.s);
  const std::size_t k = it == move_s0_.begin() ? 0 : static_cast<std::size_t>(it - move_s0_.begin()) - 1;
  const Move& m = moves_[k];
  out.position = m.start + (st.s - m.s0) * m.rate;
  out.velocity = st.v * m.rate;
  out.acceleration = st.a * m.rate;
  return out;
}

}  // namespace machplan::motion
