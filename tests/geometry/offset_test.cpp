// Contracts of engine/geometry/offset.h: every point of the offset lies at exactly |d| from
// the contour, the offset region is the grown / shrunk region (checked point by point against
// the distance function), closed-form areas for convex and concave shapes, exact arcs, and
// the reported problems for arcs that collapse and features narrower than 2|d|.
#include "engine/geometry/offset.h"
#include "tests/support/shapes.h"
#include "engine/common/internal/numbers.h"

#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

using test::polygon;

using test::rectangle;

std::vector<Vector2d> samples(const Contour& c, int per_span = 9) {
  std::vector<Vector2d> out;
  for (const auto& s : c.segments())
    for (int k = 0; k <= per_span; ++k) out.push_back(point_at(s, double(k) / per_span));
  return out;
}

// Every sampled point of every result contour is at |d| from the original.
void expect_at_distance(const Contour& original, const OffsetResult& r, double d, const std::string& what) {
  for (std::size_t k = 0; k < r.contours.size(); ++k)
    for (const auto& p : samples(r.contours[k]))
      ASSERT_NEAR(distance(original, p), std::abs(d), 1e-6) << what << " contour " << k << " at (" << p.x() << ", "
                                                            << p.y() << ")";
}

void expect_simple_and_disjoint(const OffsetResult& r, const std::string& what) {
  for (std::size_t k = 0; k < r.contours.size(); ++k) {
    EXPECT_TRUE(self_intersections(r.contours[k], 1e-7).empty()) << what << " contour " << k;
    for (std::size_t l = k + 1; l < r.contours.size(); ++l)
      EXPECT_TRUE(contour_intersections(r.contours[k], r.contours[l], 1e-7).empty()) << what << " " << k << "/" << l;
  }
}

// Membership in the offset region by the non-zero rule over all result contours.
bool in_result(const OffsetResult& r, const Vector2d& p) {
  int w = 0;
  for (const auto& c : r.contours) w += winding_number(c, p);
  return w != 0;
}

// The result region equals the grown / shrunk region at random points away from its edge.
void expect_region(const Contour& original, const OffsetResult& r, double d, std::mt19937& rng, int count,
                   const std::string& what) {
  auto box = bounding_box(original);
  const Vector2d lo = box.min() - Vector2d::Constant(std::abs(d) + 1), hi = box.max() + Vector2d::Constant(std::abs(d) + 1);
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
  for (int i = 0; i < count; ++i) {
    const Vector2d p(ux(rng), uy(rng));
    const double dist = distance(original, p);
    if (std::abs(dist - std::abs(d)) < 1e-5 || dist < 1e-5) continue;
    const bool inside = contains(original, p);
    const bool expected = d > 0 ? (inside || dist < d) : (inside && dist > -d);
    ASSERT_EQ(in_result(r, p), expected) << what << " at (" << p.x() << ", " << p.y() << "), distance " << dist;
  }
}

int count_kind(const OffsetResult& r, OffsetProblem::Kind k) {
  int n = 0;
  for (const auto& p : r.problems) n += p.kind == k;
  return n;
}

TEST(Offset, CircleChangesRadiusBothWaysBothOrientations) {
  const Vector2d c(3, -7);
  for (bool ccw : {true, false})
    for (double r : {2.0, 10.0})
      for (double d : {-1.5, 0.25, 4.0}) {
        const Contour circle = Contour::circle(c, r, ccw);
        const OffsetResult res = offset_contour(circle, d);
        ASSERT_EQ(res.contours.size(), 1u);
        EXPECT_TRUE(res.problems.empty());
        const Contour& o = res.contours[0];
        for (const auto& s : o.segments()) {
          ASSERT_TRUE(s.is_arc());
          EXPECT_NEAR(s.radius, r + d, 1e-9);
          EXPECT_NEAR((s.center - c).norm(), 0.0, 1e-9);
        }
        EXPECT_NEAR(std::abs(signed_area(o)), kPi * (r + d) * (r + d), 1e-8);
        EXPECT_EQ(orientation(o), ccw ? Orientation::ccw : Orientation::cw);
      }
}

TEST(Offset, CircleShrunkPastItsRadiusVanishes) {
  const OffsetResult res = offset_contour(Contour::circle({0, 0}, 2.0), -2.5);
  EXPECT_TRUE(res.vanished());
  EXPECT_EQ(count_kind(res, OffsetProblem::Kind::contour_vanished), 1);
  EXPECT_EQ(count_kind(res, OffsetProblem::Kind::arc_collapsed), 2);
}

TEST(Offset, RectangleOutwardGetsFourQuarterArcs) {
  const double w = 30, h = 12, d = 1.75;
  for (bool ccw : {true, false}) {
    const Contour rect = ccw ? rectangle(0, 0, w, h) : rectangle(0, 0, w, h).reversed();
    const OffsetResult res = offset_contour(rect, d);
    ASSERT_EQ(res.contours.size(), 1u);
    const Contour& o = res.contours[0];
    int lines = 0, arcs = 0;
    for (const auto& s : o.segments()) {
      if (s.is_arc()) {
        ++arcs;
        EXPECT_NEAR(s.radius, d, 1e-9);
        EXPECT_NEAR(std::abs(s.sweep), kPi / 2, 1e-9);
        EXPECT_EQ(s.sweep > 0, ccw);
        // Centred on a corner of the rectangle.
        EXPECT_NEAR(std::min(std::abs(s.center.x()), std::abs(s.center.x() - w)), 0, 1e-9);
        EXPECT_NEAR(std::min(std::abs(s.center.y()), std::abs(s.center.y() - h)), 0, 1e-9);
      } else {
        ++lines;
      }
    }
    EXPECT_EQ(lines, 4);
    EXPECT_EQ(arcs, 4);
    EXPECT_NEAR(std::abs(signed_area(o)), w * h + 2 * (w + h) * d + kPi * d * d, 1e-9);
    EXPECT_EQ(orientation(o), ccw ? Orientation::ccw : Orientation::cw);
    EXPECT_TRUE(res.problems.empty());
    expect_at_distance(rect, res, d, "rectangle");
  }
}

TEST(Offset, RectangleInwardKeepsSharpCorners) {
  const OffsetResult res = offset_contour(rectangle(0, 0, 30, 12), -2.0);
  ASSERT_EQ(res.contours.size(), 1u);
  const Contour& o = res.contours[0];
  EXPECT_EQ(o.size(), 4u);
  for (const auto& s : o.segments()) EXPECT_FALSE(s.is_arc());
  EXPECT_NEAR(signed_area(o), 26.0 * 8.0, 1e-9);
  const auto box = bounding_box(o);
  EXPECT_NEAR((box.min() - Vector2d(2, 2)).norm(), 0, 1e-9);
  EXPECT_NEAR((box.max() - Vector2d(28, 10)).norm(), 0, 1e-9);
}

TEST(Offset, ConvexOutwardAreaIsAreaPlusPerimeterTimesDPlusPiDSquared) {
  // Convex shapes with lines and convex arcs: a rounded triangle, a stadium, a hexagon, a
  // D shape.
  std::vector<Contour> shapes = {
      Contour({{0, 0}, {10, 0}, {4, 7}}, {0.2, 0.1, 0.0}),
      Contour({{0, 0}, {20, 0}, {20, 6}, {0, 6}}, {0, 1, 0, 1}),
      polygon({{5, 0}, {2.5, 4.33}, {-2.5, 4.33}, {-5, 0}, {-2.5, -4.33}, {2.5, -4.33}}).reversed(),
      Contour({{0, -5}, {0, 5}}, {0, 1}).reversed(),
  };
  for (std::size_t i = 0; i < shapes.size(); ++i)
    for (double d : {0.1, 1.0, 7.5}) {
      const Contour& c = shapes[i];
      const OffsetResult res = offset_contour(c, d);
      ASSERT_EQ(res.contours.size(), 1u) << i;
      const double a = std::abs(signed_area(c)), p = perimeter(c);
      EXPECT_NEAR(std::abs(signed_area(res.contours[0])), a + p * d + kPi * d * d, 1e-9 * (1 + a)) << i << " d " << d;
      EXPECT_NEAR(perimeter(res.contours[0]), p + 2 * kPi * d, 1e-9 * (1 + p)) << i;
      EXPECT_EQ(orientation(res.contours[0]), orientation(c));
      expect_at_distance(c, res, d, "convex " + std::to_string(i));
    }
}

// An L: 20 x 20 square minus its top-right 10 x 10 quarter. One reflex corner at (10, 10).
Contour l_shape() { return polygon({{0, 0}, {20, 0}, {20, 10}, {10, 10}, {10, 20}, {0, 20}}); }

TEST(Offset, ConcaveLShapeOutwardTrimsTheInnerCorner) {
  const Contour l = l_shape();
  const double d = 2.0, a = 300.0, p = 80.0;
  const OffsetResult res = offset_contour(l, d);
  ASSERT_EQ(res.contours.size(), 1u);
  const Contour& o = res.contours[0];
  int lines = 0, arcs = 0;
  for (const auto& s : o.segments()) (s.is_arc() ? arcs : lines)++;
  EXPECT_EQ(lines, 6);
  EXPECT_EQ(arcs, 5);
  // Five convex quarter sectors, minus the d x d square where the two strips at the reflex
  // corner overlap.
  EXPECT_NEAR(signed_area(o), a + p * d + 5 * (kPi / 4) * d * d - d * d, 1e-9);
  // The trimmed corner is a vertex of the result at (12, 12).
  bool corner = false;
  for (const auto& v : o.vertices()) corner = corner || (v - Vector2d(12, 12)).norm() < 1e-9;
  EXPECT_TRUE(corner);
  expect_at_distance(l, res, d, "L out");
  expect_simple_and_disjoint(res, "L out");
  EXPECT_TRUE(res.problems.empty());
}

TEST(Offset, ConcaveLShapeInwardRoundsTheReflexCorner) {
  const Contour l = l_shape();
  const double d = 2.0, a = 300.0, p = 80.0;
  const OffsetResult res = offset_contour(l, -d);
  ASSERT_EQ(res.contours.size(), 1u);
  const Contour& o = res.contours[0];
  int arcs = 0;
  for (const auto& s : o.segments())
    if (s.is_arc()) {
      ++arcs;
      EXPECT_NEAR((s.center - Vector2d(10, 10)).norm(), 0, 1e-9);
      EXPECT_NEAR(s.radius, d, 1e-9);
      EXPECT_NEAR(s.sweep, -kPi / 2, 1e-9);
    }
  EXPECT_EQ(arcs, 1);
  // Five convex corners each lose a d x d square's worth (d^2 tan 45), the reflex corner
  // loses a quarter disc.
  EXPECT_NEAR(signed_area(o), a - p * d + 5 * d * d - (kPi / 4) * d * d, 1e-9);
  expect_at_distance(l, res, -d, "L in");
  expect_simple_and_disjoint(res, "L in");
}

TEST(Offset, ConcaveArcCollapsesAndIsReported) {
  // A square with a concave quarter-circle notch of radius 1 at its top-right corner.
  const double b = -std::tan(kPi / 8);  // clockwise quarter arc
  const Contour c({{0, 0}, {10, 0}, {10, 9}, {9, 10}, {0, 10}}, {0, 0, b, 0, 0});
  ASSERT_TRUE(c.span(2).is_arc());
  const OffsetResult grown = offset_contour(c, 1.5);
  ASSERT_EQ(grown.contours.size(), 1u);
  ASSERT_EQ(count_kind(grown, OffsetProblem::Kind::arc_collapsed), 1);
  EXPECT_EQ(grown.problems.front().span, 2u);
  expect_at_distance(c, grown, 1.5, "notch");
  expect_simple_and_disjoint(grown, "notch");
  std::mt19937 rng(7);
  expect_region(c, grown, 1.5, rng, 3000, "notch");
  // A smaller offset keeps the arc, with radius 1 - 0.5.
  const OffsetResult small = offset_contour(c, 0.5);
  EXPECT_TRUE(small.problems.empty());
  bool found = false;
  for (const auto& s : small.contours.at(0).segments())
    found = found || (s.is_arc() && std::abs(s.radius - 0.5) < 1e-9 && (s.center - Vector2d(10, 10)).norm() < 1e-9);
  EXPECT_TRUE(found);
}

TEST(Offset, StadiumSlotShrinksOrVanishes) {
  // A 30 x 4 slot with round ends.
  const Contour slot({{0, 0}, {30, 0}, {30, 4}, {0, 4}}, {0, 1, 0, 1});
  const OffsetResult thin = offset_contour(slot, -1.5);
  ASSERT_EQ(thin.contours.size(), 1u);
  EXPECT_NEAR(signed_area(thin.contours[0]), 30 * 1 + kPi * 0.25, 1e-9);
  EXPECT_TRUE(thin.problems.empty());
  const OffsetResult gone = offset_contour(slot, -2.5);
  EXPECT_TRUE(gone.vanished());
  EXPECT_EQ(count_kind(gone, OffsetProblem::Kind::contour_vanished), 1);
  EXPECT_EQ(count_kind(gone, OffsetProblem::Kind::arc_collapsed), 2);
  // A square-ended slot narrower than 2|d| vanishes too, with no arc to collapse.
  const OffsetResult gone2 = offset_contour(rectangle(0, 0, 30, 2), -1.2);
  EXPECT_TRUE(gone2.vanished());
  EXPECT_EQ(count_kind(gone2, OffsetProblem::Kind::contour_vanished), 1);
}

TEST(Offset, DumbbellSplitsAndReportsTheNeck) {
  // Two 20 x 20 squares joined by a 10 long, 2 wide neck; shrinking by 1.5 cuts the neck.
  const Contour db = polygon({{0, 0}, {20, 0}, {20, 9}, {30, 9}, {30, 0}, {50, 0}, {50, 20}, {30, 20}, {30, 11},
                              {20, 11}, {20, 20}, {0, 20}});
  const double d = -1.5;
  const OffsetResult res = offset_contour(db, d);
  ASSERT_EQ(res.contours.size(), 2u);
  for (const auto& c : res.contours) {
    EXPECT_EQ(orientation(c), Orientation::ccw);
    // (20 - 3)^2 plus the small bulge toward the neck mouth.
    EXPECT_GT(signed_area(c), 17.0 * 17.0);
    EXPECT_LT(signed_area(c), 17.0 * 17.0 + 2.0);
  }
  EXPECT_TRUE(in_result(res, {10, 10}));
  EXPECT_TRUE(in_result(res, {40, 10}));
  EXPECT_FALSE(in_result(res, {25, 10}));
  std::vector<std::size_t> lost;
  for (const auto& p : res.problems) {
    EXPECT_EQ(p.kind, OffsetProblem::Kind::feature_too_small) << p.message;
    lost.push_back(p.span);
  }
  EXPECT_EQ(lost, (std::vector<std::size_t>{2, 8}));  // the neck's two long sides
  expect_at_distance(db, res, d, "dumbbell");
  expect_simple_and_disjoint(res, "dumbbell");
  std::mt19937 rng(11);
  expect_region(db, res, d, rng, 3000, "dumbbell");
  // A wider neck survives: one contour, no problem.
  const OffsetResult wide = offset_contour(db, -0.9);
  EXPECT_EQ(wide.contours.size(), 1u);
  EXPECT_TRUE(wide.problems.empty());
}

TEST(Offset, NarrowNotchIsFilledWhenGrowingAndReported) {
  // A 40 x 20 plate with a 2 wide, 10 deep slot cut into its top edge.
  const Contour plate =
      polygon({{0, 0}, {40, 0}, {40, 20}, {21, 20}, {21, 10}, {19, 10}, {19, 20}, {0, 20}});
  const OffsetResult res = offset_contour(plate, 1.5);
  ASSERT_EQ(res.contours.size(), 1u);
  EXPECT_TRUE(in_result(res, {20, 15}));  // the slot is closed over
  ASSERT_EQ(res.problems.size(), 1u);
  const OffsetProblem& p = res.problems[0];
  EXPECT_EQ(p.kind, OffsetProblem::Kind::feature_too_small);
  EXPECT_EQ(p.span, 3u);  // the slot's walls and bottom: spans 3, 4, 5
  EXPECT_EQ(p.span_count, 3u);
  expect_at_distance(plate, res, 1.5, "notch plate");
  expect_simple_and_disjoint(res, "notch plate");
  std::mt19937 rng(5);
  expect_region(plate, res, 1.5, rng, 3000, "notch plate");
  // The same plate drawn clockwise reports the same spans in its own numbering.
  const Contour cw = plate.reversed();
  const OffsetResult rcw = offset_contour(cw, 1.5);
  ASSERT_EQ(rcw.problems.size(), 1u);
  EXPECT_EQ(rcw.problems[0].span, 2u);  // reversed spans 2, 3, 4 are the original 5, 4, 3
  EXPECT_EQ(rcw.problems[0].span_count, 3u);
  EXPECT_NEAR(signed_area(rcw.contours.at(0)), -signed_area(res.contours[0]), 1e-9);
  // A 4 wide slot stays open (1 wide), with no problem.
  const Contour wide = polygon({{0, 0}, {40, 0}, {40, 20}, {22, 20}, {22, 10}, {18, 10}, {18, 20}, {0, 20}});
  const OffsetResult rw = offset_contour(wide, 1.5);
  EXPECT_TRUE(rw.problems.empty());
  EXPECT_FALSE(in_result(rw, {20, 15}));
}

TEST(Offset, GrowingCanCloseAnInletIntoAHole) {
  // A 30 x 30 block with a 10 x 10 cavity reached from the top by a 1 wide channel.
  const Contour c = polygon({{0, 0}, {30, 0}, {30, 30}, {15.5, 30}, {15.5, 20}, {20, 20}, {20, 10}, {10, 10},
                             {10, 20}, {14.5, 20}, {14.5, 30}, {0, 30}});
  const OffsetResult res = offset_contour(c, 1.0);
  ASSERT_EQ(res.contours.size(), 2u);
  int outer = 0, holes = 0;
  for (const auto& o : res.contours) (orientation(o) == Orientation::ccw ? outer : holes)++;
  EXPECT_EQ(outer, 1);
  EXPECT_EQ(holes, 1);
  EXPECT_FALSE(in_result(res, {15, 15}));  // the cavity's middle stays open
  EXPECT_TRUE(in_result(res, {15, 25}));   // the channel is closed
  expect_at_distance(c, res, 1.0, "inlet");
  expect_simple_and_disjoint(res, "inlet");
  std::mt19937 rng(3);
  expect_region(c, res, 1.0, rng, 3000, "inlet");
  EXPECT_GE(count_kind(res, OffsetProblem::Kind::feature_too_small), 1);
}

TEST(Offset, ZeroDistanceReturnsTheContour) {
  const Contour l = l_shape();
  const OffsetResult res = offset_contour(l, 0.0);
  ASSERT_EQ(res.contours.size(), 1u);
  EXPECT_EQ(res.contours[0].vertices(), l.vertices());
}

TEST(Offset, BadInputThrows) {
  EXPECT_THROW(offset_contour(l_shape(), std::nan("")), InputError);
  EXPECT_THROW(offset_contour(l_shape(), 1e300), InputError);
  const Contour bowtie = polygon({{0, 0}, {10, 10}, {10, 0}, {0, 10}});
  try {
    offset_contour(bowtie, 1.0);
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crosses itself"), std::string::npos) << e.what();
  }
  const Contour flat = polygon({{0, 0}, {10, 0}, {20, 0}});
  EXPECT_THROW(offset_contour(flat, 1.0), InputError);
  OffsetOptions o;
  o.tolerance_mm = -1;
  try {
    o.validate();
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "tolerance_mm: is -1, must be finite, > 0 and <= 0.1 mm");
  }
}

// A random star-shaped polygon about the origin, optionally with random bulges; regenerated
// until it does not cross itself.
Contour random_star(std::mt19937& rng, int n, double max_bulge) {
  std::uniform_real_distribution<double> ur(4.0, 20.0), ub(-max_bulge, max_bulge), ua(0.0, 2 * kPi);
  while (true) {
    std::vector<double> angles(n);
    for (auto& a : angles) a = ua(rng);
    std::sort(angles.begin(), angles.end());
    std::vector<Vector2d> v;
    std::vector<double> b;
    for (double a : angles) {
      const double r = ur(rng);
      v.emplace_back(r * std::cos(a), r * std::sin(a));
      b.push_back(max_bulge > 0 ? ub(rng) : 0.0);
    }
    try {
      Contour c(v, b);
      if (!self_intersections(c, 1e-6).empty() || std::abs(signed_area(c)) < 1.0) continue;
      bool short_span = false;
      for (const auto& s : c.segments()) short_span = short_span || length(s) < 0.05;
      if (short_span) continue;
      return c;
    } catch (const InputError&) {
    }
  }
}

void check_random(const Contour& c, double d, std::mt19937& rng, const std::string& what) {
  const OffsetResult res = offset_contour(c, d);
  expect_at_distance(c, res, d, what);
  expect_simple_and_disjoint(res, what);
  expect_region(c, res, d, rng, 400, what);
  for (std::size_t k = 0; k < res.contours.size(); ++k) {
    ASSERT_EQ(res.source_spans[k].size(), res.contours[k].size());
    for (auto s : res.source_spans[k]) EXPECT_LT(s, c.size());
  }
  if (d < 0) {
    for (const auto& o : res.contours) EXPECT_EQ(orientation(o), orientation(c)) << what;
  }
}

TEST(Offset, RandomStarPolygonsSatisfyTheDistanceProperty) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> ud(0.2, 5.0);
  std::uniform_int_distribution<int> un(3, 24);
  for (int trial = 0; trial < 60; ++trial) {
    Contour c = random_star(rng, un(rng), 0.0);
    if (trial % 2) c = c.reversed();
    const double d = ud(rng) * (trial % 3 == 0 ? 1 : -1);
    check_random(c, d, rng, "star " + std::to_string(trial) + " d " + std::to_string(d));
  }
}

TEST(Offset, RandomBulgeContoursSatisfyTheDistanceProperty) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> ud(0.2, 4.0);
  std::uniform_int_distribution<int> un(2, 16);
  for (int trial = 0; trial < 60; ++trial) {
    Contour c = random_star(rng, un(rng), 0.6);
    if (trial % 2) c = c.reversed();
    const double d = ud(rng) * (trial % 3 == 1 ? 1 : -1);
    check_random(c, d, rng, "bulge " + std::to_string(trial) + " d " + std::to_string(d));
  }
}

}  // namespace
}  // namespace machplan
