// The shortest time in which the machine can follow a given path: time-optimal path
// parameterisation under per-axis speed and acceleration limits (no jerk limit).
//
// The problem. The tool follows a path p(s) of lines and circular arcs, s the path length.
// Along it the motion is fully described by the path speed v(s) >= 0, or by x(s) = v(s)^2.
// The axis velocity and acceleration are
//
//     p' = v u(s),        p'' = a_t u(s) + kappa(s) x nL(s),    a_t = dv/dt = x'(s) / 2,
//
// where u is the unit tangent, nL the left normal and kappa the signed curvature (0 on a
// line, +-1/r on an arc). The machine's limits are a box, one bound per axis i:
//
//     |v u_i| <= vmax_i,   v <= feed(s),   |a_t u_i + kappa x nL_i| <= amax_i.
//
// For a fixed (s, x) the last line is a set of linear bounds on a_t: an interval, empty when
// x is so high that the normal part alone exceeds some axis limit. So every point of the
// path has a largest admissible x (the maximum velocity curve, MVC): the speed caps and the
// largest x for which the a_t interval is not empty (linear in x, found in closed form).
// At the start, the end and every junction where the tangent jumps the speed is 0.
//
// The method is the phase-plane / reachability one (Bobrow, Dubowsky and Gibson, "Time-optimal
// control of robotic manipulators along specified paths"; Pham and Pham, "A new approach to
// time-optimal path parameterization based on reachability analysis"): on a grid of path
// points, a backward pass lowers each x so that the rest of the path can still be braked to
// its zeros, x_k <= x_{k+1} - 2 ds a_min(s_{k+1}, x_{k+1}), and a forward pass keeps the
// speeds reachable, x_{k+1} <= x_k + 2 ds a_max(s_k, x_k), both clamped to the MVC. The time
// is the sum of 2 ds / (v_k + v_{k+1}) (constant a_t between grid points).
//
//   * On a line the box is constant, a_t in [-a, a] with a = min_i amax_i / |u_i|, and the
//     exact answer is the bang-bang trapezoid: a line is one grid step, integrated in closed
//     form, with no discretisation error.
//   * On an arc the geometry is evaluated exactly (the tangent and normal at each grid
//     angle, the true curvature 1/r), and the grid is fine (TimeOptimalOptions); the error
//     of the first-order step shrinks with the step (tests/motion/time_optimal_test.cpp
//     checks it against closed forms and against a grid four times finer).
//
// What it is for. This is the reference a planner is judged against: the minimum time of
// any motion along exactly this path within the speed and acceleration limits. Jerk is not
// limited, so a jerk-limited planner is necessarily slower by at least the time its
// acceleration takes to rise and fall. time_lower_bound_s (feed_planner.h) is a looser but
// cheaper bound: it ignores what turning costs on arcs.
#pragma once

#include <vector>

#include "engine/motion/feed_planner.h"
#include "engine/motion/job.h"

namespace machplan::motion {

struct TimeOptimalOptions {
  // Largest grid step along an arc, mm (> 0). Lines are one exact step whatever this is.
  double max_step_mm = 0.05;
  // Largest grid step along an arc, rad of turning (> 0): small arcs get enough points.
  double max_step_rad = 0.005;

  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// The optimal speed at the grid points, in order of path length (the first is 0, the last is
// the path's length). Between two points of a line the speed follows the bang-bang profile;
// between two points of an arc, constant tangential acceleration.
struct TimeOptimalProfile {
  std::vector<double> s_mm;
  std::vector<double> v_mm_per_s;
  double time_s = 0.0;
  double length_mm = 0.0;
};

// The profile and time of the file comment for `path` under `limits`' per-axis speed and
// acceleration (and the segments' feeds). Throws InputError when the options are invalid and
// InternalError when the stretch is malformed (the preconditions of plan_stretch). Deterministic,
// thread safe. O(number of grid points).
TimeOptimalProfile time_optimal_profile(const Stretch& path, const PlannerOptions& limits,
                                        const TimeOptimalOptions& options = {});
double time_optimal_s(const Stretch& path, const PlannerOptions& limits, const TimeOptimalOptions& options = {});

}  // namespace machplan::motion
