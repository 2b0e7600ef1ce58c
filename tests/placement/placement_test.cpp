// Contracts of the HexaM model and the placement checker.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/datasets.h"
#include "engine/interference/collision.h"
#include "engine/interference/height_field.h"
#include "engine/programs/mesh.h"
#include "models/hexam/hexam.h"
#include "solvers/placement/check/checker.h"
#include "solvers/placement/scene/scene.h"
#include "solvers/placement/search/search.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {


hexam::Machine paper_machine() {
  hexam::Machine m = hexam::load_machine(test::kHexamPaper + "machine.yaml");
  hexam::attach_tooling(m, hexam::Tooling{});
  return m;
}

TEST(Hexam, InverseThenForwardKinematicsRecoversThePlatePose) {
  const hexam::Machine m = paper_machine();
  for (const auto& [tip, axis] : std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>{
           {{0, 0, 250}, {0, 0, 1}}, {{80, -40, 180}, Eigen::Vector3d(0.3, 0.1, 1).normalized()},
           {{-120, 60, 220}, Eigen::Vector3d(-0.2, 0.35, 1).normalized()}}) {
    const hexam::IkResult ik = hexam::inverse_kinematics(m, tip, axis);
    ASSERT_TRUE(ik.reachable);
    for (int i = 0; i < 6; ++i)  // every strut closes at its length
      EXPECT_NEAR((ik.struts[i].slider_mm - ik.struts[i].plate_mm).norm(), m.struts[i].length_mm, 1e-9);
    std::array<double, 6> s;
    for (int i = 0; i < 6; ++i) s[i] = ik.struts[i].s_mm;
    const hexam::PlatePose guess{Eigen::Matrix3d::Identity(), ik.plate_centre_mm + Eigen::Vector3d(5, -4, 3)};
    const auto fk = hexam::forward_kinematics(m, s, guess);
    ASSERT_TRUE(fk.has_value());
    EXPECT_LT((fk->centre_mm - ik.plate_centre_mm).norm(), 1e-6);
    EXPECT_LT((fk->R - ik.R).norm(), 1e-8);
  }
}

TEST(Hexam, FarPosesAreOutOfReachWithADeficit) {
  const hexam::Machine m = paper_machine();
  const auto ik = hexam::inverse_kinematics(m, {2000, 0, 100}, {0, 0, 1});
  EXPECT_FALSE(ik.reachable);
  EXPECT_GT(ik.reach_deficit_mm, 0.0);
}

TEST(Hexam, SliderSpeedBoundHoldsForSmallMoves) {
  // kappa bounds |ds| / |dP| while the slider joints stay in their cones.
  const hexam::Machine m = paper_machine();
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.1, 1).normalized();
  const auto a = hexam::inverse_kinematics(m, {30, 20, 200}, axis);
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, 1),
                                  Eigen::Vector3d(0.6, -0.8, 0)}) {
    const auto b = hexam::inverse_kinematics(m, Eigen::Vector3d(30, 20, 200) + d, axis);
    for (int i = 0; i < 6; ++i) EXPECT_LE(std::abs(b.struts[i].s_mm - a.struts[i].s_mm), m.kappa * d.norm() + 1e-9);
  }
}

TEST(Hexam, BadMachineFileNamesTheKey) {
  const auto dir = std::filesystem::temp_directory_path() / "machplan_hexam_test";
  std::filesystem::create_directories(dir);
  std::ifstream in(test::kHexamPaper + "machine.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text.replace(text.find("strut_length_mm: 1100"), 21, "strut_length_mm: -5");
  std::ofstream(dir / "machine.yaml") << text;
  try {
    hexam::load_machine((dir / "machine.yaml").string());
    FAIL() << "a negative strut length was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("layout.strut_length_mm"), std::string::npos) << e.what();
    EXPECT_GT(e.line(), 0);
  }
}

TEST(Interference, SegmentDistanceMatchesFclCapsules) {
  using interference::Shape;
  const Eigen::Vector3d a0(0, 0, 0), a1(0, 0, 100), b0(30, -50, 40), b1(30, 50, 70);
  const double closed = interference::segment_distance(a0, a1, b0, b1);
  EXPECT_NEAR(closed, 30.0, 1e-9);
  const auto p = interference::distance(Shape::capsule(5, 100), interference::segment_pose(a0, a1), Shape::capsule(5, (b1 - b0).norm()),
                                        interference::segment_pose(b0, b1));
  EXPECT_NEAR(p.distance_mm, closed - 10.0, 1e-4);
}

TEST(Interference, HeightFieldNeverUnderestimates) {
  const Mesh box = make_box_mesh({-50, -30, 0}, {50, 30, 40});
  const interference::HeightField hf(box.vertices, box.triangles, 2.0, Eigen::AlignedBox2d(Eigen::Vector2d(-60, -30), Eigen::Vector2d(50, 30)), 0.0);
  EXPECT_GE(hf.max_height({-10, -10}, {10, 10}), 40.0);
  EXPECT_GE(hf.max_height({-59, 0}, {-58, 1}), 0.0);  // the floor rectangle (pad) counts
  EXPECT_EQ(hf.max_height({200, 200}, {210, 210}), -std::numeric_limits<double>::infinity());
}

// A small scene from the bundled machine and workpiece with a short stretch of the path.
placement::Scene small_scene(int rows) {
  const auto dir = std::filesystem::temp_directory_path() / ("machplan_place_test_" + std::to_string(rows));
  std::filesystem::create_directories(dir);
  std::ifstream in(test::kHexamPaper + "toolpath.csv");
  std::ofstream out(dir / "toolpath.csv");
  std::string line;
  for (int i = 0; i <= rows * 351 && std::getline(in, line); ++i) out << line << '\n';
  out.close();
  std::ifstream sc(test::kHexamPaper + "scene.yaml");
  std::string text((std::istreambuf_iterator<char>(sc)), std::istreambuf_iterator<char>());
  for (const char* f : {"machine.yaml", "workpiece.stl"}) {
    const auto pos = text.find(f);
    text.replace(pos, std::string(f).size(), test::kHexamPaper + f);
  }
  std::ofstream(dir / "scene.yaml") << text;
  return placement::load_scene((dir / "scene.yaml").string());
}

TEST(Checker, CertifiedReportAgreesWithDenseRecheck) {
  const placement::Scene scene = small_scene(3);
  placement::Checker checker(scene);
  Termination term;
  for (const placement::Placement p : {placement::Placement{0, 0, 0, 0}, placement::Placement{-40, -40, 70, 0},
                                       placement::Placement{120, 120, 0, 0}, placement::Placement{-40, -40, 70, 33}}) {
    const auto fast = checker.report(p, term);
    const auto dense = checker.dense_check(p, 0.5, term);
    for (int k = 0; k < placement::kKindCount; ++k)
      EXPECT_EQ(fast.kinds[k].interferes, dense.kinds[k].interferes)
          << placement::kind_name(static_cast<placement::Kind>(k)) << " at " << p.x_mm << "," << p.y_mm << "," << p.pad_mm;
  }
}

TEST(Checker, WorkpieceOnTheMagazineIsFlaggedWithItsEvasion) {
  const placement::Scene scene = small_scene(1);
  placement::Checker checker(scene);
  Termination term;
  placement::Finding w;
  const placement::Placement on_magazine{220, 220, 0, 0};
  EXPECT_EQ(checker.decide(on_magazine, {}, term, &w), placement::Decision::infeasible);
  EXPECT_TRUE(w.interferes);
  // The magazine sits on the first-quadrant diagonal: evasion points back towards the third.
  EXPECT_LT(w.evasion.x(), 0.0);
  EXPECT_LT(w.evasion.y(), 0.0);
  const auto r = checker.report(on_magazine, term);
  EXPECT_FALSE(r.free());
  EXPECT_TRUE(r.kinds[static_cast<int>(placement::Kind::workpiece_peripheral)].interferes);
}

TEST(Checker, ABoxProvenFreeIsFreeAtItsCorners) {
  // Lifted over the centre the bundled machine clears this stretch by tens of millimetres, so a
  // 4 mm box must be provable, and then every corner must pass the brute-force re-check.
  const placement::Scene scene = small_scene(2);
  placement::Checker checker(scene);
  Termination term;
  const placement::Placement centre{0, 0, 60, 0};
  ASSERT_EQ(checker.decide(centre, {4.0}, term), placement::Decision::feasible);
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(2.3, 2.3, 2.3), Eigen::Vector3d(-2.3, 2.3, -2.3), Eigen::Vector3d(0, 0, -4)})
    EXPECT_TRUE(checker.dense_check({centre.x_mm + d.x(), centre.y_mm + d.y(), centre.pad_mm + d.z(), 0}, 0.5, term).free());
  // And turned: a quarter of a degree either way. Class 1 over a turn is known only when
  // the plate hinges' ring is clear at every rotation; then the ball must be provable, and free
  // at its ends.
  const placement::Decision turned = checker.decide(centre, {0.0, 0.25}, term);
  if (!checker.class1_clear_every_rotation(term)) {
    EXPECT_EQ(turned, placement::Decision::unknown);
  } else {
    ASSERT_EQ(turned, placement::Decision::feasible);
    for (const double turn : {-0.25, 0.25})
      EXPECT_TRUE(checker.dense_check({centre.x_mm, centre.y_mm, centre.pad_mm, turn}, 0.5, term).free()) << turn;
  }
}

TEST(Checker, ScreensAndProbesNeverCondemnAFreePlacement) {
  // Learn interferences by deciding a few placements (as the search does), then screen and
  // probe balls around free and interfering placements, turned and not: a ball called
  // infeasible must have no free point (checked at its centre and corners by the brute-force
  // re-check).
  const placement::Scene scene = small_scene(2);
  placement::Checker checker(scene);
  Termination term;
  std::vector<placement::Spot> known;
  for (const placement::Placement p : {placement::Placement{0, 0, 0, 0}, placement::Placement{-150, 150, 0, 0},
                                       placement::Placement{200, -200, 0, 0}, placement::Placement{220, 220, 0, 0}}) {
    placement::Spot spot;
    if (checker.decide(p, {}, term, nullptr, &spot) == placement::Decision::infeasible && spot.exact) known.push_back(spot);
  }
  ASSERT_GT(known.size(), 0u);
  int condemned = 0;
  for (double x : {-200.0, -60.0, 0.0, 60.0, 200.0})
    for (double pad : {0.0, 40.0, 80.0})
      for (double half : {2.0, 10.0, 40.0})
        for (double turn : {0.0, 3.0}) {
          const placement::Placement c{x, -x / 2, pad + half, 0};
          const placement::Ball ball{half * std::sqrt(3.0), turn, half};
          bool screened = false;
          for (const auto& s : known) screened = screened || checker.screen_spot(s, c, ball, term) == placement::Decision::infeasible;
          placement::Spot found;
          const bool probed = !screened && checker.probe(c, ball, term, &found) == placement::Decision::infeasible;
          if (!screened && !probed) continue;
          ++condemned;
          for (const Eigen::Vector4d& d : {Eigen::Vector4d(0, 0, 0, 0), Eigen::Vector4d(half, half, half, turn),
                                           Eigen::Vector4d(-half, -half, -half, -turn), Eigen::Vector4d(half, -half, -half, turn)})
            EXPECT_FALSE(checker.dense_check({c.x_mm + d.x(), c.y_mm + d.y(), c.pad_mm + d.z(), d.w()}, 0.5, term).free())
                << "box at " << c.x_mm << "," << c.y_mm << "," << c.pad_mm << " half " << half << " turn " << turn
                << (screened ? " (screen)" : " (probe)");
        }
  EXPECT_GT(condemned, 5);  // the test must exercise both
}

TEST(Checker, AnOverlapWithTheMagazineReportsHowDeepAndCondemnsANeighbourhood) {
  // Distances stop at 0 where solids overlap; the checker carries them below 0 by (at least)
  // the depth of the overlap, so that one deep overlap condemns a whole ball of placements.
  const placement::Scene scene = small_scene(1);
  placement::Checker checker(scene);
  Termination term;
  // Towards the magazine along the diagonal, at a few heights: the deepest overlap.
  placement::Placement p;
  placement::Finding f;
  f.clearance_mm = 1e9;
  for (double pad : {0.0, 60.0, 120.0})
    for (double x = 100; x <= 400; x += 50) {
      const auto g = checker.report({x, x, pad, 0}, term).kinds[static_cast<int>(placement::Kind::machine_peripheral)];
      if (g.clearance_mm < f.clearance_mm) f = g, p = {x, x, pad, 0};
    }
  ASSERT_TRUE(f.interferes);
  ASSERT_LT(f.clearance_mm, -3.0) << f.what;
  // The brute-force re-check looks at more poses: the same depth or a deeper one.
  const auto dense = checker.dense_check(p, 0.5, term);
  EXPECT_LE(dense.kinds[static_cast<int>(placement::Kind::machine_peripheral)].clearance_mm, f.clearance_mm + 0.25);
  // A ball a third as wide as the depth is condemned as a whole, and its corners interfere.
  const double radius = -f.clearance_mm / 3;
  placement::Finding w;
  ASSERT_EQ(checker.decide(p, {radius}, term, &w), placement::Decision::infeasible);
  const double h = radius / std::sqrt(3.0);
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(h, h, h), Eigen::Vector3d(-h, h, -h), Eigen::Vector3d(h, -h, -h)})
    EXPECT_FALSE(checker.dense_check({p.x_mm + d.x(), p.y_mm + d.y(), p.pad_mm + d.z(), 0}, 0.5, term).free());
}

// `machplan place` on a scene that cannot be machined: exit code 3 and the reason, quickly.
void expect_cannot_be_machined(const std::string& workpiece, const std::string& toolpath, const std::string& reason) {
  test::TempDir dir;
  const std::string tooling =
      "tooling: {tool_diameter_mm: 10, stick_out_mm: 50, flute_length_mm: 20, chuck_diameter_mm: 60, chuck_length_mm: 45}\n";
  const std::string scene =
      dir.write("scene.yaml", fmt::format("machine: {}machine.yaml\n{}workpiece: {}\ntoolpath: path.csv\nsearch: {{pad_max_mm: 60}}\n",
                                          test::kHexamPaper, tooling, workpiece));
  dir.write("path.csv", "x,y,z,i,j,k\n" + toolpath);
  const test::CliResult r = test::Cli().run({"place", scene});
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("cannot be machined on this machine"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(reason), std::string::npos) << r.err;
}

TEST(Place, AWorkpieceLargerThanTheTableCannotBeMachined) {
  expect_cannot_be_machined("{box: {size: [1000, 1000, 100]}}", "0,0,100,0,0,1\n", "does not fit on the table");
}

TEST(Place, APathOutOfReachEverywhereCannotBeMachined) {
  // 900 mm above the table: beyond every slider's stroke wherever the workpiece goes.
  expect_cannot_be_machined("{box: {size: [100, 100, 50]}}", "0,0,50,0,0,1\n0,0,900,0,0,1\n", "no placement");
}

}  // namespace
}  // namespace machplan
