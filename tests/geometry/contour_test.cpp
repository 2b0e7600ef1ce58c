// Contracts of engine/geometry/contour.h: exact areas against closed-form formulas,
// orientation, lengths, distances, containment, intersections and degenerate input.
#include "engine/common/error.h"
#include "engine/common/internal/numbers.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/curve_fit.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace machplan {
namespace {

using Eigen::Vector2d;

Contour square(double side, bool ccw = true) {
  Contour c({{0, 0}, {side, 0}, {side, side}, {0, side}}, {0, 0, 0, 0});
  return ccw ? c : c.reversed();
}

TEST(Contour, SquareAreaPerimeterOrientation) {
  const double s = 37.5;
  EXPECT_NEAR(signed_area(square(s)), s * s, 1e-9);
  EXPECT_NEAR(signed_area(square(s, false)), -s * s, 1e-9);
  EXPECT_EQ(orientation(square(s)), Orientation::ccw);
  EXPECT_EQ(orientation(square(s, false)), Orientation::cw);
  EXPECT_NEAR(perimeter(square(s)), 4 * s, 1e-12);
  const auto box = bounding_box(square(s));
  EXPECT_EQ(box.min(), Vector2d(0, 0));
  EXPECT_EQ(box.max(), Vector2d(s, s));
}

TEST(Contour, CircleAreaIsExact) {
  for (double r : {0.5, 3.0, 125.0}) {
    const Vector2d c(10, -4);
    EXPECT_NEAR(signed_area(Contour::circle(c, r)), kPi * r * r, 1e-9 * r * r);
    EXPECT_NEAR(signed_area(Contour::circle(c, r, false)), -kPi * r * r, 1e-9 * r * r);
    EXPECT_NEAR(perimeter(Contour::circle(c, r)), 2 * kPi * r, 1e-9 * r);
    const auto box = bounding_box(Contour::circle(c, r));
    EXPECT_NEAR((box.min() - (c - Vector2d(r, r))).norm(), 0, 1e-9 * r);
    EXPECT_NEAR((box.max() - (c + Vector2d(r, r))).norm(), 0, 1e-9 * r);
  }
}

TEST(Contour, CircularSegmentAreaMatchesFormula) {
  // A chord from (-1, 0) to (1, 0) closed by an arc of sweep theta (bulge tan(theta/4)),
  // radius 1/sin(theta/2): the area is the circular segment r^2/2 (theta - sin theta).
  for (double theta : {0.3, 1.0, kPi / 2, kPi, 4.0, 6.0}) {
    const double bulge = std::tan(theta / 4);
    Contour c({{-1, 0}, {1, 0}}, {bulge, 0});
    const double r = 1 / std::sin(theta / 2);
    EXPECT_NEAR(signed_area(c), 0.5 * r * r * (theta - std::sin(theta)), 1e-9) << theta;
    EXPECT_NEAR(perimeter(c), r * theta + 2, 1e-9) << theta;
    const Segment s = c.span(0);
    ASSERT_TRUE(s.is_arc());
    EXPECT_NEAR(s.radius, r, 1e-9);
    EXPECT_NEAR(s.sweep, theta, 1e-12);
    EXPECT_NEAR((s.start - s.center).norm(), r, 1e-9);
    EXPECT_NEAR((s.end - s.center).norm(), r, 1e-9);
    const Vector2d end_from_angle = s.center + r * Vector2d(std::cos(s.end_angle()), std::sin(s.end_angle()));
    EXPECT_NEAR((end_from_angle - s.end).norm(), 0, 1e-9);
  }
}

TEST(Contour, SlotOfLinesAndHalfCircles) {
  const double w = 10, r = 5;
  Contour slot({{0, 0}, {w, 0}, {w, 2 * r}, {0, 2 * r}}, {0, 1, 0, 1});
  EXPECT_NEAR(signed_area(slot), w * 2 * r + kPi * r * r, 1e-9);
  EXPECT_NEAR(perimeter(slot), 2 * w + 2 * kPi * r, 1e-9);
  const auto box = bounding_box(slot);
  EXPECT_NEAR(box.min().x(), -r, 1e-12);
  EXPECT_NEAR(box.max().x(), w + r, 1e-12);
  EXPECT_NEAR(signed_area(slot.reversed()), -signed_area(slot), 1e-9);
  EXPECT_NEAR(perimeter(slot.reversed()), perimeter(slot), 1e-9);
  EXPECT_TRUE(self_intersections(slot).empty());
}

TEST(Contour, PointAtLengthWalksThePerimeter) {
  const Contour sq = square(10);
  EXPECT_NEAR((point_at_length(sq, 15) - Vector2d(10, 5)).norm(), 0, 1e-12);
  EXPECT_NEAR((point_at_length(sq, -5) - Vector2d(0, 5)).norm(), 0, 1e-12);
  EXPECT_NEAR((point_at_length(sq, 40 + 1) - Vector2d(1, 0)).norm(), 0, 1e-12);
  const Contour circ = Contour::circle({0, 0}, 2);
  const Vector2d q = point_at_length(circ, kPi);  // a quarter of the way round
  EXPECT_NEAR((q - Vector2d(0, 2)).norm(), 0, 1e-12);
}

TEST(Contour, DistancesAndClosestPoints) {
  const Contour sq = square(10);
  EXPECT_NEAR(distance(sq, {5, -3}), 3, 1e-12);
  EXPECT_NEAR(distance(sq, {5, 4}), 4, 1e-12);
  EXPECT_NEAR(distance(sq, {13, 14}), 5, 1e-12);
  const auto cp = closest_point(sq, {12, 5});
  EXPECT_EQ(cp.span, 1u);
  EXPECT_NEAR((cp.point - Vector2d(10, 5)).norm(), 0, 1e-12);
  const Contour circ = Contour::circle({1, 1}, 3);
  EXPECT_NEAR(distance(circ, {1, 1}), 3, 1e-12);
  EXPECT_NEAR(distance(circ, {1 + 10, 1}), 7, 1e-12);
  EXPECT_NEAR(distance(circ, {1, 1 - 1}), 2, 1e-12);
}

// The shared span helpers: point-to-segment distance, parameters, tangents, angle wrapping.
TEST(SegmentHelpers, PointSegmentDistanceFootAndEnds) {
  const Vector2d a(1, 1), b(7, 9);  // length 10, direction (0.6, 0.8)
  // A point 2 mm off the middle along the left normal (-0.8, 0.6): foot at the middle.
  const Vector2d mid = 0.5 * (a + b), off = mid + 2.0 * Vector2d(-0.8, 0.6);
  EXPECT_NEAR(point_segment_distance(off, a, b), 2.0, 1e-12);
  EXPECT_NEAR((closest_point_on_segment(a, b, off) - mid).norm(), 0.0, 1e-12);
  // Beyond either end the nearest point is that end.
  EXPECT_NEAR(point_segment_distance(a - Vector2d(3, 4), a, b), 5.0, 1e-12);
  EXPECT_EQ(closest_point_on_segment(a, b, b + Vector2d(0.6, 0.8)), b);
  // A degenerate segment is its point.
  EXPECT_NEAR(point_segment_distance({4, 5}, a, a), 5.0, 1e-12);
}

TEST(SegmentHelpers, ParameterAndTangents) {
  const Segment l = make_segment({0, 0}, {10, 0}, 0.0);
  EXPECT_NEAR(parameter_at(l, {2.5, 0}), 0.25, 1e-12);
  EXPECT_EQ(parameter_at(l, {-3, 0}), 0.0);
  EXPECT_EQ(start_tangent(l), Vector2d(1, 0));
  // A clockwise quarter circle of radius 5 about the origin from (0, 5) to (5, 0).
  const Segment cw = make_segment({0, 5}, {5, 0}, -std::tan(kPi / 8));
  ASSERT_TRUE(cw.is_arc());
  const Vector2d q(5 * std::cos(kPi / 3), 5 * std::sin(kPi / 3));  // 30 degrees into the arc
  EXPECT_NEAR(parameter_at(cw, q), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR((start_tangent(cw) - Vector2d(1, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((end_tangent(cw) - Vector2d(0, -1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((tangent_at(cw, q) - Vector2d(std::sin(kPi / 3), -std::cos(kPi / 3))).norm(), 0.0, 1e-12);
  // Angles just outside the arc map to the nearer end.
  EXPECT_EQ(parameter_at(cw, {-1, 5}), 0.0);
  EXPECT_EQ(parameter_at(cw, {5, -1}), 1.0);
  EXPECT_NEAR(cross({1, 0}, {0, 1}), 1.0, 0.0);
  EXPECT_NEAR(wrap_angle_positive(-kPi / 2), 1.5 * kPi, 1e-12);
  EXPECT_NEAR(wrap_angle_positive(5 * kPi), kPi, 1e-12);
  EXPECT_EQ(wrap_angle_positive(2 * kPi), 0.0);
}

TEST(Contour, ContainmentWithArcsBothOrientations) {
  const double w = 10, r = 5;
  Contour slot({{0, 0}, {w, 0}, {w, 2 * r}, {0, 2 * r}}, {0, 1, 0, 1});
  for (const Contour& c : {slot, slot.reversed()}) {
    EXPECT_TRUE(contains(c, {5, 5}));
    EXPECT_TRUE(contains(c, {w + r - 0.01, r}));   // inside the right half circle
    EXPECT_TRUE(contains(c, {-r + 0.01, r}));      // inside the left one
    EXPECT_FALSE(contains(c, {w + r + 0.01, r}));
    EXPECT_FALSE(contains(c, {w + 4.9, 0.1}));     // beyond the arc, inside its bounding box
    EXPECT_FALSE(contains(c, {5, -0.01}));
  }
  EXPECT_EQ(winding_number(slot, {5, 5}), 1);
  // Points on the chord of a half circle (the circle's own diameter) are inside.
  const Contour circ = Contour::circle({360, 150}, 100);
  EXPECT_TRUE(contains(circ, {420, 150}));
  EXPECT_TRUE(contains(circ.reversed(), {300, 150}));
  EXPECT_FALSE(contains(circ, {470, 150}));
  EXPECT_EQ(winding_number(slot.reversed(), {5, 5}), -1);
  // Major arc: a 300-degree arc closed by its chord holds its centre.
  const double bulge = std::tan(300.0 / 180.0 * kPi / 4);
  Contour major({{1, 0}, {0.5, -std::sqrt(3) / 2}}, {bulge, 0});
  EXPECT_TRUE(contains(major, major.span(0).center));
  EXPECT_FALSE(contains(major, {0.9, -0.6}));  // inside the circle but cut off by the chord
}

TEST(Intersect, LineLine) {
  const Segment a = make_segment({0, 0}, {10, 10}, 0), b = make_segment({0, 10}, {10, 0}, 0);
  auto hit = intersect(a, b);
  ASSERT_EQ(hit.points.size(), 1u);
  EXPECT_NEAR((hit.points[0] - Vector2d(5, 5)).norm(), 0, 1e-12);
  EXPECT_TRUE(intersect(a, make_segment({6, 0}, {10, 0}, 0)).empty());
  EXPECT_TRUE(intersect(a, make_segment({1, 0}, {11, 10}, 0)).empty());  // parallel apart
  hit = intersect(a, make_segment({5, 5}, {20, 20}, 0));                 // collinear overlap
  EXPECT_TRUE(hit.overlap);
  ASSERT_EQ(hit.points.size(), 2u);
  EXPECT_NEAR((hit.points[0] - Vector2d(5, 5)).norm(), 0, 1e-12);
  EXPECT_NEAR((hit.points[1] - Vector2d(10, 10)).norm(), 0, 1e-12);
  hit = intersect(a, make_segment({10, 10}, {20, 20}, 0));  // end to end
  EXPECT_FALSE(hit.overlap);
  ASSERT_EQ(hit.points.size(), 1u);
}

TEST(Intersect, LineArcAndArcArc) {
  const Segment upper = make_segment({2, 0}, {-2, 0}, 1);  // ccw half circle r 2, through (0, 2)
  auto hit = intersect(make_segment({-5, 1}, {5, 1}, 0), upper);
  ASSERT_EQ(hit.points.size(), 2u);
  for (const auto& p : hit.points) EXPECT_NEAR(p.norm(), 2, 1e-12);
  EXPECT_TRUE(intersect(make_segment({-5, -1}, {5, -1}, 0), upper).empty());  // misses the half
  hit = intersect(make_segment({-5, 2}, {5, 2}, 0), upper, 1e-9);             // tangent
  ASSERT_EQ(hit.points.size(), 1u);
  EXPECT_NEAR((hit.points[0] - Vector2d(0, 2)).norm(), 0, 1e-6);

  const Segment other = make_segment({4, 0}, {0, 0}, 1);  // circle r 2 about (2, 0), upper half
  hit = intersect(upper, other);
  ASSERT_EQ(hit.points.size(), 1u);
  EXPECT_NEAR((hit.points[0] - Vector2d(1, std::sqrt(3))).norm(), 0, 1e-12);

  const Segment lower = make_segment({-2, 0}, {2, 0}, 1);  // the other half of the same circle
  hit = intersect(upper, lower);
  EXPECT_FALSE(hit.overlap);
  EXPECT_EQ(hit.points.size(), 2u);
  const Segment quarter = make_segment({0, 2}, {-2, 0}, std::tan(kPi / 8));
  EXPECT_TRUE(intersect(upper, quarter).overlap);
}

TEST(SelfIntersections, BowTieAndSimple) {
  Contour bow({{0, 0}, {10, 10}, {10, 0}, {0, 10}}, {0, 0, 0, 0});
  const auto hits = self_intersections(bow);
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_NEAR((hits[0].point - Vector2d(5, 5)).norm(), 0, 1e-9);
  EXPECT_NEAR(signed_area(bow), 0, 1e-9);  // the two lobes cancel
  EXPECT_TRUE(self_intersections(square(10)).empty());
  EXPECT_TRUE(self_intersections(Contour::circle({0, 0}, 1)).empty());
  // A line that doubles back over the previous one.
  Contour spike({{0, 0}, {10, 0}, {5, 0}, {5, 5}}, {0, 0, 0, 0});
  EXPECT_FALSE(self_intersections(spike).empty());
  // An arc that cuts through a line of the same contour.
  Contour cut({{0, 0}, {10, 0}, {10, 4}, {0, 4}}, {0, 0, 0, -2.0});
  EXPECT_FALSE(self_intersections(cut).empty());
}

TEST(Degenerate, ZeroLengthSpansAndHugeBulges) {
  // A repeated vertex with a bulge is a zero-length span; it changes nothing.
  Contour c({{0, 0}, {10, 0}, {10, 0}, {10, 10}, {0, 10}}, {0, 5.0, 0, 0, 0});
  EXPECT_NEAR(signed_area(c), 100, 1e-9);
  EXPECT_NEAR(perimeter(c), 40, 1e-9);
  EXPECT_TRUE(self_intersections(c, 1e-6).empty());
  EXPECT_FALSE(c.span(1).is_arc());
  // One vertex: a point.
  Contour point({{3, 4}}, {1.0});
  EXPECT_EQ(signed_area(point), 0.0);
  EXPECT_EQ(orientation(point), Orientation::degenerate);
  EXPECT_NEAR(distance(point, {0, 0}), 5, 1e-12);
  EXPECT_EQ(point_at_length(point, 3), Vector2d(3, 4));
  EXPECT_FALSE(contains(point, {3, 4}));
  // Largest bulge allowed: nearly a full circle, still finite everywhere.
  Contour big({{0, 0}, {1e-3, 0}}, {kMaxBulge, 0});
  EXPECT_TRUE(std::isfinite(signed_area(big)));
  EXPECT_TRUE(std::isfinite(perimeter(big)));
  EXPECT_TRUE(bounding_box(big).sizes().allFinite());
  // Tiny bulges are straight.
  EXPECT_FALSE(make_segment({0, 0}, {1, 0}, 1e-300).is_arc());
}

TEST(Degenerate, NonFiniteInputIsRejected) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Contour({{0, nan}}, {0}), InputError);
  EXPECT_THROW(Contour({{inf, 0}}, {0}), InputError);
  EXPECT_THROW(Contour({{0, 0}, {1, 0}}, {0, nan}), InputError);
  EXPECT_THROW(Contour({{0, 0}, {1, 0}}, {0, 2 * kMaxBulge}), InputError);
  EXPECT_THROW(Contour({{2 * kMaxCoordinateMm, 0}}, {0}), InputError);
  EXPECT_THROW(Contour({{0, 0}}, {}), InputError);
  EXPECT_THROW(Contour({}, {}), InputError);
  EXPECT_THROW(Contour::circle({0, 0}, 0), InputError);
  EXPECT_THROW(Contour::circle({0, 0}, nan), InputError);
  try {
    Contour({{0, 0}, {1, nan}}, {0, 0});
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 1"), std::string::npos) << e.what();
  }
}

TEST(ContourIntersections, TouchingAndNested) {
  const Contour a = square(10);
  Contour inner({{2, 2}, {4, 2}, {4, 4}, {2, 4}}, {0, 0, 0, 0});
  EXPECT_TRUE(contour_intersections(a, inner).empty());
  Contour crossing({{5, 5}, {15, 5}, {15, 15}, {5, 15}}, {0, 0, 0, 0});
  EXPECT_EQ(contour_intersections(a, crossing).size(), 2u);
  EXPECT_FALSE(contour_intersections(a, Contour::circle({10, 5}, 1)).empty());
}

TEST(BoxPairs, SweepFindsExactlyTheIntersectingPairs) {
  // Pseudo-random boxes of mixed shapes (long, thin, square, empty): the sweep must report
  // each intersecting pair once and nothing else, as the all-pairs definition says.
  std::vector<Eigen::AlignedBox2d> boxes;
  unsigned seed = 12345;
  auto next = [&] {
    seed = seed * 1103515245u + 12345u;
    return static_cast<double>((seed >> 8) % 10000) / 100.0;
  };
  for (int i = 0; i < 400; ++i) {
    const Vector2d lo(next(), next());
    const Vector2d size(i % 7 == 0 ? 60 : next() / 10, i % 11 == 0 ? 60 : next() / 10);
    boxes.emplace_back(lo, lo + size);
  }
  boxes.emplace_back();  // empty: takes part in no pair
  std::set<std::pair<std::size_t, std::size_t>> seen;
  for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) {
    ASSERT_NE(a, b);
    EXPECT_TRUE(seen.insert({std::min(a, b), std::max(a, b)}).second) << "pair reported twice";
  });
  std::size_t expected = 0;
  for (std::size_t a = 0; a < boxes.size(); ++a)
    for (std::size_t b = a + 1; b < boxes.size(); ++b)
      if (!boxes[a].isEmpty() && !boxes[b].isEmpty() && boxes[a].intersects(boxes[b])) {
        ++expected;
        EXPECT_TRUE(seen.count({a, b})) << a << " " << b;
      }
  EXPECT_EQ(seen.size(), expected);
  EXPECT_GT(expected, 100u);
}

TEST(CurveFit, BiarcsFollowAParabolaWithinToleranceAndWithoutCorners) {
  auto parabola = [](double t) { return Vector2d(t, 0.05 * t * t); };
  std::vector<Vector2d> v;
  std::vector<double> b;
  const double tol = 0.002;
  const ArcFitResult r = fit_arcs(parabola, -40, 40, tol, v, b);
  ASSERT_EQ(v.size(), b.size() + 1);
  EXPECT_EQ(r.spans, b.size());
  EXPECT_LE(r.max_deviation_mm, tol);
  EXPECT_NEAR((v.front() - parabola(-40)).norm(), 0, 1e-12);
  EXPECT_NEAR((v.back() - parabola(40)).norm(), 0, 1e-12);
  std::vector<Segment> segs;
  for (std::size_t i = 0; i < b.size(); ++i) segs.push_back(make_segment(v[i], v[i + 1], b[i]));
  // Dense check, between the fitter's own samples.
  double worst = 0;
  for (int i = 0; i <= 20000; ++i) {
    const Vector2d p = parabola(-40 + 80.0 * i / 20000);
    double d = std::numeric_limits<double>::infinity();
    for (const auto& s : segs) d = std::min(d, (closest_point(s, p) - p).norm());
    worst = std::max(worst, d);
  }
  EXPECT_LE(worst, tol * 1.05);
  for (std::size_t i = 0; i + 1 < segs.size(); ++i) {
    const Vector2d a = end_tangent(segs[i]), c = start_tangent(segs[i + 1]);
    EXPECT_LT(std::abs(cross(a, c)), 1e-9) << "corner between spans " << i << " and " << i + 1;
  }
}

TEST(CurveFit, NurbsAndInterpolantsEvaluateAndValidate) {
  // A clamped linear B-spline is its control polygon.
  Nurbs line{1, {{0, 0}, {10, 0}, {10, 5}}, {}, {0, 0, 1, 2, 2}};
  EXPECT_NO_THROW(line.validate());
  EXPECT_NEAR((line.point(0.5, line.span_of(0.5)) - Vector2d(5, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((line.point(1.5, line.span_of(1.5)) - Vector2d(10, 2.5)).norm(), 0, 1e-12);
  EXPECT_EQ(line.breaks(), (std::vector<double>{0, 1, 2}));
  Nurbs bad = line;
  bad.knots = {0, 0, 2, 1, 2};
  EXPECT_THROW(bad.validate(), InputError);
  bad = line;
  bad.knots.pop_back();
  EXPECT_THROW(bad.validate(), InputError);
  bad = line;
  bad.weights = {1, -1, 1};
  EXPECT_THROW(bad.validate(), InputError);
  // The cubic through points: passes through them, with the asked end direction.
  const std::vector<Vector2d> pts = {{0, 0}, {3, 4}, {6, 0}, {10, 1}};
  const CubicInterpolant ci = interpolate_cubic(pts, Vector2d(0, 2), Vector2d::Zero());
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    EXPECT_NEAR((ci.point(ci.params[i], i) - pts[i]).norm(), 0, 1e-12);
    EXPECT_NEAR((ci.point(ci.params[i + 1], i) - pts[i + 1]).norm(), 0, 1e-12);
  }
  EXPECT_NEAR(ci.derivatives[0].x(), 0, 1e-12);
  EXPECT_THROW(interpolate_cubic({{1, 1}, {1, 1}}), InputError);
  EXPECT_THROW(interpolate_cubic({{1, 1}}), InputError);
}

}  // namespace
}  // namespace machplan
