// The first nest (solvers/nesting/bottom_left.h): parts packed to the left edge, turned where
// only a turn fits, nothing placed that the certificate refuses, and copies that fit nowhere
// named.
#include <cmath>
#include <cstdio>
#include <numeric>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "solvers/nesting/bottom_left.h"
#include "tests/nesting/shapes.h"

namespace machplan::nesting {
namespace {

using test::disc;
using test::rect;

Certificate certificate_of(const NestRequest& r, const NestResult& n) {
  return certify(r.parts, n.placements, r.sheets, r.spacing_mm);
}

TEST(BottomLeft, FourSquaresFillTwoByTwoAgainstTheLeftEdgeAtTheSpacing) {
  NestRequest r;
  r.parts = {rect(100, 100)};
  r.quantity = {4};
  r.sheets = {Sheet{400, 220, 0}};
  r.spacing_mm = 10;
  const NestResult n = bottom_left_nest(r);
  ASSERT_EQ(n.placements.size(), 4u);
  EXPECT_TRUE(n.unplaced.empty());
  EXPECT_EQ(n.sheets_used, 1);
  // Two columns of two: 100 + 10 + 100, within the outside polygons' tolerance.
  EXPECT_NEAR(n.last_length_mm(), 210.0, 0.2);
  EXPECT_TRUE(certificate_of(r, n).certified);
}

TEST(BottomLeft, APartThatFitsOnlyTurnedIsTurnedAndOneThatFitsNoWayIsNamed) {
  NestRequest r;
  r.parts = {rect(300, 50, "long"), rect(600, 10, "too long")};
  r.quantity = {1, 1};
  r.rotations_deg = {0, 90};
  r.sheets = {Sheet{200, 400, 5}};
  r.spacing_mm = 6;
  const NestResult n = bottom_left_nest(r);
  ASSERT_EQ(n.placements.size(), 1u);
  EXPECT_EQ(n.placements[0].rotation_deg, 90.0);
  ASSERT_EQ(n.unplaced.size(), 1u);
  EXPECT_EQ(n.unplaced[0].part, 1u);
  EXPECT_NE(n.unplaced[0].reason.find("larger than the sheet's usable area"), std::string::npos) << n.unplaced[0].reason;
  EXPECT_TRUE(certificate_of(r, n).certified);
}

TEST(BottomLeft, CopiesThatOverflowASheetGoToTheNextAndTheNestIsCertified) {
  NestRequest r;
  r.parts = {disc(45), rect(120, 70)};
  r.quantity = {9, 5};
  r.rotations_deg = {0, 45, 90, 135};
  r.sheets = std::vector<Sheet>(3, Sheet{400, 300, 10});
  r.spacing_mm = 6;
  const NestResult n = bottom_left_nest(r);
  EXPECT_EQ(n.placements.size(), 14u);
  EXPECT_TRUE(n.unplaced.empty());
  EXPECT_GE(n.sheets_used, 2) << "14 parts of 0.64 m^2 do not fit on one 0.12 m^2 sheet";
  const Certificate c = certificate_of(r, n);
  EXPECT_TRUE(c.certified) << (c.violations.empty() ? "" : c.violations.front());
  // With one sheet only, what is left over is named as having no room.
  r.sheets.resize(1);
  const NestResult one = bottom_left_nest(r);
  ASSERT_FALSE(one.unplaced.empty());
  EXPECT_EQ(one.unplaced[0].reason, "no room left on the sheets");
  EXPECT_TRUE(certificate_of(r, one).certified);
}

TEST(BottomLeft, RestartsKeepTheBestNestAndTheSameSeedAndWorkGiveTheSameNest) {
  NestRequest r;
  r.parts = {disc(30), rect(90, 40), rect(50, 50)};
  r.quantity = {5, 6, 4};
  r.rotations_deg = {0, 90};
  r.sheets = {Sheet{1000, 150, 5}};
  r.spacing_mm = 4;
  const NestResult one = bottom_left_nest(r);
  EXPECT_EQ(one.fills, 1);
  auto search = [&](std::uint64_t seed) {
    Termination t;
    t.set_deadline(0.05, "nominal search time");
    return bottom_left_nest(r, t, seed);
  };
  const NestResult a = search(7), b = search(7);
  EXPECT_GT(a.fills, 1);
  EXPECT_LE(a.last_length_mm(), one.last_length_mm() + 1e-9) << "never worse than the first fill";
  ASSERT_EQ(a.placements.size(), b.placements.size());
  EXPECT_EQ(a.fills, b.fills);
  for (std::size_t i = 0; i < a.placements.size(); ++i) {
    EXPECT_EQ(a.placements[i].part, b.placements[i].part);
    EXPECT_EQ(a.placements[i].translate_mm, b.placements[i].translate_mm);
  }
  std::printf("one fill %.1f mm, %d fills %.1f mm\n", one.last_length_mm(), a.fills, a.last_length_mm());
  EXPECT_TRUE(certificate_of(r, a).certified);
}

TEST(BottomLeft, SmallPartsGoInTheHolesOfLargeOnesKeepingTheSpacingFromTheEdge) {
  // A 200 x 100 frame with a 160 x 60 window, and discs of radius 20 (40 + 2 x 6 < 60).
  NestPart frame = rect(200, 100, "frame");
  frame.holes.push_back(Contour({{20, 20}, {20, 80}, {180, 80}, {180, 20}}, {0, 0, 0, 0}));
  frame.area_mm2 -= 160 * 60;
  NestRequest r;
  r.parts = {frame, disc(20)};
  r.quantity = {1, 3};
  r.sheets = {Sheet{1000, 120, 10}};
  r.spacing_mm = 6;
  const NestResult n = bottom_left_nest(r);
  ASSERT_EQ(n.placements.size(), 4u);
  for (const Placement& p : n.placements)
    if (p.part == 1) {
      const Eigen::Vector2d at = p.translate_mm - n.placements[0].translate_mm;  // the disc's centre in the frame
      EXPECT_GT(at.x(), 20 + 26 - 1e-6);
      EXPECT_LT(at.x(), 180 - 26 + 1e-6);
      EXPECT_NEAR(at.y(), 50, 4.0 + 1e-6) << "in the window, 6 mm from its edges";
    }
  EXPECT_NEAR(n.last_length_mm(), 210.0, 1e-6) << "the discs add no length";
  const Certificate c = certificate_of(r, n);
  EXPECT_TRUE(c.certified) << (c.violations.empty() ? "" : c.violations.front());
}

TEST(BottomLeft, ARequestItCannotTakeIsRefusedNamingTheField) {
  NestRequest r;
  r.parts = {rect(10, 10)};
  r.quantity = {0};
  r.sheets = {Sheet{100, 100, 0}};
  EXPECT_THROW(bottom_left_nest(r), InputError);
  r.quantity = {1};
  r.sheets = {Sheet{100, 100, 50}};
  EXPECT_THROW(bottom_left_nest(r), InputError);
  r.sheets = {Sheet{100, 100, 0}};
  r.rotations_deg.clear();
  EXPECT_THROW(bottom_left_nest(r), InputError);
}

}  // namespace
}  // namespace machplan::nesting
