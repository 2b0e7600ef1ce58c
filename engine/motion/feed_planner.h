// Feed planning: one Stretch of programmed lines and arcs becomes a rest-to-rest,
// jerk-limited Trajectory that the executor samples every servo period.
//
// The problem. The program gives a chain of segments and a feed per segment. The machine
// gives per-axis speed and acceleration limits and a jerk limit along the path. We want the
// tool to follow the chain as fast as those limits allow, without stopping at every junction
// of a contour made of many short segments, and never leaving the programmed geometry by more
// than a path tolerance delta (PlannerOptions::path_tolerance_mm).
//
// 1. Corner blending (geometry). At a junction where the direction jumps by a turning angle
//    phi, exact following needs a full stop (the velocity vector cannot turn at non-zero
//    speed with finite acceleration). LinuxCNC's trajectory planner (tp, blendmath.c) instead
//    replaces the corner by a tangent arc; GRBL keeps the corner and caps the junction speed by
//    a "junction deviation" estimate. We follow LinuxCNC: both neighbours are trimmed by a
//    length d and the gap is closed by a biarc (two tangent circular arcs) that leaves each
//    trimmed end along its own tangent, so the new path is tangent-continuous. Between two
//    lines the biarc is a single arc of radius r = d / tan(phi/2) whose farthest point from
//    the corner lies
//
//        dev = r (1 / cos(phi/2) - 1) = d tan(phi/4)
//
//    away, so d = delta / tan(phi/4) puts it exactly at the tolerance. d is also capped at half
//    of each neighbour, so blends never overlap; on a polygon of many short segments the
//    blends then meet at the segment midpoints and the tool runs on a chain of arcs close to
//    the curve the polygon approximates. When an arc takes part the deviation is measured on
//    64 points of the biarc against the untrimmed segments and d is halved until it is at
//    most 0.9 delta. Turning angles above kStopAngleRad (a near reversal) and blends shorter
//    than 1e-6 mm are not blended: the tool stops there. Junctions that are tangent within
//    1e-9 rad are passed as they are.
//
// 2. Speed and acceleration caps (per piece of the blended path). The machine's limits are a
//    box: each axis has its own speed and acceleration limit. On a line with unit direction
//    u: speed <= min(feed, min_i vmax_i / |u_i|) and tangential acceleration
//    <= min_i amax_i / |u_i| (exactly the largest that keeps every axis in its limit; a
//    diagonal gets sqrt(2) times an axis' limit). On an arc of radius r (programmed or blend)
//    the axes see a tangential part a_t u and a normal part (v^2 / r) n, over the range of
//    directions the arc sweeps. The speed is capped by v^2 / r <= f a_n, where a_n =
//    min_i amax_i / max |n_i| is the most normal acceleration the axes give everywhere on the
//    arc (f = curve_normal_fraction), by the axis speeds over the arc's tangents, and by the
//    chord between two servo samples (Koren's V T step) staying within delta of the arc:
//    (v T)^2 / (8 r) <= delta. At speed v the tangential acceleration is
//    A(v) = min over the arc and the axes of (amax_i - v^2 / r |n_i|) / |u_i|, computed
//    exactly (the arc's ends and the angles where |n_i| = v^2 / (r amax_i)). On a full circle
//    with equal axes this is sqrt(a^2 - (v^2/r)^2); on a short arc away from the axes it is
//    more. The jerk limit J is per axis too: on a line the path jerk may be
//    min_i J / |u_i|; on arcs it is J.
//
// 3. Velocity profile (look-ahead). Consecutive pieces whose caps agree within 0.5 % form a
//    zone (taking the smaller caps). Inside a zone the speed follows jerk-limited S-curves;
//    between zones, at the zone boundaries ("nodes"), the path acceleration is zero. A speed
//    change from v0 to v1 by one S-curve pulse with jerk J and acceleration at most A takes
//
//        T = 2 sqrt(dv / J)        when dv = |v1 - v0| <= A^2 / J  (triangular acceleration)
//        T = dv / A + A / J        otherwise                       (trapezoidal acceleration)
//
//    and, the pulse being symmetric in time, covers D(v0, v1) = (v0 + v1) / 2 * T. The node
//    speeds come from GRBL's two passes over the whole stretch (its planner.c "reverse pass"
//    and "forward pass"), with D in place of GRBL's (v1^2 - v0^2) / 2a: start at rest, end at
//    rest, each node at most the caps of both zones it joins (0 at a stop junction); backward,
//    each node is lowered so that the next node can still be reached by braking within the
//    zone between; forward, so that it can be reached by accelerating. Each zone then gets
//    accelerate / cruise / decelerate at the highest peak speed that fits its length. All of
//    this is computed in plan_stretch; sample() only evaluates the stored pieces. On zones with
//    arcs A depends on the speed (the smallest A(v) of the zone's arcs, tabulated on 33
//    speeds and read at the table speed at or above v); a speed change is split at 0.7 of the
//    zone's cap into two pulses, each using A at its top speed (low speeds leave more room
//    for a_t). The jerk limit costs a rest-to-rest move about a / J over the jerk-free
//    optimum (the acceleration must rise and fall); taking J per axis makes that 25 ms on
//    the gantry whatever the direction.
//
//    The zero-acceleration nodes cost a little time where caps change often (a spline cut
//    into segments of varying length); the figures in tests/motion show the price on the
//    usual shapes (duration / lower bound below 1.10).
//
// Real-time evaluation: sample(t) finds the profile phase by binary search on its start time
// (piecewise cubic s(t), v(t), a(t)), then the piece by binary search on its start length,
// and evaluates the geometry in closed form (engine/motion/interpolator.h, Koren's linear and
// circular steps without accumulation). No allocation, no throw, O(log n).
//
// The time-optimal motion on the same path (engine/motion/time_optimal.h) is the reference
// this planner is measured against (tests/motion/motion_time_test.cpp).
//
// Time lower bound. time_lower_bound_s() gives a time that no rest-to-rest motion along
// exactly the given path can beat with the same speed and acceleration limits (jerk
// ignored). The argument, per path length s:
//   * the speed v(s) is at most a ceiling c(s): the feed, the axis speeds
//     (min_i vmax_i / |u_i(s)|), and on an arc sqrt(r a_n(s)) where a_n(s) = min_i amax_i /
//     |n_i(s)| is the most normal acceleration the axes can give along the normal n(s);
//   * the speed is 0 at the start, at the end and at every junction where the direction jumps
//     (more than 1e-6 rad), since the velocity is continuous and parallel to both sides there;
//   * |d(v^2)/ds| = 2 |a_t| <= 2 A(s), A(s) = min_i amax_i / |u_i(s)| (the normal part is
//     ignored, which only makes the bound weaker and keeps it valid);
//   * so v(s) <= V(s), the largest function under the ceiling and the zeros with
//     |d(V^2)/ds| <= 2 A: V = min(c, forward envelope, backward envelope), the 1-D bang-bang
//     profile, computed exactly on pieces where c and A are replaced by their maxima over the
//     piece (arcs are cut into pieces of at most pi/32); and the time is at least
//     integral ds / V(s), which is integrated in closed form.
// A planner that rounds corners does not move along exactly the programmed path; to compare
// it with the bound, pass its executed path (PlannedTrajectory::executed_path()), which it
// follows exactly and within the same limits, so duration >= bound holds. The bound on the
// programmed path itself makes every corner a stop; a blending planner may beat it (that
// difference is the benefit of the path tolerance).
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "engine/motion/job.h"
#include "engine/motion/profile.h"

namespace machplan::motion {

struct PlannerOptions {
  // Per-axis speed limit (x, y), mm/s. Default: the thermal gantry, 4910 mm/min.
  Eigen::Vector2d max_velocity_mm_per_s = Eigen::Vector2d(4910.0 / 60.0, 4910.0 / 60.0);
  // Per-axis acceleration limit (x, y), mm/s^2. Default: the thermal gantry.
  Eigen::Vector2d max_acceleration_mm_per_s2 = Eigen::Vector2d(500.0, 500.0);
  // Jerk limit along the path (rate of change of the tangential acceleration), mm/s^3.
  double max_jerk_mm_per_s3 = 20000.0;
  // Largest distance a blended corner may leave the programmed path, mm.
  double path_tolerance_mm = 0.01;
  // The executor's sampling period, s (Koren's T): bounds the chord between two samples.
  double servo_period_s = 0.001;
  // On curves, the largest share f of the normal acceleration the axes can give everywhere on
  // the arc (min_i amax_i / max |n_i|) that v^2 / r may take at the cap speed; the rest is left
  // to speed changes (on a full circle with equal axes at least sqrt(1 - f^2) a of tangential
  // acceleration, more on arcs away from the axes). LinuxCNC's blends give 0.87 to the normal
  // part; 0.9 leaves at least 0.44 a for speed changes and keeps the executor's contour error
  // on the bundled parts within its 0.1 mm.
  double curve_normal_fraction = 0.9;

  // The two machines' defaults: the thermal gantry (v 81.8 mm/s, a 500 mm/s^2, j 20000) and
  // the NSK XY table (v 1200 mm/s, a 5000 mm/s^2, j 200000).
  static PlannerOptions thermal_gantry();
  static PlannerOptions xy_table();

  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// Turning angle above which a junction is a stop rather than a blend, rad (171 degrees).
inline constexpr double kStopAngleRad = 0.95 * 3.14159265358979323846;

// The trajectory plan_stretch builds. Beyond the Trajectory contract it exposes what it
// planned, for tests, the executor's checks and reports.
class PlannedTrajectory final : public Trajectory {
 public:
  double duration_s() const override { return duration_s_; }
  void sample(double t_s, Setpoint& out) const override;

  // The path actually followed: the programmed segments with corners replaced by blend arcs
  // (feeds: the programmed feed; blends: the smaller of their neighbours' feeds; source line:
  // the line of the segment the piece comes from, the later one for a blend).
  const Stretch& executed_path() const { return path_; }
  const Stretch* followed_path() const override { return &path_; }
  // The cruise left: to the end of the constant-speed phases at t_s and of the path piece the
  // tool is on, whichever comes first.
  double cruise_left_s(double t_s) const override;
  // Upper bound on the distance from any setpoint to the programmed path, mm (the largest
  // blend deviation; 0 when nothing was blended). At most path_tolerance_mm.
  double max_deviation_mm() const { return max_deviation_mm_; }
  double length_mm() const { return length_mm_; }
  // The path-speed profile: constant-jerk phases in time order, covering [0, duration_s()].
  const std::vector<ProfilePhase>& profile() const { return phases_; }
  // Number of junctions blended and of junctions where the tool stops (start/end excluded).
  int blended_junctions() const { return blended_; }
  int stop_junctions() const { return stops_; }

 private:
  friend std::unique_ptr<PlannedTrajectory> plan_stretch_detailed(const Stretch&, const PlannerOptions&);
  Stretch path_;
  std::vector<double> piece_s0_;    // start length of each executed piece
  std::vector<double> phase_t0_;    // start time of each phase (copy for the search)
  std::vector<ProfilePhase> phases_;
  double duration_s_ = 0.0, length_mm_ = 0.0, max_deviation_mm_ = 0.0;
  int blended_ = 0, stops_ = 0;
};

// Plans the stretch (see the file comment). Throws InputError when `options` is invalid, and
// InternalError (MACHPLAN_ASSERT: the caller built it wrong) when the stretch is malformed (no
// segments, vector sizes differ, a non-positive or non-finite feed, segments not contiguous
// within 1e-6 mm). Thread safe, deterministic.
std::unique_ptr<PlannedTrajectory> plan_stretch_detailed(const Stretch& stretch,
                                                         const PlannerOptions& options);
std::unique_ptr<Trajectory> plan_stretch(const Stretch& stretch, const PlannerOptions& options);

// Throws InternalError when the stretch is malformed (see plan_stretch_detailed).
void validate_stretch(const Stretch& stretch);

// The lower bound of the file comment, s, for motion along exactly `stretch`'s segments.
// Same preconditions and exceptions as plan_stretch.
double time_lower_bound_s(const Stretch& stretch, const PlannerOptions& options);

}  // namespace machplan::motion
