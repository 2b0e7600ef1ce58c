// Prohibited regions of the bundled profiles (datasets/profiles) and of bad drawings: open
// chains, self-intersections, overlapping contours refused with the file and the entities
// named; a tool too big for a corner, an arc or a slot reported as a warning naming the
// contour and its entities.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/shapes.h"
#include "engine/common/error.h"
#include "engine/geometry/region.h"
#include "engine/programs/dxf.h"
#include "engine/programs/region_profile.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

std::string dir() { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/profiles/"; }



std::string dxf(const std::string& entities) {
  return "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n" + entities +
         "0\nENDSEC\n0\nEOF\n";
}
std::string line(const std::string& handle, double x0, double y0, double x1, double y1) {
  return "0\nLINE\n5\n" + handle + "\n8\nCUT\n10\n" + std::to_string(x0) + "\n20\n" + std::to_string(y0) + "\n11\n" +
         std::to_string(x1) + "\n21\n" + std::to_string(y1) + "\n";
}

std::string message_of(const ProfileReadResult& p, const RegionOptions& o) {
  try {
    build_region(p, o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool has_problem(const ProhibitedRegion& r, OffsetProblem::Kind k, const std::string& text) {
  for (const auto& p : r.problems())
    if (p.kind == k && p.message.find(text) != std::string::npos) return true;
  return false;
}

TEST(RegionProfiles, PaperProfilesBuildOnBothSidesWithBothMethods) {
  for (const char* f : {"paper_triangle.dxf", "paper_quadrilateral.dxf", "paper_heptagon.dxf"}) {
    const auto p = read_dxf_profile(dir() + f);
    ASSERT_EQ(p.contours.size(), 1u) << f;
    EXPECT_FALSE(p.has_errors()) << p.report();
    for (auto side : {MachiningSide::outside, MachiningSide::inside})
      for (auto m : {OffsetMethod::robust, OffsetMethod::paper}) {
        const auto r = build_region(p, test::region_options(side, 3, m));
        ASSERT_EQ(r.boundary().size(), 1u) << f << " " << to_string(side) << " " << to_string(m);
        const double a = std::abs(p.contours[0].area_mm2), b = std::abs(signed_area(r.boundary()[0]));
        // Grown outside, shrunk inside.
        if (side == MachiningSide::outside)
          EXPECT_GT(b, a + 3 * p.contours[0].perimeter_mm * 0.99) << f;
        else
          EXPECT_LT(b, a - 3 * p.contours[0].perimeter_mm * 0.5) << f;
        EXPECT_TRUE(r.problems().empty()) << f << ": " << r.problems().front().message;
      }
  }
}

TEST(RegionProfiles, ArcProfileKeepsArcsAndReportsTheSmallFillet) {
  const auto p = read_dxf_profile(dir() + "arc_profile.dxf");
  ASSERT_EQ(p.contours.size(), 2u) << p.report();
  EXPECT_FALSE(p.has_errors()) << p.report();
  const auto r = build_region(p, test::region_options(MachiningSide::outside, 5));
  // The concave R3 fillet cannot be followed by a 5 mm tool: reported with its contour and
  // entities named.
  EXPECT_TRUE(has_problem(r, OffsetProblem::Kind::arc_collapsed, "contour 0 (entities")) << r.problems().size();
  int arcs = 0;
  for (const auto& c : r.boundary())
    for (const auto& s : c.segments()) arcs += s.is_arc();
  EXPECT_GE(arcs, 5);
  // Machined from outside the hole is a pocket of its own: shrunk to radius 5.
  EXPECT_TRUE(r.prohibited({100, 40 + 5.1}));
  EXPECT_FALSE(r.prohibited({100, 40 + 4.9}));
}

TEST(RegionProfiles, NarrowSlotIsReportedOnBothSides) {
  const auto p = read_dxf_profile(dir() + "narrow_slot.dxf");
  ASSERT_EQ(p.contours.size(), 2u);
  // Outside, a 5 mm tool cannot enter the 8 mm slot: the slot's walls are lost.
  const auto out = build_region(p, test::region_options(MachiningSide::outside, 5));
  EXPECT_TRUE(has_problem(out, OffsetProblem::Kind::feature_too_small, "contour 0 (entity")) << out.problems().size();
  EXPECT_TRUE(out.prohibited({60, 70}));  // in the slot
  // A 3.9 mm tool fits (8 > 7.8): the slot's middle is allowed.
  EXPECT_FALSE(build_region(p, test::region_options(MachiningSide::outside, 3.9)).prohibited({60, 60}));
  // Inside, the keyhole pocket's 6 mm channel cannot take a 5 mm tool.
  const auto in = build_region(p, test::region_options(MachiningSide::inside, 5));
  EXPECT_TRUE(has_problem(in, OffsetProblem::Kind::feature_too_small, "contour 1 (entity")) << in.problems().size();
  EXPECT_FALSE(in.prohibited({30, 40}));
  EXPECT_FALSE(in.prohibited({170, 40}));
  EXPECT_TRUE(in.prohibited({205, 40}));  // in the channel
  // The paper's method keeps the channel's square corners (their setback R tan(45 deg) = 5 mm
  // is shorter than the 6 mm channel end), so its mitre offset turns the channel inside out;
  // the merge removes that loop and says so.
  const auto paper = build_region(p, test::region_options(MachiningSide::inside, 5, OffsetMethod::paper));
  EXPECT_TRUE(has_problem(paper, OffsetProblem::Kind::gap_too_narrow, "contour 1 (entity")) << paper.problems().size();
  EXPECT_TRUE(paper.prohibited({205, 40}));
}

TEST(RegionProfiles, OpenChainIsRefusedNamingFileAndEntities) {
  const std::string text = dxf(line("A1", 0, 0, 50, 0) + line("A2", 50, 0, 50, 40) + line("A3", 50, 40, 0, 40));
  const auto p = read_dxf_profile_text(text, "open.dxf");
  const std::string m = message_of(p, test::region_options(MachiningSide::outside, 2));
  EXPECT_NE(m.find("open.dxf: open_chain (entities A1, A2, A3)"), std::string::npos) << m;
}

TEST(RegionProfiles, SelfIntersectionIsRefusedNamingFileAndEntities) {
  // A lopsided bow tie (it encloses area, so the crossing is what is wrong): B1 and B3 cross
  // at (21.4286, 17.1429).
  const std::string text =
      dxf(line("B1", 0, 0, 50, 40) + line("B2", 50, 40, 50, 0) + line("B3", 50, 0, 0, 30) + line("B4", 0, 30, 0, 0));
  const auto p = read_dxf_profile_text(text, "bow.dxf");
  const std::string m = message_of(p, test::region_options(MachiningSide::outside, 2));
  EXPECT_NE(m.find("bow.dxf: self_intersection (entities"), std::string::npos) << m;
  EXPECT_NE(m.find("at (21.4286, 17.1429)"), std::string::npos) << m;
}

TEST(RegionProfiles, ToolTooBigForThePocketIsRefused) {
  const auto p = read_dxf_profile(dir() + "narrow_slot.dxf");
  const std::string m = message_of(p, test::region_options(MachiningSide::inside, 45));
  EXPECT_NE(m.find("narrow_slot.dxf: prohibited region: nothing is left for the tool"), std::string::npos) << m;
}

TEST(RegionProfiles, SharpCornerDroppedByThePaperMethodIsNamed) {
  // A 10-degree spike on a square: with R = 4 the setback R tan(phi/2) at its tip exceeds the
  // spike's sides, so the paper's method drops the tip, and the warning names it.
  const std::string text = dxf(line("C1", 0, 0, 40, 0) + line("C2", 40, 0, 40, 40) + line("C3", 40, 40, 23, 40) +
                               line("C4", 23, 40, 20, 57) + line("C5", 20, 57, 17, 40) + line("C6", 17, 40, 0, 40) +
                               line("C7", 0, 40, 0, 0));
  const auto p = read_dxf_profile_text(text, "spike.dxf");
  ASSERT_FALSE(p.has_errors()) << p.report();
  const auto r = build_region(p, test::region_options(MachiningSide::outside, 4, OffsetMethod::paper));
  EXPECT_TRUE(has_problem(r, OffsetProblem::Kind::vertex_dropped, "(20.0000, 57.0000) dropped")) << r.problems().size();
  // The robust method keeps the spike: its tip is 4 mm inside the limit.
  const auto robust = build_region(p, test::region_options(MachiningSide::outside, 4));
  EXPECT_NEAR(robust.query({20, 57}).signed_distance_mm, -4.0, 1e-9);
  EXPECT_TRUE(robust.problems().empty());
}

}  // namespace
}  // namespace machplan
