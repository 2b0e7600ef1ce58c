// Contracts of engine/geometry/span_index.h (nearest span, side, winding, box queries against
// brute force over contour.h), paper_offset.h (the paper's filter and mitre shift, arcs as
// chords) and merge_positive (offset.h: the boundary of positive winding).
#include "engine/geometry/span_index.h"
#include "tests/support/shapes.h"
#include "engine/common/internal/numbers.h"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "engine/geometry/offset.h"
#include "engine/geometry/paper_offset.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

using test::polygon;

// A star-shaped contour of n spans about c with random radii and random bulges, either
// orientation; drawn again until it does not cross itself (bulged spikes can).
Contour random_star(std::mt19937& rng, const Vector2d& c, int n, bool ccw) {
  std::uniform_real_distribution<double> rad(20, 40), bulge(-0.15, 0.15);
  while (true) {
    std::vector<Vector2d> v;
    std::vector<double> b;
    for (int k = 0; k < n; ++k) {
      const double t = 2 * kPi * k / n;
      v.push_back(c + rad(rng) * Vector2d(std::cos(t), std::sin(t)));
      b.push_back(n >= 8 ? bulge(rng) : 0.0);
    }
    const Contour star(v, b);
    if (self_intersections(star, 1e-9).empty()) return ccw ? star : star.reversed();
  }
}

TEST(SpanIndex, NearestWindingSideAndBoxesMatchBruteForce) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    // An outer star, a hole in it, and a separate star.
    const std::vector<Contour> cs = {random_star(rng, {0, 0}, 5 + trial * 7, true),
                                     Contour::circle({0, 0}, 8 + trial * 0.2, false),
                                     random_star(rng, {120, 10}, 9 + trial, trial % 2 == 0)};
    const SpanIndex index(cs);
    std::size_t total = 0;
    for (const auto& c : cs) total += c.size();
    ASSERT_EQ(index.size(), total);
    std::uniform_real_distribution<double> ux(-60, 180), uy(-60, 60);
    for (int i = 0; i < 300; ++i) {
      const Vector2d p(ux(rng), uy(rng));
      double best = std::numeric_limits<double>::infinity();
      int w = 0;
      for (const auto& c : cs) {
        best = std::min(best, distance(c, p));
        w += winding_number(c, p);
      }
      const SpanIndex::Nearest n = index.nearest(p);
      ASSERT_NEAR(n.distance, best, 1e-9) << trial;
      const auto& it = index.item(n.item);
      ASSERT_NEAR((closest_point(cs[it.contour].span(it.span), p) - n.point).norm(), 0.0, 1e-9);
      if (best < 1e-6) continue;
      ASSERT_EQ(index.winding(p), w) << trial << " at (" << p.x() << ", " << p.y() << ")";
      // Per contour: the non-zero windings, by contour.
      std::vector<std::pair<std::uint32_t, int>> each;
      index.windings(p, each);
      std::vector<std::pair<std::uint32_t, int>> want;
      for (std::uint32_t k = 0; k < cs.size(); ++k)
        if (const int wk = winding_number(cs[k], p)) want.emplace_back(k, wk);
      ASSERT_EQ(each, want) << trial << " at (" << p.x() << ", " << p.y() << ")";
      // Left of the nearest contour: inside the outer star and outside the hole (together:
      // their winding is positive); for the separate star, inside when it runs ccw, outside
      // when it runs cw.
      const bool expected = it.contour == 2 ? (winding_number(cs[2], p) != 0) == (trial % 2 == 0)
                                            : winding_number(cs[0], p) + winding_number(cs[1], p) > 0;
      ASSERT_EQ(index.left_of(p, n), expected) << trial << " at (" << p.x() << ", " << p.y() << ")";
    }
    // Box query: exactly the spans whose boxes meet the box.
    const Eigen::AlignedBox2d q(Vector2d(-10, -5), Vector2d(30, 25));
    std::vector<bool> seen(index.size(), false);
    index.for_each_in_box(q, [&](std::size_t i) { seen[i] = true; });
    for (std::size_t i = 0; i < index.size(); ++i) {
      const auto& it = index.item(i);
      EXPECT_EQ(seen[i], bounding_box(cs[it.contour].span(it.span)).intersects(q)) << i;
    }
  }
}

TEST(SpanIndex, WindingOnAnArcsChordLine) {
  // A half disc whose chord is vertical at x = 100: points on that line, inside the half
  // disc, are inside.
  const Contour half({{100, -40}, {100, 40}}, {1, 0});  // arc from (100,-40) to (100,40) ccw, then the chord back
  const SpanIndex index({half});
  EXPECT_EQ(index.winding({100.0 + 1e-12, 0}), 1);
  EXPECT_EQ(index.winding({120, 0}), 1);
  EXPECT_EQ(index.winding({150, 0}), 0);
  const Contour disc = Contour::circle({100, 40}, 45);
  EXPECT_EQ(SpanIndex({disc}).winding({120, 40}), 1);  // on both chords' line
  EXPECT_EQ(SpanIndex({disc}).winding({100, 40}), 1);
}

TEST(PaperOffset, MitreShiftAndTheVeryClosePointRule) {
  // A 40 x 20 rectangle grown by 2: mitre corners at distance 2 along both normals.
  const auto r = paper_offset(polygon({{0, 0}, {40, 0}, {40, 20}, {0, 20}}), 2.0, 0.01, 1e-6);
  ASSERT_EQ(r.vertices.size(), 4u);
  EXPECT_NEAR((r.vertices[0] - Vector2d(-2, -2)).norm(), 0, 1e-12);
  EXPECT_NEAR((r.vertices[2] - Vector2d(42, 22)).norm(), 0, 1e-12);
  EXPECT_TRUE(r.dropped.empty());
  // A 1 mm step in a long edge, shrunk by 3 mm: at its corners the setback R tan(45 deg) = 3
  // exceeds the 1 mm step, so the step's points are dropped and the edge is shifted straight.
  const auto s = paper_offset(polygon({{0, 0}, {20, 0}, {20, 1}, {40, 1}, {40, 30}, {0, 30}}), -3.0, 0.01, 1e-6);
  EXPECT_GE(s.dropped.size(), 1u);
  for (const auto& d : s.dropped) EXPECT_GT(d.setback_mm, d.segment_mm);
  ASSERT_FALSE(s.vanished());
  // A triangle shrunk past its inradius: nothing left but still a polygon (the paper's method
  // has no vanishing test beyond the point filter); a hairpin with R > 0 loses its tip.
  const auto t = paper_offset(polygon({{0, 0}, {10, 0}, {5, 0.5}}), 1.0, 0.01, 1e-6);
  EXPECT_FALSE(t.dropped.empty());
}

TEST(PaperOffset, ArcsBecomeChordsWithinTheSagitta) {
  const Contour circle = Contour::circle({0, 0}, 50);
  std::vector<std::size_t> src;
  const auto v = polygonise(circle, 0.01, &src);
  ASSERT_EQ(v.size(), src.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    EXPECT_NEAR(v[i].norm(), 50.0, 1e-9);
    const Vector2d mid = 0.5 * (v[i] + v[(i + 1) % v.size()]);
    EXPECT_LE(50.0 - mid.norm(), 0.01 + 1e-12);  // sagitta
  }
  // Enough chords for that sagitta and not many more: theta = 2 acos(1 - 0.01 / 50).
  const double theta = 2 * std::acos(1 - 0.01 / 50);
  EXPECT_LE(v.size(), static_cast<std::size_t>(std::ceil(2 * kPi / theta)) + 2);
}

TEST(MergePositive, UnionOfOverlappingRegionsMinusHoles) {
  // Two overlapping squares (union area 100 + 100 - 25) and a hole in the first.
  const std::vector<Contour> cs = {polygon({{0, 0}, {10, 0}, {10, 10}, {0, 10}}),
                                   polygon({{5, 5}, {15, 5}, {15, 15}, {5, 15}}),
                                   polygon({{1, 1}, {3, 1}, {3, 3}, {1, 3}}).reversed()};
  const MergeResult m = merge_positive(cs);
  double area = 0;
  for (const auto& c : m.contours) area += signed_area(c);
  EXPECT_NEAR(area, 175.0 - 4.0, 1e-9);
  ASSERT_EQ(m.crossings.size(), 1u);
  EXPECT_EQ(m.crossings[0].contour_a, 0u);
  EXPECT_EQ(m.crossings[0].contour_b, 1u);
  // A figure of eight crossing itself at (5, 5): its left lobe runs counter-clockwise, its
  // right lobe clockwise (winding -1): only the left lobe is positive.
  const MergeResult e = merge_positive({polygon({{0, 0}, {10, 10}, {10, 0}, {0, 10}})});
  ASSERT_EQ(e.contours.size(), 1u);
  EXPECT_NEAR(signed_area(e.contours[0]), 25.0, 1e-9);
  EXPECT_LT(bounding_box(e.contours[0]).max().x(), 5.0 + 1e-9);
  ASSERT_EQ(e.crossings.size(), 1u);
  EXPECT_EQ(e.crossings[0].contour_a, e.crossings[0].contour_b);
}

}  // namespace
}  // namespace machplan
