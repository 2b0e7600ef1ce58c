// Contracts of engine/geometry/region.h: the prohibited region for external and internal
// machining equals the set of tool centres within R of the material (checked point by point
// against the profile's own distance function), signed distances and normals at known points,
// both offset methods, merged neighbours, and errors that name the contour.
#include "engine/geometry/region.h"
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



// Material by the even-odd rule over the profile (depth parity), and the distance to it.
bool in_material(const std::vector<Contour>& profile, const Vector2d& p) {
  int n = 0;
  for (const auto& c : profile) n += contains(c, p);
  return n % 2 == 1;
}
double profile_distance(const std::vector<Contour>& profile, const Vector2d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& c : profile) d = std::min(d, distance(c, p));
  return d;
}

// The exact prohibited set: outside, the tool centre within R of the part; inside, the tool
// centre outside the pocket or within R of its wall (or of an island).
bool exact_prohibited(const std::vector<Contour>& profile, MachiningSide side, double r, const Vector2d& p) {
  const bool mat = in_material(profile, p);
  const double d = profile_distance(profile, p);
  if (side == MachiningSide::outside) return mat || d < r;
  return !mat || d < r;
}

TEST(Region, RectangleOutsideDistancesAndNormals) {
  const auto region = ProhibitedRegion::build({rectangle(0, 0, 100, 50)}, test::region_options(MachiningSide::outside, 5));
  auto q = region.query({110, 25});
  EXPECT_NEAR(q.signed_distance_mm, 5.0, 1e-9);
  EXPECT_NEAR((q.nearest_mm - Vector2d(105, 25)).norm(), 0, 1e-9);
  EXPECT_NEAR((q.normal - Vector2d(1, 0)).norm(), 0, 1e-9);
  q = region.query({103, 25});
  EXPECT_NEAR(q.signed_distance_mm, -2.0, 1e-9);
  EXPECT_NEAR((q.normal - Vector2d(1, 0)).norm(), 0, 1e-9);
  EXPECT_TRUE(region.prohibited({103, 25}));
  EXPECT_FALSE(region.prohibited({106, 25}));
  // Off a corner the limit is the quarter circle of radius 5 about it.
  q = region.query({103, 54});
  EXPECT_NEAR(q.signed_distance_mm, -(5.0 - 5.0), 1e-9);
  q = region.query({110, 60});
  EXPECT_NEAR(q.signed_distance_mm, std::hypot(10, 10) - 5, 1e-9);
  // Deep inside the part: as far as the nearest limit.
  EXPECT_NEAR(region.query({50, 20}).signed_distance_mm, -25.0, 1e-9);
  EXPECT_TRUE(region.problems().empty());
}

TEST(Region, RectanglePocketInside) {
  const auto region = ProhibitedRegion::build({rectangle(0, 0, 100, 50).reversed()}, test::region_options(MachiningSide::inside, 5));
  EXPECT_NEAR(region.query({50, 25}).signed_distance_mm, 20.0, 1e-9);
  auto q = region.query({2, 25});
  EXPECT_NEAR(q.signed_distance_mm, -3.0, 1e-9);
  EXPECT_NEAR((q.normal - Vector2d(1, 0)).norm(), 0, 1e-9);
  EXPECT_NEAR(region.query({-10, 25}).signed_distance_mm, -15.0, 1e-9);
  ASSERT_EQ(region.boundary().size(), 1u);
  // The pocket shrunk by R keeps sharp corners: 90 x 40.
  EXPECT_NEAR(std::abs(signed_area(region.boundary()[0])), 90.0 * 40.0, 1e-9);
}

// A plate with rounded corners (arcs), a round hole and a square hole.
std::vector<Contour> plate_with_holes() {
  Contour outer({{10, 0}, {90, 0}, {100, 10}, {100, 50}, {90, 60}, {10, 60}, {0, 50}, {0, 10}},
                {0, std::tan(kPi / 8), 0, std::tan(kPi / 8), 0, std::tan(kPi / 8), 0, std::tan(kPi / 8)});
  return {outer, Contour::circle({30, 30}, 10), rectangle(60, 20, 80, 40)};
}

void expect_matches_exact(const std::vector<Contour>& profile, MachiningSide side, double r, int count,
                          unsigned seed) {
  const auto region = ProhibitedRegion::build(profile, test::region_options(side, r));
  Eigen::AlignedBox2d box;
  for (const auto& c : profile) box.extend(bounding_box(c));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(box.min().x() - 2 * r - 5, box.max().x() + 2 * r + 5);
  std::uniform_real_distribution<double> uy(box.min().y() - 2 * r - 5, box.max().y() + 2 * r + 5);
  int checked = 0;
  for (int i = 0; i < count; ++i) {
    const Vector2d p(ux(rng), uy(rng));
    const double d = profile_distance(profile, p);
    if (std::abs(d - r) < 1e-6 || d < 1e-6) continue;
    const bool expected = exact_prohibited(profile, side, r, p);
    const RegionDistance q = region.query(p);
    ASSERT_EQ(q.signed_distance_mm < 0, expected) << to_string(side) << " R " << r << " at (" << p.x() << ", "
                                                  << p.y() << ") profile distance " << d;
    // Outside the prohibited region the distance to it is exactly the distance to the
    // material minus R (the offset is exact).
    if (!expected && side == MachiningSide::outside) { ASSERT_NEAR(q.signed_distance_mm, d - r, 1e-7); }
    ++checked;
  }
  EXPECT_GT(checked, count * 9 / 10);
}

TEST(Region, PlateWithHolesMatchesTheExactSetBothSides) {
  for (double r : {0.0, 1.0, 4.0, 12.0}) {
    expect_matches_exact(plate_with_holes(), MachiningSide::outside, r, 3000, 7);
    if (r < 10) expect_matches_exact(plate_with_holes(), MachiningSide::inside, r, 3000, 8);
  }
}

TEST(Region, LargeWavyProfileMatchesTheExactSet) {
  // 5 000 spans, concave and convex: the indexed offset, merge and query give the exact set.
  std::vector<Vector2d> v;
  const int n = 5000;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * kPi * k / n;
    const double r = 300.0 * (1.0 + 0.15 * std::sin(5 * t) + 0.04 * std::sin(17 * t));
    v.emplace_back(r * std::cos(t), r * std::sin(t));
  }
  const std::vector<Contour> profile = {polygon(v)};
  for (auto side : {MachiningSide::outside, MachiningSide::inside}) {
    const auto region = ProhibitedRegion::build(profile, test::region_options(side, 5));
    ASSERT_EQ(region.boundary().size(), 1u);
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-400, 400);
    int checked = 0;
    for (int i = 0; i < 200; ++i) {
      const Vector2d p(u(rng), u(rng));
      const double d = distance(profile[0], p);
      if (std::abs(d - 5) < 1e-6) continue;
      ASSERT_EQ(region.prohibited(p), exact_prohibited(profile, side, 5, p)) << to_string(side) << " at (" << p.x()
                                                                           << ", " << p.y() << ")";
      ++checked;
    }
    EXPECT_GT(checked, 190);
  }
}

TEST(Region, NeighboursCloserThanTheToolMergeAndAreReported) {
  // Two squares 4 mm apart, tool radius 3: the tool cannot pass between them.
  const std::vector<Contour> profile = {rectangle(0, 0, 10, 10), rectangle(14, 0, 24, 10)};
  const auto region = ProhibitedRegion::build(profile, test::region_options(MachiningSide::outside, 3));
  ASSERT_EQ(region.boundary().size(), 1u);
  EXPECT_TRUE(region.prohibited({12, 5}));
  bool reported = false;
  for (const auto& p : region.problems())
    reported = reported || (p.kind == OffsetProblem::Kind::gap_too_narrow &&
                            p.message.find("contour 0 and contour 1") != std::string::npos);
  EXPECT_TRUE(reported);
  expect_matches_exact(profile, MachiningSide::outside, 3, 2000, 9);
}

TEST(Region, PaperMethodMitresTheTriangle) {
  // A right triangle grown by R with the paper's method: the corners are mitre points at
  // distance R / sin(alpha / 2)... checked as: every boundary edge is parallel to its profile
  // edge at distance R.
  const Contour tri = polygon({{0, 0}, {60, 0}, {0, 40}});
  const auto region = ProhibitedRegion::build({tri}, test::region_options(MachiningSide::outside, 2, OffsetMethod::paper));
  ASSERT_EQ(region.boundary().size(), 1u);
  const Contour& b = region.boundary()[0];
  ASSERT_EQ(b.size(), 3u);
  for (const auto& s : b.segments()) EXPECT_NEAR(distance(tri, point_at(s, 0.5)), 2.0, 1e-9);
  // The right-angle corner's mitre point is (-2, -2).
  bool found = false;
  for (const auto& v : b.vertices()) found = found || (v - Vector2d(-2, -2)).norm() < 1e-9;
  EXPECT_TRUE(found);
  EXPECT_TRUE(region.prohibited({-1.9, -1.9}));   // in the mitre, further than R from the part
  EXPECT_FALSE(region.prohibited({-2.1, -2.1}));
}

TEST(Region, BadProfilesNameTheContour) {
  const Contour bow = polygon({{0, 0}, {10, 10}, {10, 0}, {0, 10}});
  try {
    ProhibitedRegion::build({rectangle(-50, -50, 50, 50), bow}, test::region_options(MachiningSide::outside, 1));
    FAIL() << "a self-crossing contour was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("contour 1: the contour crosses itself"), std::string::npos) << e.what();
  }
  try {
    ProhibitedRegion::build({rectangle(0, 0, 10, 10), rectangle(5, 5, 15, 15)}, test::region_options(MachiningSide::outside, 1),
                            {"part (1A)", "pocket (2B)"});
    FAIL() << "crossing contours were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("part (1A) and pocket (2B): the contours cross"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ProhibitedRegion::build({}, test::region_options(MachiningSide::outside, 1)), InputError);
  EXPECT_THROW(ProhibitedRegion::build({polygon({{0, 0}, {10, 0}, {20, 0}})}, test::region_options(MachiningSide::outside, 1)),
               InputError);
  // A pocket narrower than the tool everywhere leaves nothing.
  try {
    ProhibitedRegion::build({rectangle(0, 0, 100, 6)}, test::region_options(MachiningSide::inside, 4));
    FAIL() << "a pocket narrower than the tool was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing is left"), std::string::npos) << e.what();
  }
  RegionOptions bad;
  bad.tool_radius_mm = -1;
  EXPECT_THROW(bad.validate(), InputError);
  EXPECT_THROW(parse_machining_side("outsid"), InputError);
  EXPECT_EQ(parse_machining_side("inside").value, MachiningSide::inside);
  EXPECT_EQ(parse_offset_method("paper").value, OffsetMethod::paper);
}

}  // namespace
}  // namespace machplan
