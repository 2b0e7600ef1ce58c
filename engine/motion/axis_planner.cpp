#include "engine/motion/axis_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

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

const char* kJointAxisNames[kJointAxes] = {"x", "y", "z", "rotary 1", "rotary 2"};

// min_k lim_k / |u_k| over the axes that move (infinity when none does).
double joint_axis_cap(const JointVector& lim, const JointVector& u_abs) {
  double r = kNoCap;
  for (int k = 0; k < kJointAxes; ++k)
    if (u_abs[k] > 0.0) r = std::min(r, lim[k] / u_abs[k]);
  return r;
}

JointVector corner_tolerance(const AxisLimits& l) {
  JointVector t;
  t << l.corner_tolerance_mm, l.corner_tolerance_mm, l.corner_tolerance_mm, l.corner_tolerance_rad, l.corner_tolerance_rad;
  return t;
}

}  // namespace

void AxisLimits::validate() const {
  const auto each = [](const JointVector& v, const char* field) {
    for (int k = 0; k < kJointAxes; ++k)
      require_field(std::isfinite(v[k]) && v[k] > 0.0, fmt::format("{}.{}", field, kJointAxisNames[k]), v[k],
                    "must be finite and > 0");
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

double joint_move_length(const JointVector& delta, double tip_mm) {
  if (tip_mm > kMinJointMove) return tip_mm;
  return delta.tail<2>().norm();
}

MoveCaps joint_move_caps(const JointVector& u, double feed, bool tip_moves, const AxisLimits& l) {
  MoveCaps c;
  const bool rapid = feed <= 0.0;
  c.speed = joint_axis_cap(rapid ? l.rapid_velocity : l.velocity, u);
  if (!rapid && l.feed == AxisLimits::Feed::tip && tip_moves) c.speed = std::min(c.speed, feed);
  if (!rapid && l.feed == AxisLimits::Feed::axes) {
    constexpr double kDegPerRad = 180.0 / std::numbers::pi;
    const double combined = std::hypot(u.head<3>().norm(), kDegPerRad * u.tail<2>().norm());
    if (combined > 0.0) c.speed = std::min(c.speed, feed / combined);
  }
  c.accel = joint_axis_cap(l.acceleration, u);
  c.jerk = joint_axis_cap(l.jerk, u);
  return c;
}

double junction_speed_cap(const JointVector& du_abs, double max_blend, const AxisLimits& l) {
  if (!(du_abs.maxCoeff() > kSameRate)) return kNoCap;
  const JointVector tol = corner_tolerance(l);
  double blend = max_blend;
  for (int k = 0; k < kJointAxes; ++k)
    if (du_abs[k] > 0.0) blend = std::min(blend, 8.0 * tol[k] / du_abs[k]);
  return std::sqrt(blend * joint_axis_cap(l.acceleration, du_abs));
}

JointPlan plan_joint_moves(const JointVector& start, const std::vector<JointMove>& moves, const AxisLimits& limits) {
  limits.validate();
  MACHPLAN_ASSERT(start.allFinite(), "plan_joint_moves: the start is not finite");
  JointPlan plan;
  plan.start_ = start;
  // The moves with their rates and caps; the jerk and acceleration caps kept beside them.
  std::vector<double> accel, jerk;
  JointVector q = start;
  for (std::size_t i = 0; i < moves.size(); ++i) {
    const JointMove& m = moves[i];
    MACHPLAN_ASSERT(m.end.allFinite() && std::isfinite(m.tip_mm) && m.tip_mm >= 0.0 && std::isfinite(m.feed_mm_per_s) &&
                        m.feed_mm_per_s >= 0.0,
                    "plan_joint_moves: move {} has a non-finite position, or tip length {} or feed {}", i, m.tip_mm,
                    m.feed_mm_per_s);
    const JointVector delta = m.end - q;
    const double len = joint_move_length(delta, m.tip_mm);
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
