// Tool-path readers: APT/CLDATA and CSV, what they accept, what they refuse and how they say it.
#include "engine/programs/toolpath.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "engine/common/error.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

namespace fs = std::filesystem;

using test::TempDir;
using test::error_of;

std::string apt_error(const std::string& text) {
  return error_of([&] { read_apt(text, "path.cl"); });
}

std::string csv_error(const std::string& text) {
  return error_of([&] { read_toolpath_csv(text, "path.csv"); });
}

TEST(Apt, EveryStatement) {
  const std::string text =
      "$$ a comment line\n"
      "PARTNO bracket op 10\n"
      "UNITS/MM\n"
      "\n"
      "CUTTER/10, 5, 0, 0, 0, 0, 50\n"
      "MULTAX/ON\n"
      "FEDRAT/MMPM, 1200\n"
      "tlaxis / 0, 0, 2   $$ normalised to (0, 0, 1)\n"
      "RAPID\n"
      "GOTO/0, 0, 50\n"
      "GOTO/10, 20, 30, $\n"
      "   0, 1, 1\n"
      "FEDRAT/800, MMPM\n"
      "goto/ +1.5e1, -20., .5\n"
      "FEDRAT/600\n"
      "MULTAX/OFF\n"
      "MULTAX\n"
      "GOTO/1,2,3\n"
      "FINI\n"
      "$$ trailing comment\n";
  const ToolPath p = read_apt(text, "part.cl");
  EXPECT_EQ(p.source, "part.cl");
  EXPECT_EQ(p.part_name, "bracket op 10");
  ASSERT_TRUE(p.cutter.has_value());
  EXPECT_DOUBLE_EQ(p.cutter->diameter_mm, 10.0);
  EXPECT_DOUBLE_EQ(p.cutter->corner_radius_mm, 5.0);
  EXPECT_DOUBLE_EQ(p.cutter->length_mm, 50.0);
  EXPECT_TRUE(p.multiaxis);
  ASSERT_EQ(p.poses.size(), 4u);

  EXPECT_TRUE(p.poses[0].rapid);
  EXPECT_EQ(p.poses[0].line, 10);
  EXPECT_TRUE(p.poses[0].axis.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_DOUBLE_EQ(p.poses[0].feed_mm_per_min, 1200.0);

  EXPECT_FALSE(p.poses[1].rapid);
  EXPECT_EQ(p.poses[1].line, 11);  // a continued statement carries its first line
  EXPECT_TRUE(p.poses[1].tip_mm.isApprox(Eigen::Vector3d(10, 20, 30)));
  EXPECT_NEAR(p.poses[1].axis.norm(), 1.0, 1e-15);
  EXPECT_TRUE(p.poses[1].axis.isApprox(Eigen::Vector3d(0, 1, 1).normalized()));

  EXPECT_TRUE(p.poses[2].tip_mm.isApprox(Eigen::Vector3d(15, -20, 0.5)));
  EXPECT_TRUE(p.poses[2].axis.isApprox(Eigen::Vector3d::UnitZ()));  // a 6-value GOTO leaves TLAXIS alone
  EXPECT_DOUBLE_EQ(p.poses[2].feed_mm_per_min, 800.0);
  EXPECT_DOUBLE_EQ(p.poses[3].feed_mm_per_min, 600.0);
  EXPECT_EQ(p.poses[3].line, 18);
}

TEST(Apt, CrLfLineEndsAndMissingFinalNewline) {
  const ToolPath p = read_apt("GOTO/1,2,3\r\nGOTO/4,5,6", "crlf.cl");
  ASSERT_EQ(p.poses.size(), 2u);
  EXPECT_TRUE(p.poses[1].tip_mm.isApprox(Eigen::Vector3d(4, 5, 6)));
  EXPECT_EQ(p.poses[1].line, 2);
}

TEST(Apt, InchesAreConverted) {
  const ToolPath p = read_apt("UNITS/INCHES\nCUTTER/0.5\nFEDRAT/10\nGOTO/1,2,3\nFEDRAT/MMPM,100\nGOTO/1,1,1,1,0,0\n"
                              "UNITS/MM\nGOTO/1,1,1\n",
                              "in.cl");
  ASSERT_EQ(p.poses.size(), 3u);
  EXPECT_TRUE(p.poses[0].tip_mm.isApprox(Eigen::Vector3d(25.4, 50.8, 76.2)));
  EXPECT_DOUBLE_EQ(p.poses[0].feed_mm_per_min, 254.0);
  EXPECT_DOUBLE_EQ(p.cutter->diameter_mm, 12.7);
  EXPECT_DOUBLE_EQ(p.poses[1].feed_mm_per_min, 100.0);
  EXPECT_TRUE(p.poses[1].axis.isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(p.poses[2].tip_mm.isApprox(Eigen::Vector3d(1, 1, 1)));
}

TEST(Apt, OtherStatementsAreSkippedAndCountedPerKind) {
  const ToolPath p = read_apt("PARTNO x\nSELECT/TOOL,3\nGOTO/0,0,0\nSPINDL/1000,RPM,CLW\nPPRINT hello there\n"
                              "COOLNT/FLOOD\nSELECT/TOOL,4\nSPINDL/OFF\nGOTO/1,1,1\nFINI\n",
                              "path.cl");
  ASSERT_EQ(p.poses.size(), 2u);
  EXPECT_TRUE(p.warnings.empty()) << "nothing skipped changes the path";
  ASSERT_EQ(p.skipped.size(), 4u);
  EXPECT_EQ(p.skipped[0].statement, "SELECT");
  EXPECT_EQ(p.skipped[0].first_line, 2);
  EXPECT_EQ(p.skipped[0].count, 2u);
  EXPECT_EQ(p.skipped[3].statement, "COOLNT");
  EXPECT_EQ(skipped_summary(p), "path.cl: skipped 6 statements that carry no tool-path geometry: SELECT x2 (first at line 2), "
                                "SPINDL x2 (first at line 4), PPRINT (line 5), COOLNT (line 6)");
  // A coordinate system that moves the poses is not applied: the one warning; identity ones
  // are skipped like the rest.
  const ToolPath c = read_apt("CSYS/1,0,0,0,0,1,0,0,0,0,1,0\nGOTO/0,0,0\nCSYS/1,0,0,5,0,1,0,0,0,0,1,0\nGOTO/1,1,1\n"
                              "CSYS/1,0,0,7,0,1,0,0,0,0,1,0\n",
                              "c.cl");
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0], "c.cl:3: APT statement 'CSYS' with a transformation other than the identity (2 statements): "
                           "the poses after it are kept in the coordinates written, not transformed");
  EXPECT_EQ(skipped_summary(c), "c.cl: skipped 1 statement that carries no tool-path geometry: CSYS (line 1)");
  EXPECT_TRUE(c.poses[1].tip_mm.isApprox(Eigen::Vector3d(1, 1, 1)));
}

// Tools as CAM systems write them: a CUTTER before its LOAD/TOOL (CAMWorks), after it, or alone;
// a tool loaded again is the same tool; each move carries the tool that makes it.
TEST(Apt, ToolsAreBoundToTheMovesTheyMake) {
  const ToolPath p = read_apt("GOTO/0,0,50\n"                                   // 1: before any tool
                              "CUTTER/6,0,3,1.8,31,0,45\nLOAD/TOOL,6\n"         // 2-3: CUTTER first
                              "CSI_SET_FLUTE_LENGTH/2.\nCSI_SET_EXTENSION_LENGTH/22.5\n"
                              "GOTO/0,0,10\n"                                   // 6
                              "LOAD/TOOL,2\nCUTTER/10,2\n"                      // 7-8: CUTTER after
                              "GOTO/5,0,10\nGOTO/6,0,10\n"                     // 9-10
                              "LOAD/TOOL,6\nGOTO/7,0,10\n",                    // 11-12: T6 again
                              "t.cl");
  ASSERT_EQ(p.tools.size(), 2u);
  EXPECT_EQ(p.tools[0].name(), "T6");
  EXPECT_EQ(p.tools[0].line, 3);
  ASSERT_TRUE(p.tools[0].cutter);
  EXPECT_DOUBLE_EQ(p.tools[0].cutter->diameter_mm, 6.0);
  EXPECT_DOUBLE_EQ(p.tools[0].cutter->length_mm, 45.0);
  EXPECT_DOUBLE_EQ(p.tools[0].flute_mm, 2.0);
  EXPECT_DOUBLE_EQ(p.tools[0].extension_mm, 22.5);
  EXPECT_EQ(p.tools[0].poses, 2u);
  EXPECT_EQ(p.tools[1].name(), "T2");
  ASSERT_TRUE(p.tools[1].cutter);
  EXPECT_DOUBLE_EQ(p.tools[1].cutter->corner_radius_mm, 2.0);
  EXPECT_EQ(p.tools[1].poses, 2u);
  const int expected[] = {-1, 0, 1, 1, 0};
  ASSERT_EQ(p.poses.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(p.poses[i].tool, expected[i]) << "pose " << i;

  // A CUTTER alone describes the tool in the spindle, and a second one after moves a new tool.
  const ToolPath c = read_apt("CUTTER/6\nGOTO/0,0,0\nCUTTER/12\nGOTO/1,0,0\n", "c.cl");
  ASSERT_EQ(c.tools.size(), 2u);
  EXPECT_EQ(c.tools[0].number, -1);
  EXPECT_EQ(c.tools[1].name(), "the tool of line 3");
  EXPECT_EQ(c.poses[1].tool, 1);

  // One number, one tool; bad numbers are refused at their line.
  EXPECT_THAT(apt_error("LOAD/TOOL,6\nCUTTER/6\nGOTO/0,0,0\nLOAD/TOOL,6\nCUTTER/8\nGOTO/1,0,0\n"),
              HasSubstr("path.cl:5: CUTTER describes tool 6 unlike the CUTTER of line 2"));
  EXPECT_THAT(apt_error("GOTO/0,0,0\nLOAD/TOOL,2.5\n"), HasSubstr("path.cl:2: LOAD/TOOL: tool number 2.5 must be an integer"));
  EXPECT_THAT(apt_error("LOAD/SPINDL,3\n"), HasSubstr("path.cl:1: LOAD: expected LOAD/TOOL, n"));
  EXPECT_THAT(apt_error("LOAD/TOOL,1\nCSI_SET_FLUTE_LENGTH/-2\n"), HasSubstr("path.cl:2: CSI_SET_FLUTE_LENGTH: length -2"));
}

TEST(Apt, CutterCompensationIsAWarning) {
  const ToolPath p = read_apt("GOTO/0,0,0\nCUTCOM/LEFT\nGOTO/1,0,0\nCUTCOM/OFF\nCUTCOM/RIGHT\nGOTO/2,0,0\n", "k.cl");
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_THAT(p.warnings[0], HasSubstr("k.cl:2: cutter compensation (CUTCOM/LEFT or RIGHT) (2 statements)"));
}

// Distance of p from the circle of `arc` (radially and along its axis from the helix).
double off_arc(const ToolArc& arc, const Eigen::Vector3d& p) {
  const Eigen::Vector3d r = p - arc.center_mm;
  const Eigen::Vector3d radial = r - r.dot(arc.axis) * arc.axis;
  return std::abs(radial.norm() - arc.radius_mm);
}

TEST(Apt, CycleClearStartsTheCycleStateAfreshLikeCycleInit) {
  // Two drilled holes between CYCLE/CLEAR lines, as some post-processors write them: read as
  // with CYCLE/INIT, never refused for its missing FEDTO.
  const auto program = [](const std::string& reset) {
    return "UNIT/MM\n"
           "FEDRAT/300.,MMPM\n"
           "RAPID/\n"
           "GOTO/0,0,20.\n"
           "CYCLE/" + reset + "\n"
           "CYCLE/DRILL,FEDTO,5.,RTRCTO,2.\n"
           "GOTO/10.,10.,0\n"
           "GOTO/20.,10.,0\n"
           "CYCLE/OFF\n"
           "CYCLE/" + reset + "\n"
           "GOTO/0,0,20.\n"
           "FINI\n";
  };
  const ToolPath clear = read_apt(program("CLEAR"), "clear.apt");
  const ToolPath init = read_apt(program("INIT"), "init.apt");
  EXPECT_TRUE(clear.warnings.empty());
  ASSERT_EQ(clear.poses.size(), init.poses.size());
  for (std::size_t i = 0; i < clear.poses.size(); ++i) {
    EXPECT_EQ(clear.poses[i].tip_mm, init.poses[i].tip_mm) << i;
    EXPECT_EQ(clear.poses[i].rapid, init.poses[i].rapid) << i;
  }
  // Each hole: rapid to 2 mm above, feed to 5 mm deep, rapid back up.
  std::size_t deep = 0;
  for (const ToolPose& q : clear.poses) deep += q.tip_mm.z() == -5.0 && !q.rapid;
  EXPECT_EQ(deep, 2u);
}

TEST(Apt, CamStyleFileWithUnitCirclesAndCycles) {
  const std::string text =
      "PARTNO/1\n"                                // 1
      "UNIT/MM\n"                                 // 2
      "CUTTER/6.,0,3.,1.8,31.,0,45.\n"            // 3
      "LOAD/TOOL,6\n"                             // 4
      "RAPID/\n"                                  // 5
      "GOTO/15.,15.,25.\n"                        // 6
      "CYCLE/INIT\n"                              // 7
      "CYCLE/DEEP2,FEDTO,10.,1STPECK,5.,SUBPECK,2.,MMPM,200.,RAPTO,3.,RTRCTO,25.\n"  // 8
      "GOTO/15.,15.,0\n"                          // 9
      "GOTO/45.,15.,0\n"                          // 10
      "CYCLE/OFF\n"                               // 11
      "RAPID/\n"                                  // 12
      "GOTO/30.,0,-5.\n"                          // 13
      "FEDRAT/600.,MMPM\n"                        // 14
      "CIRCLE/30.,10.,-5.,0,0,1.\n"               // 15: full turn counter-clockwise, r = 10
      "GOTO/30.,0,-5.\n"                          // 16
      "CIRCLE/30.,10.,-5.,0,0,-1.,10.\n"          // 17: quarter clockwise to (20, 10)
      "GOTO/20.,10.,-7.\n"                        // 18: and down 2 mm: a helix
      "FINI\n";
  const ToolPath p = read_apt(text, "cam.apt");
  EXPECT_TRUE(p.warnings.empty());
  EXPECT_EQ(skipped_summary(p), "") << "LOAD/TOOL names the tool of the moves";
  ASSERT_EQ(p.tools.size(), 1u);
  EXPECT_EQ(p.tools[0].name(), "T6");
  // The cycle: from (15, 15, 25) already at the retract height, rapid to RAPTO 3, feed to
  // -10, back to 25; then the second hole adds its approach at 25 first.
  std::vector<Eigen::Vector3d> drill;
  std::vector<bool> rapid;
  std::size_t k = 0;
  for (; k < p.poses.size() && p.poses[k].line <= 10; ++k) {
    drill.push_back(p.poses[k].tip_mm);
    rapid.push_back(p.poses[k].rapid);
  }
  const std::vector<Eigen::Vector3d> want = {{15, 15, 25}, {15, 15, 3},  {15, 15, -10}, {15, 15, 25},
                                             {45, 15, 25}, {45, 15, 3}, {45, 15, -10}, {45, 15, 25}};
  ASSERT_EQ(drill.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_TRUE(drill[i].isApprox(want[i])) << i << ": " << drill[i].transpose();
  EXPECT_EQ(rapid, (std::vector<bool>{true, true, false, true, true, true, false, true}));
  EXPECT_DOUBLE_EQ(p.poses[2].feed_mm_per_min, 200.0);

  ASSERT_EQ(p.arcs.size(), 2u);
  const ToolArc& full = p.arcs[0];
  EXPECT_NEAR(full.sweep_rad, 2 * M_PI, 1e-12);
  EXPECT_NEAR(full.radius_mm, 10, 1e-12);
  EXPECT_EQ(full.line, 15);
  const ToolArc& quarter = p.arcs[1];
  EXPECT_NEAR(quarter.sweep_rad, M_PI / 2, 1e-12);
  ToolPathReadOptions o;
  for (int a = 0; a < 2; ++a) {
    const ToolArc& arc = p.arcs[static_cast<std::size_t>(a)];
    EXPECT_EQ(p.poses[arc.last_pose].arc, a);
    for (std::size_t i = arc.first_pose; i <= arc.last_pose; ++i) {
      EXPECT_LT(off_arc(arc, p.poses[i].tip_mm), 1e-9);
      const Eigen::Vector3d step = p.poses[i].tip_mm - p.poses[i - 1].tip_mm;
      // Chord error r (1 - cos(h / 2)) from the chord length 2 r sin(h / 2).
      const double h = 2 * std::asin(std::min(1.0, (step - step.dot(arc.axis) * arc.axis).norm() / (2 * arc.radius_mm)));
      EXPECT_LE(arc.radius_mm * (1 - std::cos(h / 2)), o.arc_tolerance_mm + 1e-12);
      EXPECT_LE(h, o.arc_step_rad + 1e-12);
    }
  }
  // Counter-clockwise seen from +z: from (30, 0) the full turn heads to +x first.
  EXPECT_GT(p.poses[full.first_pose].tip_mm.x(), 30);
  // Clockwise about -z... i.e. (0, 0, -1) with the right-hand rule: from (30, 0) towards -x.
  EXPECT_LT(p.poses[quarter.first_pose].tip_mm.x(), 30);
  // The helix descends linearly with the angle.
  const std::size_t mid = (quarter.first_pose + quarter.last_pose) / 2;
  const double frac = static_cast<double>(mid - quarter.first_pose + 1) / static_cast<double>(quarter.last_pose - quarter.first_pose + 1);
  EXPECT_NEAR(p.poses[mid].tip_mm.z(), -5 - 2 * frac, 1e-9);
  EXPECT_TRUE(p.poses.back().tip_mm.isApprox(Eigen::Vector3d(20, 10, -7)));
  EXPECT_DOUBLE_EQ(p.poses.back().feed_mm_per_min, 600.0);
}

TEST(Apt, CirclesAndCyclesRefuseWhatTheyCannotMean) {
  EXPECT_THAT(apt_error("CIRCLE/0,0,0,0,0,1\nGOTO/1,0,0\n"), HasSubstr("path.cl:1: CIRCLE before any position"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCIRCLE/0,0,0,0,0,1\nGOTO/0,2,0\n"),
              HasSubstr("path.cl:3: the GOTO ending the CIRCLE of line 2 is 2 mm from the axis"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCIRCLE/0,0,0,0,0,1,3\nGOTO/0,1,0\n"),
              HasSubstr("path.cl:2: CIRCLE: radius 3 mm but the start point is 1 mm"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCIRCLE/0,0,0,0,0,1\nFINI\n"), HasSubstr("path.cl:3: FINI after the CIRCLE of line 2"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCIRCLE/0,0,0,0,0,1\n"), HasSubstr("path.cl:2: CIRCLE without a GOTO"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCIRCLE/0,0,0\n"), HasSubstr("path.cl:2: CIRCLE: expected at least 6 values"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCYCLE/DRILL,RAPTO,3\nGOTO/1,1,0\n"), HasSubstr("path.cl:2: CYCLE/DRILL: no FEDTO"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCYCLE/DRILL,FEDTO\n"), HasSubstr("path.cl:2: CYCLE: 'FEDTO' has no value"));
  EXPECT_THAT(apt_error("GOTO/1,0,0\nCYCLE/DRILL,FEDTO,3\nGOTO/1,1,0\n"), HasSubstr("no feed"));
  EXPECT_THAT(apt_error("RAPID/1\n"), HasSubstr("path.cl:1: RAPID: expected 3 values"));
  const ToolPath r = read_apt("RAPID/1,2,3\nGODLTA/1,1,1\n", "r.cl");
  ASSERT_EQ(r.poses.size(), 2u);
  EXPECT_TRUE(r.poses[0].rapid);
  EXPECT_TRUE(r.poses[1].tip_mm.isApprox(Eigen::Vector3d(2, 3, 4)));
}

TEST(Apt, ZeroAndTinyAxesAreRefused) {
  EXPECT_THAT(apt_error("GOTO/0,0,0\nTLAXIS/0,0,0\nGOTO/1,1,1\n"), HasSubstr("path.cl:2: tool axis (0, 0, 0)"));
  EXPECT_THAT(apt_error("GOTO/0,0,0\nGOTO/1,1,1,1e-10,0,0\n"), HasSubstr("path.cl:2: tool axis"));
  // Just above the threshold is fine, and normalised.
  const ToolPath p = read_apt("GOTO/1,1,1,0,2e-9,0\n", "ok.cl");
  EXPECT_TRUE(p.poses[0].axis.isApprox(Eigen::Vector3d::UnitY()));
}

TEST(Apt, BadNumbersAreRefused) {
  EXPECT_THAT(apt_error("GOTO/1,nan,2\n"), HasSubstr("path.cl:1: GOTO y: number 'nan' is not finite"));
  EXPECT_THAT(apt_error("GOTO/1,2,inf\n"), HasSubstr("path.cl:1: GOTO z: number 'inf' is not finite"));
  EXPECT_THAT(apt_error("\nGOTO/1e999,2,3\n"), HasSubstr("path.cl:2: GOTO x: number '1e999' is out of range"));
  EXPECT_THAT(apt_error("GOTO/1,2,3x\n"), HasSubstr("path.cl:1: GOTO z: expected a number, found '3x'"));
  EXPECT_THAT(apt_error("GOTO/1,,3\n"), HasSubstr("path.cl:1: GOTO y: expected a number, found ''"));
  EXPECT_THAT(apt_error("TLAXIS/0,0,nan\n"), HasSubstr("path.cl:1: TLAXIS k"));
}

TEST(Apt, MalformedStatementsAreRefused) {
  EXPECT_THAT(apt_error("GOTO/1,2\n"), HasSubstr("path.cl:1: GOTO: expected 3 values"));
  EXPECT_THAT(apt_error("GOTO/1,2,3,4\n"), HasSubstr("found 4"));
  EXPECT_THAT(apt_error("GOTO/\n"), HasSubstr("path.cl:1: APT statement 'GOTO': no values after '/'"));
  EXPECT_THAT(apt_error("GOTO/1,2,3\nTLAXIS/NORMAL,PS\n"), HasSubstr("path.cl:2: TLAXIS: only the form"));
  EXPECT_THAT(apt_error("FEDRAT/0\nGOTO/1,2,3\n"), HasSubstr("path.cl:1: FEDRAT: feed 0 must be positive"));
  EXPECT_THAT(apt_error("FEDRAT/MMPR,0.1\n"), HasSubstr("path.cl:1: FEDRAT: per-revolution feed 'MMPR'"));
  EXPECT_THAT(apt_error("FEDRAT/FAST,10\n"), HasSubstr("unknown feed mode 'FAST'"));
  EXPECT_THAT(apt_error("CUTTER/0\n"), HasSubstr("path.cl:1: CUTTER: diameter 0 must be positive"));
  EXPECT_THAT(apt_error("CUTTER/10,6\n"), HasSubstr("corner radius 6"));
  EXPECT_THAT(apt_error("UNITS/FEET\n"), HasSubstr("path.cl:1: UNITS: expected UNITS/MM or UNITS/INCHES"));
  EXPECT_THAT(apt_error("MULTAX/MAYBE\n"), HasSubstr("path.cl:1: MULTAX"));
  EXPECT_THAT(apt_error("GOTO/1,2,3\nFINI\nGOTO/4,5,6\n"), HasSubstr("path.cl:3: APT statement 'GOTO' after FINI"));
  EXPECT_THAT(apt_error("GOTO/1,2,3\nGOTO/4,5, $\n"),
              HasSubstr("path.cl:2: statement continued with '$' but the file ends"));
  EXPECT_THAT(apt_error("GOTO/1,2,3\n12,3,4\n"), HasSubstr("path.cl:2: expected an APT statement"));
  EXPECT_THAT(apt_error("GOTO/1,2,3\n\x01\x02\n"), HasSubstr("path.cl:2: expected an APT statement"));
  EXPECT_EQ(apt_error("PARTNO x\n$$ nothing\nFINI\n"), "path.cl: the tool path holds no pose");
  EXPECT_EQ(apt_error(""), "path.cl: the tool path holds no pose");
}

TEST(Apt, LimitsAreEnforced) {
  ToolPathReadOptions o;
  o.max_poses = 2;
  EXPECT_THAT(error_of([&] { read_apt("GOTO/1,2,3\nGOTO/1,2,3\nGOTO/1,2,3\n", "cap.cl", o); }),
              HasSubstr("cap.cl:3: more than 2 poses"));
  o = {};
  o.max_line_bytes = 16;
  EXPECT_THAT(error_of([&] { read_apt("GOTO/1,2,3\nGOTO/1.000000000,2,3\n", "long.cl", o); }),
              HasSubstr("long.cl:2: line is longer than 16 bytes"));
  o = {};
  o.max_statement_bytes = 20;
  EXPECT_THAT(error_of([&] { read_apt("GOTO/1, $\n2, $\n3, $\n4, $\n5, $\n6\n", "cont.cl", o); }),
              HasSubstr("cont.cl:1: statement continued with '$' is longer than 20 bytes"));
}

TEST(Csv, HeaderWithAxisAndFeed) {
  const ToolPath p = read_toolpath_csv("# exported\nx, y, z, i, j, k, feed\n1,2,3,0,0,1,500\n\n4,5,6,1,0,1,600\n",
                                       "p.csv");
  ASSERT_EQ(p.poses.size(), 2u);
  EXPECT_TRUE(p.multiaxis);
  EXPECT_EQ(p.poses[1].line, 5);
  EXPECT_TRUE(p.poses[1].tip_mm.isApprox(Eigen::Vector3d(4, 5, 6)));
  EXPECT_TRUE(p.poses[1].axis.isApprox(Eigen::Vector3d(1, 0, 1).normalized()));
  EXPECT_DOUBLE_EQ(p.poses[1].feed_mm_per_min, 600.0);
}

TEST(Csv, HeaderInAnotherOrderAndUpperCase) {
  const ToolPath p = read_toolpath_csv("K,J,I,Z,Y,X\r\n1,0,0,3,2,1\r\n", "p.csv");
  ASSERT_EQ(p.poses.size(), 1u);
  EXPECT_TRUE(p.poses[0].tip_mm.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(p.poses[0].axis.isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(Csv, WithoutHeader) {
  const ToolPath three = read_toolpath_csv("1,2,3\n4,5,6\n", "p.csv");
  ASSERT_EQ(three.poses.size(), 2u);
  EXPECT_FALSE(three.multiaxis);
  EXPECT_TRUE(three.poses[0].axis.isApprox(Eigen::Vector3d::UnitZ()));
  const ToolPath six = read_toolpath_csv("1,2,3,0,1,0\n", "p.csv");
  EXPECT_TRUE(six.poses[0].axis.isApprox(Eigen::Vector3d::UnitY()));
  const ToolPath seven = read_toolpath_csv("1,2,3,0,1,0,250\n", "p.csv");
  EXPECT_DOUBLE_EQ(seven.poses[0].feed_mm_per_min, 250.0);
}

TEST(Csv, Refusals) {
  EXPECT_THAT(csv_error("x,y,z,i,j,k\n0,0,0,0,0,1\n1,0,0,0,0,0\n"), HasSubstr("path.csv:3: tool axis (0, 0, 0)"));
  EXPECT_THAT(csv_error("x,y,z\n1,2,3\n1,2\n"), HasSubstr("path.csv:3: CSV row has 2 fields, expected 3"));
  EXPECT_THAT(csv_error("1,2,3,4\n"), HasSubstr("path.csv:1: CSV row has 4 fields"));
  EXPECT_THAT(csv_error("x,y,w\n"), HasSubstr("path.csv:1: CSV header: unknown column 'w'"));
  EXPECT_THAT(csv_error("x,y,z,x\n"), HasSubstr("column 'x' appears twice"));
  EXPECT_THAT(csv_error("x,y,z,i\n"), HasSubstr("i, j and k go together"));
  EXPECT_THAT(csv_error("x,y\n"), HasSubstr("x, y and z are required"));
  EXPECT_THAT(csv_error("1,2,nan\n"), HasSubstr("path.csv:1: z: number 'nan' is not finite"));
  EXPECT_THAT(csv_error("\n\n1,2,1e400\n"), HasSubstr("path.csv:3: z: number '1e400' is out of range"));
  EXPECT_THAT(csv_error("1e308,2,3\n"), HasSubstr("path.csv:1: x: number '1e308' is beyond +-1e+09"));
  EXPECT_THAT(csv_error("x,y,z,feed\n1,2,3,-5\n"), HasSubstr("path.csv:2: feed -5 must be positive"));
  EXPECT_THAT(csv_error("# only comments\n"), HasSubstr("path.csv: the tool path holds no pose"));
}

TEST(Files, FormatByExtensionOrContent) {
  TempDir dir;
  const std::string apt = "GOTO/1,2,3\n";
  const std::string csv = "x,y,z\n1,2,3\n";
  for (const char* name : {"a.cl", "a.APT", "a.cls"}) {
    EXPECT_EQ(read_toolpath_file(dir.write(name, apt)).poses.size(), 1u) << name;
  }
  EXPECT_EQ(read_toolpath_file(dir.write("a.csv", csv)).poses.size(), 1u);
  EXPECT_EQ(read_toolpath_file(dir.write("sniffed_apt.txt", "$$ hi\n" + apt)).poses.size(), 1u);
  EXPECT_EQ(read_toolpath_file(dir.write("sniffed_csv.txt", csv)).poses.size(), 1u);
  EXPECT_EQ(read_toolpath_file(dir.write("sniffed_plain.dat", "# c\n-1,2,3\n")).poses.size(), 1u);
  // The extension wins over the content: CSV text in a .cl file is refused as APT (the
  // header's first word passes for an unknown statement, the numbers do not).
  const std::string wrong = dir.write("wrong.cl", csv);
  EXPECT_THAT(error_of([&] { read_toolpath_file(wrong); }), HasSubstr(wrong + ":2: expected an APT statement"));
  const std::string odd = dir.write("odd.txt", "\n*&^\n");
  EXPECT_THAT(error_of([&] { read_toolpath_file(odd); }), HasSubstr(odd + ":2: cannot tell whether"));
  EXPECT_THAT(error_of([&] { read_toolpath_file(dir.write("empty.txt", "")); }), HasSubstr("no pose"));
  EXPECT_THAT(error_of([] { read_toolpath_file("/nonexistent/path.cl"); }), HasSubstr("/nonexistent/path.cl: "));
}

TEST(ToolPathSummary, FiguresFollowThePoses) {
  const ToolPath p = read_apt("GOTO/0,0,0\nGOTO/3,4,0,0,1,1\nRAPID\nGOTO/3,4,10,1,0,0\nGOTO/3,5,10\n", "s.cl");
  const ToolPathSummary s = summarize(p);
  EXPECT_EQ(s.poses, 4u);
  EXPECT_EQ(s.rapid_poses, 1u);
  EXPECT_TRUE(s.min_mm.isApprox(Eigen::Vector3d(0, 0, 0)));
  EXPECT_TRUE(s.max_mm.isApprox(Eigen::Vector3d(3, 5, 10)));
  EXPECT_NEAR(s.min_tilt_rad, 0.0, 1e-15);
  EXPECT_NEAR(s.max_tilt_rad, M_PI / 2, 1e-12);
  EXPECT_DOUBLE_EQ(s.max_step_mm, 10.0);
  EXPECT_EQ(s.max_step_line, 4);
  EXPECT_DOUBLE_EQ(s.feed_length_mm, 5.0 + 1.0);
  EXPECT_DOUBLE_EQ(s.rapid_length_mm, 10.0);
}

// The HexaM placement test path: 351 x 351 points at 1 mm, axis along a surface normal.
std::string hexam_sized_apt(int n) {
  std::string s = "PARTNO grid\nCUTTER/10,5\nMULTAX/ON\nFEDRAT/MMPM,1000\n";
  s.reserve(static_cast<std::size_t>(n) * n * 64);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double x = a - 175.0, y = b - 175.0;
      const double z = 100.0 - 0.001 * (x * x + y * y);
      s += fmt::format("GOTO/{:.4f},{:.4f},{:.4f},{:.6f},{:.6f},{:.6f}\n", x, y, z, 0.002 * x, 0.002 * y, 1.0);
    }
  return s + "FINI\n";
}


TEST(Reader, HexamSizedPathReadsWhole) {
  // The size of the HexaM placement test (351 x 351 poses); its speed is measured in
  // bench/readers_bench.cpp, not here.
  const int n = 351;
  const ToolPath p = read_apt(hexam_sized_apt(n), "grid.cl");
  ASSERT_EQ(p.poses.size(), static_cast<std::size_t>(n * n));
  EXPECT_NEAR(p.poses.back().axis.norm(), 1.0, 1e-12);
}

TEST(Cli, BadInputExitsWithTwoAndNamesTheLine) {
  test::Cli cli;
  const std::string bad = cli.write("bad.cl", "GOTO/0,0,0\nCIRCLE/1\n");
  const test::CliResult r = cli.run({"toolpath", bad});
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr(bad + ":2: CIRCLE: expected at least 6 values"));

  // Skipped statements are one note on stderr, and the exit code stays 0.
  const std::string skipped = cli.write("skipped.apt", "UNIT/MM\nSPINDL/1000\nGOTO/0,0,0\nGOTO/1,0,0\nFINI\n");
  const test::CliResult w = cli.run({"toolpath", skipped});
  EXPECT_EQ(w.code, 0);
  EXPECT_EQ(w.err, "note: " + skipped + ": skipped 1 statement that carries no tool-path geometry: SPINDL (line 2)\n");

  // A CAM file's dozen kinds of set-up statements stay one line, and the CSYS that is not
  // applied comes first, on stderr and atop the report.
  std::string cam = "PARTNO/P\n";
  for (const char* word : {"LOAD/TOOL,1", "SELECT/TOOL,1", "SPINDL/1000", "COOLNT/ON", "CUTCOM/OFF", "TRNTYP/1",
                           "INSERT/X", "PPRINT A", "OPSKIP/ON", "ORIGIN/0,0,0", "SEQNO/1", "TOOLNO/1"})
    cam += std::string(word) + "\n";
  cam += "GOTO/0,0,0\nCSYS/1,0,0,5,0,1,0,0,0,0,1,0\nGOTO/1,1,1\nFINI\n";
  const std::string cam_file = cli.write("cam.cl", cam);
  const test::CliResult c = cli.run({"toolpath", cam_file});
  EXPECT_EQ(c.code, 0);
  EXPECT_THAT(c.err, ::testing::StartsWith("warning: " + cam_file + ":15: APT statement 'CSYS' with a transformation"));
  EXPECT_THAT(c.err, HasSubstr("\nnote: " + cam_file + ": skipped 11 statements that carry no tool-path geometry: SELECT "
                               "(line 3)"));
  EXPECT_EQ(std::count(c.err.begin(), c.err.end(), '\n'), 2);
  EXPECT_THAT(c.out, HasSubstr(" poses (0 rapid)\nWARNING: " + cam_file + ":15: APT statement 'CSYS'"));
  const test::CliResult cj = cli.run({"toolpath", cam_file, "--json"});
  EXPECT_THAT(cj.out, HasSubstr("\"statement\": \"TOOLNO\""));

  const std::string good = cli.write("good.csv", "1,2,3\n4,6,3\n");
  const test::CliResult ok = cli.run({"toolpath", good, "--json"});
  EXPECT_EQ(ok.code, 0);
  EXPECT_THAT(ok.out, HasSubstr("\"poses\": 2"));
  EXPECT_THAT(ok.out, HasSubstr("\"max_step_mm\": 5.0"));
}

}  // namespace
}  // namespace machplan
