// CAM output as exported: a mesh and a tool path whose zero is on the top of the stock at a
// corner, moved into the workpiece frame together; tool tips below the bottom face reported;
// the pad under the part in the tool's way unless the scene declares a spoilboard.
#include <cmath>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <nlohmann/json.hpp>
#include <gtest/gtest.h>

#include "solvers/placement/search/search.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace {

using ::testing::HasSubstr;
using test::TempDir;

const std::string kMachine = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/hexam-paper/machine.yaml";

// An ASCII STL of the box [lo, hi], faces outwards.
std::string box_stl(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  auto v = [&](int k) { return Eigen::Vector3d(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z()); };
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  std::string out = "solid box\n";
  for (const auto& q : quads)
    for (const auto& t : {std::array<int, 3>{q[0], q[1], q[2]}, std::array<int, 3>{q[0], q[2], q[3]}}) {
      out += " facet normal 0 0 0\n  outer loop\n";
      for (int k : t) out += fmt::format("   vertex {} {} {}\n", v(k).x(), v(k).y(), v(k).z());
      out += "  endloop\n endfacet\n";
    }
  return out + "endsolid box\n";
}

// A 40 x 30 x 20 mm part with the CAM zero on its top face at the corner (x 0 .. 40, y 0 .. 30,
// z -20 .. 0), a facing pass over the top and a hole drilled through it 5 mm into what is below
// (the mesh is the stock: the drill's flutes, 30 mm long, are in it by design).
std::string write_job(const TempDir& dir, const std::string& workpiece_extra) {
  dir.write("part.stl", box_stl({0, 0, -20}, {40, 30, 0}));
  std::string path = "x,y,z\n";
  for (int k = 0; k <= 8; ++k) path += fmt::format("{},15,0\n", 5 * k);
  path += "20,15,10\n20,15,-12\n20,15,-25\n20,15,10\n";
  dir.write("path.csv", path);
  return dir.write("scene.yaml", fmt::format("machine: {}\n"
                                             "tooling: {{tool_diameter_mm: 6, corner_radius_mm: 0, stick_out_mm: 40, flute_length_mm: 30, "
                                             "chuck_diameter_mm: 40, chuck_length_mm: 45}}\n"
                                             "workpiece: {{mesh: part.stl{}}}\n"
                                             "toolpath: path.csv\n"
                                             "search: {{pad_max_mm: 150}}\n",
                                             kMachine, workpiece_extra));
}

TEST(SceneFrame, MeshAndToolPathMoveTogetherToTheBottomFaceCentre) {
  TempDir dir;
  const Scene s = load_scene(write_job(dir, ""));
  EXPECT_TRUE(s.origin_from_mesh);
  EXPECT_TRUE(s.origin_in_cam_mm.isApprox(Eigen::Vector3d(20, 15, -20)));
  EXPECT_NEAR(s.workpiece_bounds.min().z(), 0.0, 1e-9);
  EXPECT_NEAR(s.workpiece_bounds.max().z(), 20.0, 1e-9);
  EXPECT_NEAR(s.workpiece_bounds.center().x(), 0.0, 1e-9);
  EXPECT_NEAR(s.workpiece_bounds.center().y(), 0.0, 1e-9);
  // The facing pass now runs on top of the part, 20 mm up.
  EXPECT_TRUE(s.tips_mm.front().isApprox(Eigen::Vector3d(-20, 0, 20)));
  // The drill goes 5 mm below the bottom face: reported, with its line.
  EXPECT_EQ(s.below_bottom.poses, 1);
  EXPECT_NEAR(s.below_bottom.deepest_mm, 5.0, 1e-9);
  EXPECT_EQ(s.below_bottom.deepest_line, 13);
}

TEST(SceneFrame, TheOriginCanBeGivenInCamCoordinates) {
  TempDir dir;
  const Scene s = load_scene(write_job(dir, ", origin_in_cam_mm: [0, 0, -20]"));
  EXPECT_FALSE(s.origin_from_mesh);
  EXPECT_NEAR(s.workpiece_bounds.min().x(), 0.0, 1e-9);
  EXPECT_NEAR(s.workpiece_bounds.max().y(), 30.0, 1e-9);
  // An origin above the solid's lowest point is refused, naming the key.
  const std::string msg = test::error_of([&] { load_scene(write_job(dir, ", origin_in_cam_mm: [0, 0, -10]")); });
  EXPECT_THAT(msg, HasSubstr("origin_in_cam_mm"));
  EXPECT_THAT(msg, HasSubstr("10.000 mm above the solid's lowest point"));
}

// A profile pass beside the part, 5.5 mm below its bottom face: clear of the pad under the
// footprint, but on a pad under 10.5 mm the table comes within the safe distance of the tool,
// wherever the part goes. The thin pads are ruled out by the pad alone. (The screening once
// took the tool's clearance at the top of a box of pads for the whole box, and certified the
// same lowest placement again and again. Pads up to 40 mm keep that case, a box whose top is
// clear and whose bottom is not, at a fortieth of the run time of pads up to 150 mm.)
TEST(SceneFrame, PadsTooThinForAPassBelowThePartAreRuledOutEverywhere) {
  TempDir dir;
  dir.write("part.stl", box_stl({0, 0, -20}, {40, 30, 0}));
  std::string path = "x,y,z\n";
  for (int k = 0; k <= 8; ++k) path += fmt::format("{},15,0\n", 5 * k);
  path += "0,-9,10\n0,-9,-25.5\n40,-9,-25.5\n40,-9,10\n";  // 6 mm from the part's side
  dir.write("path.csv", path);
  const std::string file = dir.write(
      "scene.yaml", fmt::format("machine: {}\n"
                                "tooling: {{tool_diameter_mm: 6, corner_radius_mm: 0, stick_out_mm: 40, flute_length_mm: 30, "
                                "chuck_diameter_mm: 40, chuck_length_mm: 45}}\n"
                                "workpiece: {{mesh: part.stl}}\ntoolpath: path.csv\nsearch: {{pad_max_mm: 40}}\n",
                                kMachine));
  const Scene s = load_scene(file);
  Termination term;
  term.set_budget(5'000'000, "pose queries");  // ends a search that would not
  const PlacementResult r = place(s, PlacementOptions{}, term);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  EXPECT_TRUE(r.verified);
  EXPECT_EQ(r.placement.pad_mm, 11.0);
  EXPECT_NEAR(r.report.kinds[static_cast<int>(Kind::tool_support)].clearance_mm, 5.5, 0.25);
  // One pad less is refused, at the answer and at the table centre.
  CheckOptions exact;
  EXPECT_FALSE(check(s, {r.placement.x_mm, r.placement.y_mm, 10, 0}, exact, term).report.free());
  EXPECT_FALSE(check(s, {0, 0, 10, 0}, exact, term).report.free());
}

TEST(SceneFrame, ADrillThroughThePartNeedsASpoilboard) {
  TempDir dir;
  Termination term;
  // Without one the drill runs into the pad (or the table), wherever the part goes.
  const Scene plain = load_scene(write_job(dir, ""));
  const PlacementResult none = place(plain, PlacementOptions{}, term);
  EXPECT_EQ(none.summary.status, Status::infeasible) << none.summary.full_report();
  EXPECT_EQ(none.summary.status, Status::infeasible);
  EXPECT_TRUE(none.report.kinds[static_cast<int>(Kind::tool_support)].interferes);
  // A 12 mm spoilboard takes the 5 mm plunge with the 5 mm safe distance to spare.
  TempDir dir2;
  const Scene board = load_scene(write_job(dir2, ", spoilboard_mm: 12"));
  const PlacementResult r = place(board, PlacementOptions{}, term);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  EXPECT_TRUE(r.verified);
  EXPECT_GE(r.placement.pad_mm, 12.0);
  const Finding& support = r.report.kinds[static_cast<int>(Kind::tool_support)];
  EXPECT_FALSE(support.interferes);
  EXPECT_NEAR(support.clearance_mm, 7.0, 0.25);  // 12 - 5 below the bottom face
  // The brute-force re-check agrees.
  CheckOptions dense;
  dense.dense = true;
  EXPECT_TRUE(check(board, r.placement, dense, term).report.free());
  // The report gives the work offset of the CAM zero: the placement less the frame's move.
  EXPECT_NEAR(r.work_offset.xyz_mm.x(), r.placement.x_mm - 20, 1e-9);
  EXPECT_NEAR(r.work_offset.xyz_mm.y(), r.placement.y_mm - 15, 1e-9);
  EXPECT_NEAR(r.work_offset.xyz_mm.z(), r.placement.pad_mm + 20, 1e-9);
  EXPECT_THAT(r.summary.full_report(), HasSubstr("tool tips below the bottom face: 1 poses, deepest 5.000 mm"));
  EXPECT_THAT(r.summary.full_report(), HasSubstr("moved by (-20.000, -15.000, 20.000) mm"));
}

TEST(SceneFrame, TheJsonCarriesTheFrameAndTheWorkOffset) {
  TempDir dir;
  const std::string scene = write_job(dir, ", spoilboard_mm: 12");
  const test::Cli cli;
  const test::CliResult r = cli.run(fmt::format("place '{}' --json", scene));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["scene"]["workpiece_frame"]["moved_by_mm"], nlohmann::json::array({-20.0, -15.0, 20.0}));
  EXPECT_EQ(j["scene"]["below_bottom"]["poses"], 1);
  EXPECT_EQ(j["scene"]["spoilboard_mm"], 12.0);
  EXPECT_EQ(j["summary"]["status"], "done");
  EXPECT_NEAR(j["work_offset"]["x_mm"].get<double>(), j["placement"]["x_mm"].get<double>() - 20, 1e-9);
  EXPECT_TRUE(j["interference"].contains("tool_support"));
  // A check thinner than the spoilboard is refused, naming the flag.
  const test::CliResult thin = cli.run(fmt::format("check '{}' --at 0,0,5", scene));
  EXPECT_EQ(thin.code, 2);
  EXPECT_THAT(thin.err, HasSubstr("--at"));
}

}  // namespace
}  // namespace machplan::placement
