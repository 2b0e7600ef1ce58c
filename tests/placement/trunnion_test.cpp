// The table-tilting 5-axis machine: its inverse kinematics, the continuous choice between the two
// solutions (flips only where the limits force them), the travel objective's bounds, and the
// bundled scene's least-travel placement against the table centre.
#include <cmath>
#include <fstream>
#include <optional>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "models/trunnion/trunnion.h"
#include "solvers/placement/search/internal/planned_time.h"
#include "engine/common/internal/numbers.h"
#include "solvers/placement/search/internal/objective.h"
#include "solvers/placement/search/search.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using test::TempDir;

const std::string kMachine = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/trunnion_ac.yaml";
const std::string kScene = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/trunnion-5axis/scene.yaml";

Eigen::Vector3d tilted(double tilt_deg, double azimuth_deg) {
  const double t = tilt_deg * kDeg, a = azimuth_deg * kDeg;
  return {std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t)};
}

TEST(Trunnion, BothSolutionsTurnTheToolAxisOntoTheSpindle) {
  const trunnion::Machine m = trunnion::load_machine(kMachine);
  for (double tilt : {5.0, 20.0, 34.0, 50.0, 80.0})
    for (double az : {-170.0, -45.0, 0.0, 33.0, 90.0, 135.0}) {
      const Eigen::Vector3d axis = tilted(tilt, az);
      const auto sol = trunnion::solve_angles(m, axis);
      ASSERT_EQ(sol.size(), 2u) << tilt << " " << az;
      for (const auto& s : sol) {
        EXPECT_LT((trunnion::axis_at(m, s.a_rad, s.c_rad) - axis).norm(), 1e-9) << tilt << " " << az;
        EXPECT_NEAR(std::abs(s.a_rad), tilt * kDeg, 1e-9);  // A/C: the tilt is the A angle
      }
      // The two differ by the sign of the tilt and half a turn of the table.
      EXPECT_NEAR(sol[0].a_rad, -sol[1].a_rad, 1e-9);
      EXPECT_NEAR(std::abs(std::remainder(sol[0].c_rad - sol[1].c_rad, 2 * M_PI)), M_PI, 1e-9);
    }
  // Along the table's axis the table's angle is free: one solution, keeping the hint.
  const auto up = trunnion::solve_angles(m, Eigen::Vector3d::UnitZ(), 0.7);
  ASSERT_EQ(up.size(), 1u);
  EXPECT_NEAR(up[0].a_rad, 0.0, 1e-12);
  EXPECT_NEAR(up[0].c_rad, 0.7, 1e-12);
}

// A scene on the bundled trunnion (or one with a symmetric tilt axis) with a CSV tool path.
Scene swing_scene(const TempDir& dir, const std::string& path, bool symmetric) {
  std::ifstream in(kMachine);
  std::string machine((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (symmetric) machine.replace(machine.find("max_deg: 35"), 11, "max_deg: 120");
  const std::string mfile = dir.write("machine.yaml", machine);
  dir.write("path.csv", path);
  return load_scene(dir.write("scene.yaml", fmt::format("machine: {}\n"
                                                        "tooling: {{tool_diameter_mm: 6, stick_out_mm: 60, chuck_diameter_mm: 30, "
                                                        "chuck_length_mm: 60}}\n"
                                                        "workpiece: {{box: {{size: [60, 60, 20]}}}}\n"
                                                        "toolpath: path.csv\n",
                                                        mfile)));
}

TEST(Trunnion, TheTableTurnsContinuouslyAndFlipsOnlyWhereTheLimitsForceIt) {
  // The tool leans 40 deg towards +x, swings up through the vertical in the x-z plane, and
  // leans 40 deg towards -x. A tilt axis reaching +-120 deg passes through the vertical
  // changing the tilt's sign, with the table still; this machine's tilt axis stops at +35 deg,
  // so 40 deg either way needs the negative tilt and the table must turn half a turn: a flip,
  // forced.
  std::string path = "x,y,z,i,j,k\n";
  for (int k = -40; k <= 40; ++k) {
    const Eigen::Vector3d a = tilted(std::abs(k), k >= 0 ? 0.0 : 180.0);
    path += fmt::format("0,0,25,{},{},{}\n", a.x(), a.y(), a.z());
  }
  // Then the same lean turned all the way round at 40 deg: the table follows, no flip.
  for (int k = 0; k <= 72; ++k) {
    const Eigen::Vector3d a = tilted(40, 5.0 * k);
    path += fmt::format("0,0,25,{},{},{}\n", a.x(), a.y(), a.z());
  }
  TempDir dir, dir2;
  const auto forced = axis_travel(swing_scene(dir, path, false), {0, 0, 0, 0});
  ASSERT_TRUE(forced.has_value());
  EXPECT_EQ(forced->flips, 1);
  EXPECT_EQ(forced->forced_flips, 1);
  ASSERT_EQ(forced->flip_poses.size(), 1u);
  EXPECT_NEAR(forced->flip_poses[0], 40, 1);  // at the vertical
  const auto free = axis_travel(swing_scene(dir2, path, true), {0, 0, 0, 0});
  ASSERT_TRUE(free.has_value());
  EXPECT_EQ(free->flips, 0);
  // Without the flip the table turns a full turn (the second part) and no more.
  EXPECT_NEAR(free->travel[4], 360.0, 1.0);
  // A pose the tilt axis cannot reach is refused with its line.
  TempDir dir3;
  const std::string msg =
      test::error_of([&] { swing_scene(dir3, fmt::format("x,y,z,i,j,k\n0,0,25,{},0,{}\n", -std::sin(130 * kDeg), std::cos(130 * kDeg)), false); });
  EXPECT_THAT(msg, HasSubstr("path.csv:2"));
  EXPECT_THAT(msg, HasSubstr("outside its travel"));
}

// The bundled scene's path as the machine runs it, at rotation 0.
std::optional<AxisPath> bundled_axis_path() {
  const Scene scene = load_scene(kScene);
  std::vector<PathPose> poses(scene.tips_mm.size());
  for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = {scene.tips_mm[i], scene.axes[i]};
  if (scene.model->prepare(poses)) return std::nullopt;
  return scene.model->axis_path(poses, scene.feeds_mm_per_min, 0.0);
}

TEST(Trunnion, TheObjectivesBoundsNeverExceedTheirValues) {
  const auto path = bundled_axis_path();
  ASSERT_TRUE(path.has_value());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const auto kind : {AxisObjective::Kind::travel, AxisObjective::Kind::time}) {
    const AxisObjective f(*path, kind);
    for (int k = 0; k < 40; ++k) {
      const Eigen::Vector3d c(60 * u(rng), 60 * u(rng), 40 + 40 * u(rng));
      const Eigen::Vector3d h(20 * std::abs(u(rng)), 20 * std::abs(u(rng)), 20 * std::abs(u(rng)));
      const double lb = f.lower_bound(c, h);
      for (int j = 0; j < 8; ++j) {
        const Eigen::Vector3d x = c + h.cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
        EXPECT_LE(lb, f.value(x) + 1e-9);
      }
      EXPECT_LE(lb, f.value(c) + 1e-9);
    }
  }
}

TEST(Trunnion, TheBundledSceneSavesAxisTravelAgainstTheTableCentreWithoutFlips) {
  const Scene scene = load_scene(kScene);
  Termination term;
  const PlacementResult r = place(scene, PlacementOptions{}, term);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  EXPECT_EQ(r.objective, PlacementOptions::Objective::travel);
  EXPECT_TRUE(r.verified);
  ASSERT_TRUE(r.travel && r.centre_travel);
  // The published setup search saved 16.8 % of the axis travel; this scene's dome, off the part's
  // centre, gives more when it is brought onto the rotary axes.
  EXPECT_GT(1.0 - r.travel->linear_mm / r.centre_travel->linear_mm, 0.168);
  EXPECT_EQ(r.travel->flips, 0);
  // Never worse than the table centre, which is itself free here.
  CheckOptions dense;
  dense.dense = true;
  EXPECT_TRUE(check(scene, {0, 0, 0, 0}, CheckOptions{}, term).report.free());
  // The answer survives the brute-force re-check.
  EXPECT_TRUE(check(scene, r.placement, dense, term).report.free());
  // The work offset is where the CAM zero lies with the rotary axes at zero.
  const trunnion::Machine m = trunnion::load_machine(kMachine);
  const Eigen::Vector3d zero_table = r.placement.offset() - scene.origin_in_cam_mm;  // rotation 0
  EXPECT_LT((r.work_offset.xyz_mm - m.axes_for_nose(m.table_pose(0, 0) * zero_table)).norm(), 1e-9);
  EXPECT_THAT(r.summary.full_report(), HasSubstr("% less"));
  // A rotary axis that turns more than once reads in turns ("C 33.2 turns"), not in thousands of
  // degrees; a rotary axis within one turn stays in degrees.
  for (std::size_t k = 3; k < r.travel->axes.size(); ++k) {
    const double deg = r.travel->travel[k];
    const std::string expected = deg > 360.0 ? fmt::format("{} {:.1f} turns", r.travel->axes[k], deg / 360.0)
                                             : fmt::format("{} {:.1f} deg", r.travel->axes[k], deg);
    EXPECT_THAT(r.summary.full_report(), HasSubstr(expected));
  }
  // Timed by the feed planner (the machine gives accelerations and jerks): never faster than at
  // the speed limits alone, and both times are reported.
  ASSERT_TRUE(r.travel->planned && r.centre_travel->planned);
  EXPECT_GE(r.travel->time_s, r.travel->velocity_only_time_s);
  EXPECT_GE(r.centre_travel->time_s, r.centre_travel->velocity_only_time_s);
  EXPECT_THAT(r.summary.full_report(), HasSubstr("machining time by the feed planner"));
}

TEST(Trunnion, ThePlannedTimesBoundNeverExceedsThePlannedTime) {
  const auto path = bundled_axis_path();
  ASSERT_TRUE(path.has_value());
  const PlannedTime planned(*path);
  const AxisObjective speeds(*path, AxisObjective::Kind::time);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector3d c(60 * u(rng), 60 * u(rng), 40 + 40 * u(rng));
    const Eigen::Vector3d h(20 * std::abs(u(rng)), 20 * std::abs(u(rng)), 20 * std::abs(u(rng)));
    const double lb = planned.lower_bound(c, h);
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d o = c + Eigen::Vector3d(h.x() * u(rng), h.y() * u(rng), h.z() * u(rng));
      const double t = planned.planned_s(o);
      EXPECT_LE(lb, t + 1e-9);
      // At a point the bound lies between the velocity-only time and the planned one.
      EXPECT_LE(speeds.value(o), planned.lower_bound(o, Eigen::Vector3d::Zero()) + 1e-9);
      EXPECT_LE(planned.lower_bound(o, Eigen::Vector3d::Zero()), t + 1e-9);
    }
  }
}

TEST(Trunnion, AccelerationsAndJerksAreCheckedAndTheTimeObjectiveNeedsThem) {
  std::ifstream in(kMachine);
  const std::string machine((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto edited = [&](const std::string& from, const std::string& to) {
    std::string m = machine;
    const std::size_t at = m.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return m.replace(at, from.size(), to);
  };
  const auto error_in = [](const std::string& text) {
    TempDir dir;
    const std::string file = dir.write("machine.yaml", text);
    return test::error_of([&] { trunnion::load_machine(file); });
  };
  // A bad value names the file and line.
  EXPECT_THAT(error_in(edited("accel_mm_per_s2: 3000", "accel_mm_per_s2: -3")), HasSubstr("machine.yaml:25"));
  EXPECT_THAT(error_in(edited("jerk_deg_per_s3: 6000", "jerk_deg_per_s3: 0")), HasSubstr("machine.yaml:"));
  EXPECT_THAT(error_in(edited("accel_deg_per_s2: 1200", "accel_deg_per_s2: .nan")), HasSubstr("accel_deg_per_s2"));
  // One without the other.
  EXPECT_THAT(error_in(edited("  jerk_deg_per_s3: 12000\n", "")), HasSubstr("comes without jerk_deg_per_s3"));
  // None at all on an axis: the machine loads (placing by travel and checking need no
  // accelerations), and the time objective refuses it naming the axis's line.
  TempDir dir;
  const std::string file = dir.write("machine.yaml", edited("  accel_deg_per_s2: 1200\n  jerk_deg_per_s3: 12000\n", ""));
  const trunnion::Machine m = trunnion::load_machine(file);
  EXPECT_THAT(m.dynamics_missing, HasSubstr("axis C"));
  std::string path = "x,y,z,i,j,k\n0,0,25,0,0,1\n10,0,25,0,0,1\n";
  dir.write("path.csv", path);
  const Scene scene = load_scene(dir.write("scene.yaml", fmt::format("machine: {}\n"
                                                                     "tooling: {{tool_diameter_mm: 6, stick_out_mm: 60, "
                                                                     "chuck_diameter_mm: 30, chuck_length_mm: 60}}\n"
                                                                     "workpiece: {{box: {{size: [60, 60, 20]}}}}\n"
                                                                     "toolpath: path.csv\n",
                                                                     file)));
  Termination term;
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  const std::string msg = test::error_of([&] { place(scene, o, term); });
  EXPECT_THAT(msg, HasSubstr("machine.yaml:"));
  EXPECT_THAT(msg, HasSubstr("axis C gives no accel_deg_per_s2"));
  o.objective = PlacementOptions::Objective::travel;
  const PlacementResult r = place(scene, o, term);
  ASSERT_TRUE(r.summary.done());
  EXPECT_FALSE(r.travel->planned);
}

}  // namespace
}  // namespace machplan::placement
