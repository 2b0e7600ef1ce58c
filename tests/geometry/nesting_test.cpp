// engine/geometry/nesting.h: which contours lie inside which, checked against contains() over
// every pair, on a sheet of our own: parts with holes, a part in a hole, separate parts.
#include "engine/geometry/nesting.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace machplan {
namespace {

using Eigen::Vector2d;

Contour rect(double x0, double y0, double x1, double y1, bool ccw = true) {
  const Contour c({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, {0, 0, 0, 0});
  return ccw ? c : c.reversed();
}

TEST(Nesting, PartsHolesAndAPartInAHole) {
  const std::vector<Contour> cs = {
      rect(0, 0, 100, 100, false),          // 0 a part
      Contour::circle({20, 20}, 5),         // 1 its hole
      rect(40, 40, 90, 90),                 // 2 its large hole
      Contour::circle({65, 65}, 10, false), // 3 a part in that hole
      Contour::circle({65, 65}, 3),         // 4 the part's own hole
      rect(200, 0, 260, 50),                // 5 a separate part
      Contour(),                            // 6 empty: nothing
  };
  const Nesting n = nest_contours(cs);
  EXPECT_EQ(n.parent, (std::vector<int>{-1, 0, 0, 2, 3, -1, -1}));
  EXPECT_EQ(n.depth, (std::vector<int>{0, 1, 1, 2, 3, 0, 0}));
  EXPECT_EQ(n.children[0], (std::vector<int>{1, 2}));
  EXPECT_EQ(n.children[2], (std::vector<int>{3}));
  EXPECT_TRUE(n.children[5].empty());
}

TEST(Nesting, MatchesEveryPairOnARandomSheet) {
  // Rows of plates with random holes, some holes holding small parts: the parent is the
  // smallest larger contour holding the first vertex, found pair by pair here.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Contour> cs;
  for (int row = 0; row < 6; ++row)
    for (int col = 0; col < 8; ++col) {
      const double x = col * 130.0, y = row * 90.0;
      cs.push_back(rect(x, y, x + 120, y + 80, false));
      for (int h = 0; h < 3; ++h) {
        const Vector2d c(x + 20 + 40 * h, y + 25 + 30 * u(rng));
        const double r = 6 + 8 * u(rng);
        cs.push_back(Contour::circle(c, r));
        if (r > 10) cs.push_back(Contour::circle(c + Vector2d(1, 0), r / 3, false));
      }
    }
  const Nesting n = nest_contours(cs);
  for (std::size_t i = 0; i < cs.size(); ++i) {
    int parent = -1, depth = 0;
    const double ai = std::abs(signed_area(cs[i]));
    for (std::size_t j = 0; j < cs.size(); ++j) {
      if (j == i || !(std::abs(signed_area(cs[j])) > ai) || !contains(cs[j], cs[i].vertices().front())) continue;
      ++depth;
      if (parent < 0 || std::abs(signed_area(cs[j])) < std::abs(signed_area(cs[static_cast<std::size_t>(parent)])))
        parent = static_cast<int>(j);
    }
    ASSERT_EQ(n.parent[i], parent) << i;
    ASSERT_EQ(n.depth[i], depth) << i;
  }
}

TEST(Nesting, ContoursGivenAsCrossingHoldNeitherTheOther) {
  // A square crossing a larger one that holds its first vertex, inside a third.
  const std::vector<Contour> cs = {rect(0, 0, 100, 100), rect(10, 10, 60, 60), rect(40, 40, 70, 70)};
  const Nesting plain = nest_contours(cs);
  EXPECT_EQ(plain.parent[2], 1);
  const Nesting apart = nest_contours(cs, {{2, 1}});
  EXPECT_EQ(apart.parent[2], 0);
  EXPECT_EQ(apart.depth[2], 1);
  EXPECT_EQ(apart.parent[1], 0);
  EXPECT_EQ(apart.children[0], (std::vector<int>{1, 2}));
}

}  // namespace
}  // namespace machplan
