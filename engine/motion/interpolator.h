// Real-time interpolation on lines and arcs: the position, direction and curvature of the
// tool point at a given path length along one Segment.
//
// Koren's interpolators (Koren, "Control of machine tools", section 3.1) run at the
// servo period T. The linear one adds, each period,
//
//     dX = T * Vx,   dY = T * Vy,   with  Vx = V * Lx / L,  Vy = V * Ly / L,
//
// where L is the segment length and (Lx, Ly) its components: the axis speeds are the path
// speed V split along the unit direction (Lx, Ly) / L. The circular one advances the angle by
//
//     alpha = V * T / R
//
// per period, so the tool moves between iterations along chords of length V T.
//
// We keep both ideas but not their accumulation. The feed planner gives the path length
// s(t) travelled at the sample instant exactly (a piecewise cubic in t), and the functions
// below turn s into a point in closed form:
//
//     line:  P(s) = A + s * u,                          u = (B - A) / L
//     arc:   P(s) = C + R (cos th, sin th),  th = th0 + sign(sweep) * s / R
//
// Summing the increments dX = T Vx, or stepping the angle by alpha, is the same computation
// written incrementally; evaluating at the absolute s instead means rounding errors never
// accumulate, so a long arc (or many turns of a circle) ends where its geometry says, and a
// sample at any t is independent of the samples before it. The velocity is V u (Koren's
// Vx = V Lx / L), and on an arc the acceleration gains the normal term V^2 / R towards the
// centre.
//
// The cost is one sine and one cosine per arc sample and a few multiplications per line
// sample; nothing allocates, throws or locks (see bench/motion_bench.cpp for the figure).
#pragma once

#include <Eigen/Core>

#include "engine/geometry/contour.h"

namespace machplan::motion {

// Geometry of a segment at one path length.
struct PathPoint {
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d tangent = Eigen::Vector2d::UnitX();  // unit direction of travel
  // Signed curvature, 1/mm: positive when the path turns left (counter-clockwise arc),
  // negative when it turns right, 0 on a line. The centripetal acceleration at speed v is
  // v^2 * curvature * left_normal, left_normal = (-tangent.y, tangent.x).
  double curvature_per_mm = 0.0;
};

// The point at path length `s_mm` from the segment's start, s clamped to [0, length(seg)].
// A zero-length line gives its start point and the x direction. Precondition: `seg` is a
// valid Segment (an arc has radius > 0).
PathPoint interpolate(const Segment& seg, double s_mm);

}  // namespace machplan::motion
