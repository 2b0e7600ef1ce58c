// The paper's three invasion checks (engine/geometry/invasion.h) and ProhibitedRegion::query()
// agree on inside / outside at many random points, for several profiles (polygons, arcs,
// holes, several contours), both machining sides, both offset methods; and their distances
// agree where each method measures the true one.
#include "engine/geometry/invasion.h"
#include "tests/support/shapes.h"
#include "engine/common/internal/numbers.h"

#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/programs/dxf.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

using test::polygon;

struct Case {
  std::string name;
  std::vector<Contour> profile;
  MachiningSide side;
  double r;
  OffsetMethod method = OffsetMethod::robust;
};

std::vector<Contour> bundled(const std::string& file) {
  const auto p = read_dxf_profile(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/profiles/" + file);
  EXPECT_FALSE(p.has_errors()) << p.report();
  std::vector<Contour> out;
  for (const auto& c : p.contours) out.push_back(c.contour);
  return out;
}

std::vector<Case> cases() {
  const std::vector<Contour> triangle = {polygon({{0, 0}, {120, 0}, {45, 95}})};
  const std::vector<Contour> heptagon = {
      polygon({{0, 0}, {90, -10}, {140, 30}, {120, 80}, {70, 60}, {30, 100}, {-20, 50}})};
  const double b = std::tan(kPi / 8);
  const std::vector<Contour> plate = {
      Contour({{10, 0}, {90, 0}, {100, 10}, {100, 50}, {90, 60}, {10, 60}, {0, 50}, {0, 10}}, {0, b, 0, b, 0, b, 0, b}),
      Contour::circle({30, 30}, 10, false), polygon({{60, 20}, {80, 20}, {80, 40}, {60, 40}})};
  const std::vector<Contour> two = {polygon({{0, 0}, {30, 0}, {30, 30}, {0, 30}}),
                                    Contour::circle({45, 15}, 8)};  // 7 mm apart
  std::vector<Case> out = {
      {"triangle outside", triangle, MachiningSide::outside, 3},
      {"triangle outside paper", triangle, MachiningSide::outside, 3, OffsetMethod::paper},
      {"heptagon outside", heptagon, MachiningSide::outside, 4},
      {"heptagon inside", heptagon, MachiningSide::inside, 4},
      {"heptagon inside paper", heptagon, MachiningSide::inside, 4, OffsetMethod::paper},
      {"plate outside", plate, MachiningSide::outside, 2},
      {"plate inside", plate, MachiningSide::inside, 2},
      {"plate inside paper", plate, MachiningSide::inside, 2, OffsetMethod::paper},
      {"two parts merged", two, MachiningSide::outside, 5},
      {"arc profile outside", bundled("arc_profile.dxf"), MachiningSide::outside, 5},
      {"arc profile inside", bundled("arc_profile.dxf"), MachiningSide::inside, 2},
      {"narrow slot outside", bundled("narrow_slot.dxf"), MachiningSide::outside, 5},
      {"narrow slot inside paper", bundled("narrow_slot.dxf"), MachiningSide::inside, 5, OffsetMethod::paper},
  };
  return out;
}

TEST(Invasion, AllFourMethodsAgreeOnInsideOutside) {
  constexpr double kSpacing = 0.1;  // point matrix E, mm
  for (const auto& c : cases()) {
    RegionOptions o;
    o.side = c.side;
    o.tool_radius_mm = c.r;
    o.method = c.method;
    const auto region = ProhibitedRegion::build(c.profile, o);
    const PointMatrixCheck matrix(region, kSpacing);
    const AngleSumCheck angles(region);
    const IntervalDistanceCheck interval(region);
    Eigen::AlignedBox2d box;
    for (const auto& k : c.profile) box.extend(bounding_box(k));
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> ux(box.min().x() - 20, box.max().x() + 20);
    std::uniform_real_distribution<double> uy(box.min().y() - 20, box.max().y() + 20);
    // Away from the boundary by more than the chords' sagitta and the matrix spacing.
    const double margin = 2 * kSpacing + o.paper_chord_tolerance_mm;
    int checked = 0, prohibited = 0;
    for (int i = 0; i < 2000; ++i) {
      const Vector2d p(ux(rng), uy(rng));
      const RegionDistance q = region.query(p);
      if (std::abs(q.signed_distance_mm) < margin) continue;
      const bool ours = q.signed_distance_mm < 0;
      ASSERT_EQ(matrix.check(p).prohibited, ours) << c.name << " point matrix at (" << p.x() << ", " << p.y() << ")";
      ASSERT_EQ(angles.check(p).prohibited, ours) << c.name << " angle sum at (" << p.x() << ", " << p.y() << ")";
      const InvasionAnswer in = interval.check(p);
      ASSERT_EQ(in.prohibited, ours) << c.name << " interval at (" << p.x() << ", " << p.y() << ")";
      // Distances: the angle-sum check measures to every edge (the polygonised boundary lies
      // within the chord tolerance of the true one); the interval check sees only the edges
      // over the point's x, so it can only be farther.
      ASSERT_NEAR(angles.check(p).distance_mm, std::abs(q.signed_distance_mm), o.paper_chord_tolerance_mm + 1e-9)
          << c.name;
      ASSERT_GE(in.distance_mm, std::abs(q.signed_distance_mm) - o.paper_chord_tolerance_mm - 1e-9) << c.name;
      ASSERT_NEAR(matrix.check(p).distance_mm, std::abs(q.signed_distance_mm), kSpacing + o.paper_chord_tolerance_mm)
          << c.name;
      ++checked;
      prohibited += ours;
    }
    EXPECT_GT(checked, 1800) << c.name;
    // Both answers occur often enough for the agreement to mean something.
    EXPECT_GT(prohibited, 100) << c.name;
    EXPECT_LT(prohibited, checked - 100) << c.name;
  }
}

TEST(Invasion, QueryNearestFeatureAndNormalAreConsistent) {
  // For any point: nearest + |d| * normal (signed) returns to the point, and the nearest
  // point lies on the named boundary span.
  for (const auto& c : cases()) {
    RegionOptions o;
    o.side = c.side;
    o.tool_radius_mm = c.r;
    o.method = c.method;
    const auto region = ProhibitedRegion::build(c.profile, o);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-40, 160);
    for (int i = 0; i < 500; ++i) {
      const Vector2d p(u(rng), u(rng));
      const RegionDistance q = region.query(p);
      ASSERT_NEAR((q.nearest_mm + q.signed_distance_mm * q.normal - p).norm(), 0.0, 1e-9) << c.name;
      ASSERT_NEAR(q.normal.norm(), 1.0, 1e-12) << c.name;
      ASSERT_LT(q.contour, region.boundary().size());
      const Contour& b = region.boundary()[q.contour];
      ASSERT_LT(q.span, b.size());
      ASSERT_NEAR((closest_point(b.span(q.span), q.nearest_mm) - q.nearest_mm).norm(), 0.0, 1e-9) << c.name;
      // No boundary point is nearer.
      double best = std::numeric_limits<double>::infinity();
      for (const auto& k : region.boundary()) best = std::min(best, distance(k, p));
      ASSERT_NEAR(best, std::abs(q.signed_distance_mm), 1e-9) << c.name;
    }
  }
}

TEST(Invasion, BadSpacingIsRefused) {
  RegionOptions o;
  o.tool_radius_mm = 1;
  const auto region = ProhibitedRegion::build({polygon({{0, 0}, {10, 0}, {0, 10}})}, o);
  EXPECT_THROW(PointMatrixCheck(region, 0.0), InputError);
  EXPECT_THROW(PointMatrixCheck(region, std::nan("")), InputError);
}

}  // namespace
}  // namespace machplan
