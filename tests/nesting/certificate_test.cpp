// The nest's parts read from drawings, the placement transform, and the certificate that
// checks a nest on the true geometry (solvers/nesting).
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "solvers/nesting/certificate.h"
#include "solvers/nesting/outline.h"
#include "tests/nesting/shapes.h"
#include "solvers/nesting/part.h"

namespace machplan::nesting {
namespace {

std::string dxf(const std::string& entities) {
  return "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n" + entities + "0\nENDSEC\n0\nEOF\n";
}
std::string dxf_circle(double x, double y, double r) {
  return "0\nCIRCLE\n8\nCUT\n10\n" + std::to_string(x) + "\n20\n" + std::to_string(y) + "\n40\n" + std::to_string(r) + "\n";
}
// A closed rectangle as one LWPOLYLINE.
std::string dxf_rect(double x0, double y0, double x1, double y1) {
  std::string s = "0\nLWPOLYLINE\n8\nCUT\n90\n4\n70\n1\n";
  for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}})
    s += "10\n" + std::to_string(x) + "\n20\n" + std::to_string(y) + "\n";
  return s;
}

std::vector<NestPart> parts_of(const std::string& entities, bool split = false) {
  return nest_parts(read_dxf_profile_text(dxf(entities), "part.dxf"), split);
}

using test::disc;
NestPart square(double side) { return test::rect(side, side, "square"); }

Placement at(std::size_t part, double x, double y, double deg = 0.0, bool mirrored = false, int sheet = 0) {
  Placement p;
  p.part = part;
  p.sheet = sheet;
  p.translate_mm = {x, y};
  p.rotation_deg = deg;
  p.mirrored = mirrored;
  return p;
}

const std::vector<Sheet> kSheet{{1000, 500, 10}};

TEST(NestParts, ADrawingIsItsOuterContourWithItsHolesAndSeveralOutersAreRefusedUnlessSplit) {
  const std::vector<NestPart> plate = parts_of(dxf_rect(0, 0, 100, 60) + dxf_circle(30, 30, 10) + dxf_circle(70, 30, 10));
  ASSERT_EQ(plate.size(), 1u);
  EXPECT_EQ(plate[0].holes.size(), 2u);
  EXPECT_NEAR(plate[0].area_mm2, 6000 - 2 * M_PI * 100, 1e-6);
  EXPECT_EQ(orientation(plate[0].outer), Orientation::ccw);
  EXPECT_EQ(orientation(plate[0].holes[0]), Orientation::cw);
  // Two plates side by side, and a disc in a plate's hole: three outer contours.
  const std::string three = dxf_rect(0, 0, 100, 60) + dxf_circle(50, 30, 20) + dxf_circle(50, 30, 5) + dxf_rect(200, 0, 260, 40);
  try {
    parts_of(three);
    FAIL() << "several outer contours were taken as one part";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("holds 3 outer contours"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("part.dxf"), std::string::npos) << e.what();
  }
  const std::vector<NestPart> split = parts_of(three, true);
  ASSERT_EQ(split.size(), 3u);
  EXPECT_EQ(split[0].holes.size(), 1u) << "the plate and its hole";
  EXPECT_TRUE(split[1].holes.empty()) << "the disc in the hole is a part of its own";
  EXPECT_THROW(parts_of(""), InputError);
}

TEST(NestPlacement, APointOfTheDrawingLandsAtTranslatePlusTheRotatedMirroredPoint) {
  Placement p = at(0, 100, 50, 90.0, true);
  const Eigen::Vector2d q = p.apply({10, 2});  // mirrored (-10, 2), turned 90 deg: (-2, -10)
  EXPECT_NEAR(q.x(), 98.0, 1e-12);
  EXPECT_NEAR(q.y(), 40.0, 1e-12);
  // A placed contour keeps its sense and its area, mirror or not; arcs stay arcs.
  const NestPart plate = parts_of(dxf_rect(0, 0, 100, 60) + dxf_circle(30, 30, 10))[0];
  for (bool mirrored : {false, true}) {
    p.mirrored = mirrored;
    const Contour o = place(plate.outer, p), h = place(plate.holes[0], p);
    EXPECT_EQ(orientation(o), Orientation::ccw);
    EXPECT_EQ(orientation(h), Orientation::cw);
    EXPECT_NEAR(signed_area(h), signed_area(plate.holes[0]), 1e-9);
    EXPECT_LT(distance(h, p.apply({30, 40})), 1e-9) << "the hole's top lands where the transform puts it";
  }
}

TEST(NestCertificate, PartsAtTheSpacingPassAndAHundredthCloserFailsOnTheTrueArcs) {
  const std::vector<NestPart> parts{disc(50), square(80)};
  // Two discs: centres 106 mm apart leave 6 mm between the arcs.
  EXPECT_TRUE(certify(parts, {at(0, 100, 100), at(0, 206.01, 100)}, kSheet, 6.0).certified);
  const Certificate close = certify(parts, {at(0, 100, 100), at(0, 205.99, 100)}, kSheet, 6.0);
  EXPECT_FALSE(close.certified);
  ASSERT_EQ(close.violations.size(), 1u);
  EXPECT_NE(close.violations[0].find("closer than the spacing"), std::string::npos) << close.violations[0];
  // A disc beside the square's corner, on its diagonal: 6 mm from the corner along it is
  // 6 mm from the square; the chord polygon of the disc would not tell 0.01 mm.
  const double d = 50 + 6.0;  // centre to corner: r + 6
  const double k = d / std::sqrt(2.0);
  EXPECT_TRUE(certify(parts, {at(1, 200, 100), at(0, 280 + k + 0.01, 180 + k + 0.01)}, kSheet, 6.0).certified);
  EXPECT_FALSE(certify(parts, {at(1, 200, 100), at(0, 280 + k - 0.01, 180 + k - 0.01)}, kSheet, 6.0).certified);
  // Overlapping copies, and copies on different sheets at the same place.
  EXPECT_FALSE(certify(parts, {at(1, 200, 100), at(1, 200, 100)}, kSheet, 6.0).certified);
  const std::vector<Sheet> two{kSheet[0], kSheet[0]};
  EXPECT_TRUE(certify(parts, {at(1, 200, 100, 0, false, 0), at(1, 200, 100, 0, false, 1)}, two, 6.0).certified);
}

TEST(NestCertificate, APartInAHoleKeepsTheSpacingFromTheHolesEdge) {
  // A plate with a 60 mm hole (radius 30) and a disc of radius 20: 10 mm of room all round.
  std::vector<NestPart> parts = parts_of(dxf_rect(0, 0, 120, 120) + dxf_circle(60, 60, 30));
  parts.push_back(disc(20));
  EXPECT_TRUE(certify(parts, {at(0, 100, 100), at(1, 160, 160)}, kSheet, 6.0).certified) << "centred: 10 mm";
  EXPECT_TRUE(certify(parts, {at(0, 100, 100), at(1, 163.9, 160)}, kSheet, 6.0).certified) << "6.1 mm on one side";
  const Certificate off = certify(parts, {at(0, 100, 100), at(1, 164.1, 160)}, kSheet, 6.0);
  EXPECT_FALSE(off.certified) << "5.9 mm";
  ASSERT_FALSE(off.violations.empty());
  EXPECT_NE(off.violations[0].find("in a hole"), std::string::npos) << off.violations[0];
  // A disc too big for the hole with the spacing, centred.
  parts.push_back(disc(26));
  EXPECT_FALSE(certify(parts, {at(0, 100, 100), at(2, 160, 160)}, kSheet, 6.0).certified);
}

TEST(NestCertificate, APartPastTheMarginIsReportedAndBadIndicesAreRefused) {
  const std::vector<NestPart> parts{disc(50)};
  EXPECT_TRUE(certify(parts, {at(0, 60, 60)}, kSheet, 6.0).certified);
  const Certificate past = certify(parts, {at(0, 59, 60)}, kSheet, 6.0);
  EXPECT_FALSE(past.certified);
  ASSERT_EQ(past.violations.size(), 1u);
  EXPECT_NE(past.violations[0].find("reaches past its usable area"), std::string::npos) << past.violations[0];
  EXPECT_THROW(certify(parts, {at(1, 60, 60)}, kSheet, 6.0), InputError);
  EXPECT_THROW(certify(parts, {at(0, 60, 60, 0, false, 1)}, kSheet, 6.0), InputError);
  EXPECT_THROW(certify(parts, {at(0, 60, 60)}, kSheet, -1.0), InputError);
}

// A remnant: an L (500 x 300 with the upper right 250 x 150 gone) with a round cut-out of
// radius 30 at (100, 150); margin 5.
TEST(NestCertificate, OnARemnantAPartStaysInsideItsOutlineAndClearOfItsCutOutsByTheMargin) {
  Sheet rem{500, 300, 5};
  NestPart l;
  l.file = "remnant.dxf";
  l.outer = Contour({{0, 0}, {500, 0}, {500, 150}, {250, 150}, {250, 300}, {0, 300}}, {0, 0, 0, 0, 0, 0});
  l.holes.push_back(Contour::circle({100, 150}, 30).reversed());
  rem.remnant = l;
  const std::vector<Sheet> sheets{rem};
  const std::vector<NestPart> parts{disc(20)};
  EXPECT_TRUE(certify(parts, {at(0, 400, 75)}, sheets, 6.0).certified) << "in the lower arm";
  EXPECT_TRUE(certify(parts, {at(0, 100, 150 - 30 - 5 - 20 - 0.01)}, sheets, 6.0).certified) << "just below the cut-out";
  const Certificate corner = certify(parts, {at(0, 400, 225)}, sheets, 6.0);
  ASSERT_FALSE(corner.certified) << "in the corner the remnant lacks";
  EXPECT_NE(corner.violations[0].find("outline"), std::string::npos) << corner.violations[0];
  const Certificate edge = certify(parts, {at(0, 400, 150 - 5 - 19.9)}, sheets, 6.0);
  EXPECT_FALSE(edge.certified) << "0.1 mm nearer than the margin to the inner corner's edge";
  const Certificate cut = certify(parts, {at(0, 100, 150 - 30 - 5 - 19.9)}, sheets, 6.0);
  ASSERT_FALSE(cut.certified);
  EXPECT_NE(cut.violations[0].find("cut-out"), std::string::npos) << cut.violations[0];
  EXPECT_FALSE(certify(parts, {at(0, 100, 150)}, sheets, 6.0).certified) << "on the cut-out";
  // A cut-out may lie in a part's hole, the margin kept from the hole's edge.
  NestPart ring = disc(60);
  ring.holes.push_back(Contour::circle({0, 0}, 36).reversed());
  EXPECT_TRUE(certify({ring}, {at(0, 100, 150)}, sheets, 6.0).certified);
  EXPECT_FALSE(certify({ring}, {at(0, 101.5, 150)}, sheets, 6.0).certified);
}

// The polygon holds the material and lies within the tolerance of the true contour: on the
// rounded outline it runs outside the arcs, round the holes inside them.
TEST(NestOutline, ThePolygonHoldsTheTrueContourAndStaysWithinTheTolerance) {
  const std::string rounded = "0\nLWPOLYLINE\n8\nCUT\n90\n4\n70\n1\n10\n0\n20\n0\n42\n0\n10\n100\n20\n0\n42\n0.4142136\n"
                              "10\n120\n20\n20\n42\n0\n10\n0\n20\n20\n42\n-0.3\n";
  const NestPart p = parts_of(rounded + dxf_circle(40, 10, 6))[0];
  for (const double t : {0.5, 0.05, 0.001}) {
    for (const Contour& c : {p.outer, p.holes[0]}) {
      const std::vector<Eigen::Vector2d> poly = outside_polygon(c, t);
      const Contour polygon(poly, std::vector<double>(poly.size(), 0.0));
      const bool hole = orientation(c) == Orientation::cw;
      double worst_out = 0.0, worst_far = 0.0;
      for (int k = 0; k < 2000; ++k) {  // the true contour, inside (outer) or outside (hole) the polygon
        const Eigen::Vector2d q = point_at_length(c, perimeter(c) * k / 2000.0);
        const double off = distance(polygon, q);
        if (contains(polygon, q) == hole && off > 1e-9) worst_out = std::max(worst_out, off);
        worst_far = std::max(worst_far, off);
      }
      for (const Eigen::Vector2d& v : poly) worst_far = std::max(worst_far, distance(c, v));
      EXPECT_EQ(worst_out, 0.0) << "tolerance " << t << (hole ? ", hole" : ", outer");
      EXPECT_LE(worst_far, t + 1e-9) << "tolerance " << t << (hole ? ", hole" : ", outer");
    }
  }
  EXPECT_THROW(outside_polygon(p.outer, 0.0), InputError);
}

}  // namespace
}  // namespace machplan::nesting
