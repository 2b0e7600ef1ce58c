// Smooth plane curves (NURBS, interpolating cubics, ellipses, arcs seen through an affine map)
// turned into the lines-and-arcs vocabulary of contour.h, within a stated tolerance.
//
// Why arcs. A kerf offset of an arc is an arc, exactly; an offset of a polyline of chords is
// another polyline whose error adds to the chord error. So curves are approximated by biarcs:
// pairs of tangent-continuous arcs that interpolate the curve's end points and end tangents
// (Bolton, "Biarc curves", Computer-Aided Design 7(2), 1975; Meek and Walton, "Approximating
// smooth planar curves by arc splines", J. Comput. Appl. Math. 59, 1995). The result is G1
// (no corner where the curve has none), so an offset never opens a gap between spans.
//
// The fit. fit_arcs() takes the curve as a function of a parameter t on [t0, t1]. On one
// interval it builds the biarc of equal tangent lengths between c(t0), c(t1) with the curve's
// unit tangents there, and measures the largest distance from the curve to the biarc at
// kSamplesPerPiece interior parameters. Within the tolerance the two arcs are emitted;
// otherwise the interval is halved (up to a depth limit, after which the biarc is kept and
// the worst deviation is reported in the result). Tangents come from central differences, so
// the function must be defined (as the smooth continuation of the same piece) a hair outside
// [t0, t1]: 1e-7 of the interval on each side. A curve with corners must be cut at them by
// the caller (NURBS: at every distinct knot, see Nurbs::breaks()).
//
// The deviation is measured at samples, so a wiggle narrower than 1/kSamplesPerPiece of a
// piece can escape it; the pieces of smooth CAD curves are far smoother than that.
//
// Everything is in mm and pure; nothing throws except Nurbs::validate() and
// interpolate_cubic() on bad input (InputError naming the field with the reason, for the
// reader to turn into an InputError with its file and line).
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <vector>

#include <Eigen/Core>

namespace machplan {

// Interior samples per biarc at which the deviation is measured.
inline constexpr int kSamplesPerPiece = 8;

struct ArcFitResult {
  std::size_t spans = 0;         // spans appended
  double max_deviation_mm = 0.0; // largest deviation measured at the samples
  bool exhausted = false;        // stopped at `max_spans`: the polyline is incomplete
};

// Appends the spans approximating `curve` on [t0, t1] to an open polyline (arcs whose sagitta
// is below a hundredth of the tolerance are written as lines): the caller has
// already pushed c(t0) to `vertices`; for each span this pushes the span's bulge to `bulges`
// and its end point to `vertices` (bulge convention of contour.h). The last vertex pushed is
// c(t1) exactly. Spans shorter than 1e-12 mm are not emitted. `tolerance_mm` > 0.
// At most `max_depth` halvings per interval (default 24: 16 M pieces), and at most `max_spans`
// spans appended: past that the fit stops, with `exhausted` set (the caller refuses the curve),
// so that no curve, however absurd, costs more than a bounded amount of work.
ArcFitResult fit_arcs(const std::function<Eigen::Vector2d(double)>& curve, double t0, double t1,
                      double tolerance_mm, std::vector<Eigen::Vector2d>& vertices,
                      std::vector<double>& bulges, int max_depth = 24,
                      std::size_t max_spans = std::numeric_limits<std::size_t>::max());

// A non-uniform rational B-spline of degree p in the plane: control points P(i), weights
// w(i) > 0, knots u(0) <= ... <= u(n + p) for n control points. Its domain is
// [u(p), u(n)]; the curve is sum N(i,p)(t) w(i) P(i) / sum N(i,p)(t) w(i)
// (Piegl and Tiller, "The NURBS Book", 2nd ed., 1997, chapter 4).
struct Nurbs {
  int degree = 3;
  std::vector<Eigen::Vector2d> control;
  std::vector<double> weights;  // empty: all 1
  std::vector<double> knots;

  // Throws InputError unless 1 <= degree <= 30, n >= degree + 1, the knot count
  // is n + degree + 1, knots are finite and non-decreasing with a non-empty domain, and
  // weights (if any) are n finite positive numbers.
  void validate() const;
  // The distinct knot values inside the domain, first and last included: the curve is a
  // polynomial (rational) piece between two consecutive breaks.
  std::vector<double> breaks() const;
  // The point at t, computed with the polynomial piece of the knot span [u(k), u(k+1)]
  // (de Boor's algorithm on homogeneous points), so t may lie a little outside the span.
  // k must satisfy degree <= k < n with u(k) < u(k+1). span_of() finds it for t.
  Eigen::Vector2d point(double t, std::size_t k) const;
  std::size_t span_of(double t) const;
};

// The C2 cubic through `points` with chord-length parameters (the curve AutoCAD draws for a
// SPLINE defined by fit points). `start_tangent` / `end_tangent` fix the end directions
// when non-zero; otherwise the ends are natural (zero second derivative). Returns the
// Hermite derivative at each point with respect to the chord-length parameter; piece i runs
// over [s(i), s(i+1)], s the cumulative chord lengths. Needs >= 2 points with positive
// distances between consecutive ones (throws InputError::field("points", ...) otherwise).
struct CubicInterpolant {
  std::vector<Eigen::Vector2d> points;
  std::vector<Eigen::Vector2d> derivatives;
  std::vector<double> params;  // cumulative chord length, params[0] = 0

  // Point on piece i (params[i] <= t <= params[i+1], or a little outside).
  Eigen::Vector2d point(double t, std::size_t i) const;
};
CubicInterpolant interpolate_cubic(const std::vector<Eigen::Vector2d>& points,
                                   const Eigen::Vector2d& start_tangent = Eigen::Vector2d::Zero(),
                                   const Eigen::Vector2d& end_tangent = Eigen::Vector2d::Zero());

}  // namespace machplan
