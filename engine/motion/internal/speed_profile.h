// The look-ahead both feed planners share (engine/motion/feed_planner.h, axis_planner.h): a
// path cut into zones, each with a speed cap, a tangential acceleration cap (constant, or
// falling with the speed on zones with arcs) and a jerk limit; node speeds between zones by
// GRBL's reverse and forward passes with jerk-limited S-curve distances; then one accelerate /
// cruise / decelerate profile per zone at the highest peak speed its length allows. The
// formulas are in feed_planner.h's file comment (section 3).
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "engine/motion/profile.h"

namespace machplan::motion::internal {

// Duration of one jerk-limited speed change by dv >= 0 with acceleration <= a and jerk j:
// 2 sqrt(dv / j) when dv <= a^2 / j, else dv / a + a / j.
double pulse_time(double dv, double a, double j);

// A run of path pieces planned as one accelerate / cruise / decelerate block. Its tangential
// acceleration cap may depend on the speed through the normal acceleration v^2 kappa of its
// arcs: A(v) = min(a_line, table), the table `a_arc` on kAccelTable + 1 speeds from 0 to the
// cap, read at the table speed at or above v (never above the true value). A speed change is
// then made of pulses in two bands, below and above v_split = 0.7 cap, each with the A of its
// top speed. Without arcs (a_arc empty, kappa 0) A is a_line everywhere and a change is one
// pulse.
inline constexpr int kAccelTable = 32;
struct SpeedZone {
  std::size_t first = 0, last = 0;  // the planner's piece range [first, last]
  double s0 = 0.0, length = 0.0, cap = 0.0;
  double a_line = std::numeric_limits<double>::infinity(), kappa = 0.0;
  double jerk = std::numeric_limits<double>::infinity();  // path jerk limit
  std::vector<double> a_arc;  // the table; empty without arcs

  double accel(double v_top) const;
  double split() const { return kappa > 0.0 ? 0.7 * cap : cap; }
};

// Distance covered by the speed change v0 -> v1 in zone z.
double transition_distance(double v0, double v1, const SpeedZone& z);
// Highest v1 in [v0, cap] that one transition from v0 reaches within the zone's length.
double reachable(double v0, const SpeedZone& z, double cap);

// Node speeds between zones, node[k] at the start of zone k (node[nz] the end): rest at both
// ends; node k in 1 .. nz-1 at most node_cap[k] (0: a stop) and the caps of both zones it
// joins; then the reverse pass (each node low enough to brake to the next within the zone
// between) and the forward pass (reachable from the one before). node_cap has nz + 1 entries.
std::vector<double> node_speeds(const std::vector<SpeedZone>& zones, const std::vector<double>& node_cap);

// One accelerate / cruise / decelerate profile per zone, at the highest peak speed that fits
// its length, appended to `phases`; returns the duration.
double build_profile(const std::vector<SpeedZone>& zones, const std::vector<double>& node,
                     std::vector<ProfilePhase>& phases);

// The time lower bound of feed_planner.h's file comment (the 1-D bang-bang envelope) over a
// chain of pieces: on piece k the speed is at most `cap` and changes with |d(v^2)/ds| <= 2
// `accel`; at the node before it v^2 is at most `node_cap2` (0: a stop, infinity: no limit
// but the caps of the pieces it joins); rest at both ends. Returns integral ds / V(s) for the
// largest such V, in closed form. It only falls when any cap rises.
struct EnvelopePiece {
  double length = 0.0, cap = 0.0, accel = 0.0;
  double node_cap2 = std::numeric_limits<double>::infinity();
};
double envelope_time_s(const std::vector<EnvelopePiece>& pieces);

}  // namespace machplan::motion::internal
