// A CAM job with several tools is checked move by move with the tool that makes it (the CL file's
// LOAD/TOOL and CUTTER, the scene's holder and per-tool entries), tool changes included: what a
// scene declaring one tooling for every move gets wrong both ways, and the bad input refused.
#include "solvers/placement/check/checker.h"
#include "solvers/placement/search/search.h"
#include "solvers/placement/scene/scene.h"
#include "tests/support/datasets.h"

#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace tools_test {

using ::testing::HasSubstr;
using test::error_of;
using test::TempDir;

// A 100 x 60 x 20 mm block (its frame: the centre of its bottom face). T1, a 6 mm drill, drills
// 5 mm deep at (-40, 10) beside a tall clamp; T2, a 20 mm drill, 10 mm deep at (20, 0), far
// from it; T3, a
// slender 6 mm tool with 10 mm of flutes, plunges 20 mm deep at (30, -15).
const char* const kJob =
    "PARTNO three tools\n"
    "CUTTER/6,0\n"        // 2
    "LOAD/TOOL,1\n"       // 3
    "GOTO/-40,10,40\n"    // 4
    "GOTO/-40,10,15\n"    // 5
    "GOTO/-40,10,40\n"    // 6
    "CUTTER/20,0\n"       // 7
    "LOAD/TOOL,2\n"       // 8
    "GOTO/20,0,40\n"      // 9
    "GOTO/20,0,5\n"       // 10
    "GOTO/20,0,40\n"      // 11
    "FINI\n";

const char* const kSlender =
    "CUTTER/16,0\nLOAD/TOOL,1\nGOTO/-20,0,40\nGOTO/-20,0,18\nGOTO/-20,0,40\n"  // 1-5: a 2 mm face
    "CUTTER/6,0\nLOAD/TOOL,3\nGOTO/30,-15,40\nGOTO/30,-15,0\nGOTO/30,-15,40\n"  // 6-10: 20 mm deep
    "FINI\n";

// The same moves with the tools' statements taken out: what a one-tooling scene reads.
std::string without_tools(std::string text) {
  std::string out, line;
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t end = text.find('\n', start);
    line = text.substr(start, end - start);
    start = end + 1;
    out += line.rfind("CUTTER", 0) == 0 || line.rfind("LOAD", 0) == 0 ? "$$ removed\n" : line + "\n";
  }
  return out;
}

// The clamp: a 30 x 20 x 140 mm block on the table beside the block's +y edge (6 mm away with
// the block on a 60 mm pad at the table centre).
std::string scene_text(const std::string& machine, const std::string& toolpath, const std::string& tooling) {
  return fmt::format(
      "machine: {}\n"
      "safe_distance_mm: 5\n"
      "{}\n"
      "workpiece: {{box: {{size: [100, 60, 20]}}}}\n"
      "toolpath: {}\n"
      "peripherals:\n"
      "  - {{name: clamp, box: {{center: [-40, 46, 70], size: [30, 20, 140]}}}}\n",
      machine, tooling, toolpath);
}

// A function, not a constant: test::kHexamPaper may be initialised after this file's globals.
std::string hexam_machine() { return test::kHexamPaper + "machine.yaml"; }
const std::string kHolders =
    "holder: {length_mm: 60, stick_out_mm: 30}\n"
    "tools: {1: {chuck_diameter_mm: 20}, 2: {chuck_diameter_mm: 63, flute_length_mm: 25}}";
const std::string kSlenderHolders =
    "holder: {length_mm: 60, stick_out_mm: 30}\n"
    "tools: {1: {chuck_diameter_mm: 63, flute_length_mm: 25}, 3: {chuck_diameter_mm: 20, stick_out_mm: 80, "
    "flute_length_mm: 10}}";
// What one must declare for every move without the CL file's tools: the largest.
const std::string kLargest =
    "tooling: {tool_diameter_mm: 20, corner_radius_mm: 0, stick_out_mm: 50, flute_length_mm: 40, chuck_diameter_mm: 63, "
    "chuck_length_mm: 60}";

CheckReport check_at(const TempDir& dir, const std::string& job, const std::string& tooling, const Placement& p) {
  dir.write("job.cl", job);
  const std::string scene_file = dir.write("scene.yaml", scene_text(hexam_machine(), "job.cl", tooling));
  const Scene scene = load_scene(scene_file);
  Termination term;
  Checker checker(scene);
  return checker.report(p, term);
}

const Finding& of(const CheckReport& r, Kind k) { return r.kinds[static_cast<int>(k)]; }

TEST(Tools, TheSmallToolPassesAClampTheLargestWouldHit) {
  TempDir dir;
  const Placement p{0, 0, 60, 0};
  const CheckReport each = check_at(dir, kJob, kHolders, p);
  EXPECT_TRUE(each.free()) << of(each, Kind::machine_peripheral).what;
  EXPECT_GE(of(each, Kind::machine_peripheral).clearance_mm, 5.0);
  ASSERT_EQ(each.tools.size(), 2u);
  EXPECT_EQ(each.tools[0].tool, "T1");
  EXPECT_EQ(each.tools[0].poses, 3);
  EXPECT_EQ(each.tools[1].tool, "T2");
  // T1's 20 mm holder passes the clamp 26 mm from its axis with 16 mm to spare; the tightest of
  // T1's moves is its flutes' 15 mm above the pad.
  EXPECT_NEAR(each.tools[0].tightest.clearance_mm, 15.0, 0.3) << each.tools[0].tightest.what;

  const CheckReport one = check_at(dir, without_tools(kJob), kLargest, p);
  const Finding& hit = of(one, Kind::machine_peripheral);
  EXPECT_TRUE(hit.interferes);
  EXPECT_THAT(hit.what, HasSubstr("clamp"));
  EXPECT_GE(hit.line, 4);
  EXPECT_LE(hit.line, 6) << "the hit is on T1's moves";
  EXPECT_TRUE(one.tools.size() <= 1);
}

TEST(Tools, ALongToolsShankHitsWhatOneToolingMissed) {
  TempDir dir;
  const Placement p{0, 0, 60, 0};
  const CheckReport each = check_at(dir, kSlender, kSlenderHolders, p);
  const Finding& c1 = of(each, Kind::workpiece_class1);
  EXPECT_TRUE(c1.interferes);
  EXPECT_THAT(c1.what, HasSubstr("(T3)"));
  EXPECT_GE(c1.line, 8);
  EXPECT_LE(c1.line, 10);
  // Read as the largest tool's flutes (40 mm long), the plunge is all cutting.
  const CheckReport one = check_at(dir, without_tools(kSlender), kLargest, p);
  EXPECT_FALSE(of(one, Kind::workpiece_class1).interferes) << of(one, Kind::workpiece_class1).what;
}

// The bundled HexaM with its tool change position moved to `nose` (none when empty).
std::string machine_with_change(const TempDir& dir, const std::string& nose) {
  std::ifstream in(hexam_machine());
  std::string text, line;
  while (std::getline(in, line))
    if (line.rfind("tool_change:", 0) != 0) text += line + "\n";
  if (!nose.empty()) text += "tool_change: {nose_mm: " + nose + "}\n";
  return dir.write("machine.yaml", text);
}

TEST(Tools, ToolChangeMovesAreChecked) {
  TempDir dir;
  dir.write("job.cl", kJob);
  const std::string wall = "  - {name: wall, box: {center: [-150, 0, 240], size: [20, 300, 180]}}\n";
  const Placement p{0, 0, 60, 0};
  auto report = [&](const std::string& machine) {
    const Scene scene = load_scene(dir.write("scene.yaml", scene_text(machine, "job.cl", kHolders) + wall));
    Termination term;
    Checker checker(scene);
    return checker.report(p, term);
  };
  // The path alone stays clear of the wall ...
  const CheckReport alone = report(machine_with_change(dir, ""));
  EXPECT_TRUE(alone.free()) << of(alone, Kind::machine_peripheral).what;
  // ... but the way to the change position at (-250, 0, 300) and back crosses it.
  const CheckReport changed = report(machine_with_change(dir, "[-250, 0, 300]"));
  const Finding& hit = of(changed, Kind::machine_peripheral);
  EXPECT_TRUE(hit.interferes);
  EXPECT_THAT(hit.what, HasSubstr("/ wall (T"));
  EXPECT_THAT(hit.what, HasSubstr("tool change"));
  EXPECT_EQ(hit.line, 9) << "named at the first move after the change";
  // With the change position on the work's side of the wall the job is free again.
  EXPECT_TRUE(report(machine_with_change(dir, "[0, -150, 300]")).free());
}

// The bundled four-tool job on the trunnion, tool changes included: placed and certified, and
// the brute-force re-check agrees at the answer.
TEST(Tools, TheBundledFourToolJobIsPlacedAndCertified) {
  const Scene scene = load_scene(test::kDatasets + "multi-tool/scene.yaml");
  ASSERT_EQ(scene.tools.size(), 4u);
  ASSERT_EQ(scene.runs.size(), 4u);
  ASSERT_TRUE(scene.tool_change);
  EXPECT_DOUBLE_EQ(scene.tools[1].tooling.chuck_diameter_mm, 24.0) << "the scene's entry for T2";
  EXPECT_DOUBLE_EQ(scene.tools[1].tooling.flute_length_mm, 15.0) << "the file's CSI_SET_FLUTE_LENGTH";
  EXPECT_DOUBLE_EQ(scene.tools[3].tooling.stick_out_mm, 80.0) << "the file's CSI_SET_EXTENSION_LENGTH";
  Termination term;
  const PlacementResult r = place(scene, PlacementOptions{}, term);
  ASSERT_TRUE(r.summary.done()) << r.summary.message;
  EXPECT_TRUE(r.verified);
  ASSERT_EQ(r.report.tools.size(), 4u);
  for (const ToolClearance& t : r.report.tools) EXPECT_GE(t.tightest.clearance_mm, scene.safe_distance_mm) << t.tool;
  Termination dense_term;
  const CheckResult dense = check(scene, r.placement, {.dense = true, .dense_step_mm = 1.0}, dense_term);
  ASSERT_TRUE(dense.summary.done());
  EXPECT_TRUE(dense.report.free()) << of(dense.report, Kind::self).what;
}

// What `check --json` says of the tools: the scene's tools and changes, each tool's tightest.
TEST(Tools, TheJsonNamesEachToolItsTightestClearanceAndTheChanges) {
  TempDir dir;
  dir.write("job.cl", kJob);
  const std::string scene = dir.write("scene.yaml", scene_text(hexam_machine(), "job.cl", kHolders));
  const test::Cli cli;
  const test::CliResult r = cli.run(fmt::format("check '{}' --at 0,0,60 --json", scene));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["scene"]["tools"].size(), 2u);
  EXPECT_EQ(j["scene"]["tools"][1]["name"], "T2");
  EXPECT_EQ(j["scene"]["tools"][1]["holder_diameter_mm"], 63.0);
  ASSERT_EQ(j["scene"]["tool_changes"].size(), 1u);
  EXPECT_EQ(j["scene"]["tool_changes"][0]["to"], "T2");
  EXPECT_EQ(j["scene"]["tool_changes"][0]["line"], 8 + 1);
  ASSERT_EQ(j["tools"].size(), 2u);
  EXPECT_EQ(j["tools"][0]["tool"], "T1");
  EXPECT_EQ(j["tools"][0]["poses"], 3);
  EXPECT_GE(j["tools"][0]["tightest"]["clearance_mm"].get<double>(), 5.0);
}

// A G-code job names its tools by M6; a LinuxCNC tool table gives their diameters and lengths.
TEST(Tools, AGcodeJobTakesItsToolsFromTheToolTable) {
  TempDir dir;
  dir.write("job.ngc",
            "G21 G90 G17\nT1 M6\nG0 X-40 Y10 Z40\nG1 Z25 F200\nG0 Z40\n"        // 1-5
            "T2 M6\nG0 X20 Y0 Z40\nG1 Z25 F300\nG2 X30 Y0 I5 J0 F600\nG0 Z40\nM2\n");  // 6-11
  dir.write("tool.tbl", "; the tools\nT1 P1 D6.0 Z+95.0 ;6 mm drill\nT2 P2 D10.0 Z+110.0\n");
  const std::string scene_file = dir.write(
      "scene.yaml", scene_text(hexam_machine(), "job.ngc", "holder: {diameter_mm: 40, length_mm: 60}\ntool_table: tool.tbl"));
  const Scene scene = load_scene(scene_file);
  ASSERT_EQ(scene.tools.size(), 2u);
  EXPECT_EQ(scene.tools[0].name, "T1");
  EXPECT_DOUBLE_EQ(scene.tools[0].tooling.tool_diameter_mm, 6.0);
  EXPECT_DOUBLE_EQ(scene.tools[0].tooling.stick_out_mm, 35.0) << "95 mm from tip to spindle, less the 60 mm holder";
  EXPECT_DOUBLE_EQ(scene.tools[1].tooling.stick_out_mm, 50.0);
  ASSERT_EQ(scene.runs.size(), 2u);
  EXPECT_EQ(scene.lines[scene.runs[1].first], 7);
  // The half circle of line 9 as poses on its arc (5 mm about (25, 0)), the last at its end.
  const std::size_t end = scene.runs[1].end;
  EXPECT_GT(end - scene.runs[1].first, 10u);
  for (std::size_t i = scene.runs[1].first + 2; i + 1 < end; ++i)
    EXPECT_NEAR((scene.tips_mm[i] + scene.origin_in_cam_mm - Eigen::Vector3d(25, 0, 25)).head<2>().norm(), 5.0, 1e-9);

  auto refused = [&](const std::string& table) {
    dir.write("tool.tbl", table);
    return error_of([&] { load_scene(scene_file); });
  };
  EXPECT_THAT(refused("T1 P1 D6 Z95\nT2 P2 K4\n"), HasSubstr("tool.tbl:2: 'K' is not a tool table word"));
  EXPECT_THAT(refused("T1 P1 D6 Z95\nP2 D4\n"), HasSubstr("tool.tbl:2: a tool table line needs its T word"));
  EXPECT_THAT(refused("T1 P1 D6 Z95\nT2 D1e9\n"), HasSubstr("tool.tbl:2: D: '1e9' is not a number within +-1e6"));
  EXPECT_THAT(refused("T1 P1 D6 Z50\nT2 D10 Z110\n"), HasSubstr("T1: its length 50 mm (tool.tbl:1) does not reach past the 60 mm holder"));
  EXPECT_THAT(refused("T1 P1 D6 Z95\n"), HasSubstr("T2 (job.ngc:6) is loaded with nothing to say what it is"));
}

TEST(Tools, BadToolsAreRefusedNamingTheToolAndTheLine) {
  TempDir dir;
  auto error = [&](const std::string& job, const std::string& tooling, const std::string& machine = hexam_machine()) {
    dir.write("job.cl", job);
    const std::string f = dir.write("scene.yaml", scene_text(machine, "job.cl", tooling));
    return error_of([&] { load_scene(f); });
  };
  EXPECT_THAT(error("LOAD/TOOL,7\nGOTO/0,0,40\n", "holder: {diameter_mm: 50, length_mm: 60, stick_out_mm: 40}"),
              HasSubstr("T7 (job.cl:1) is loaded with nothing to say what it is (no CUTTER, no tool table entry): "
                        "describe it in the scene, tools: {7:"));
  EXPECT_THAT(error(kJob, "holder: {length_mm: 60, stick_out_mm: 30}"),
              HasSubstr("T1 (job.cl:3) has no holder diameter: give the scene's holder: {diameter_mm: ...}"));
  EXPECT_THAT(error(kJob, "holder: {diameter_mm: 50, length_mm: 60}"), HasSubstr("has no length out of the holder"));
  EXPECT_THAT(error(kJob, "holder: {diameter_mm: 50, length_mm: 60, stick_out_mm: 30}\ntools: {9: {stick_out_mm: 20}}"),
              HasSubstr("job.cl makes no move with a tool numbered '9' (its tools: T1, T2)"));
  EXPECT_THAT(error(kJob, kLargest), HasSubstr("is one tool for every move, but the tool path changes tools (T1, T2)"));
  EXPECT_THAT(error(kJob, "holder: {diameter_mm: 50, length_mm: 60, stick_out_mm: 30}\ntools: {1: {flute_length_mm: 31}}"),
              HasSubstr("T1 (job.cl:3): flutes 31 mm long but only 30 mm out of the holder"));
  // A tool longer than the trunnion's Z stroke can bring down to its table.
  EXPECT_THAT(error(kJob, "holder: {diameter_mm: 50, length_mm: 60, stick_out_mm: 600}", "trunnion_ac"),
              HasSubstr("T1 does not fit machine"));
  // A change position beyond the sliders' stroke.
  EXPECT_THAT(error(kJob, kHolders, machine_with_change(dir, "[600, 0, 450]")),
              HasSubstr("key 'tool_change.nose_mm' puts T1 (90 mm from its tip to the spindle nose) where 'slider stroke"));
}

}  // namespace tools_test
}  // namespace machplan::placement
