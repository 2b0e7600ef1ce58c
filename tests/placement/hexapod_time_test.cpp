// `--objective time` on the HexaM: its six sliders timed by the feed planner, the bound the search
// prunes with never above the planned time of any placement it covers, and the machine file's
// slider limits read all or none.
#include "solvers/placement/search/internal/planned_time.h"
#include "solvers/placement/search/search.h"
#include "solvers/placement/scene/scene.h"
#include "tests/support/datasets.h"

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace hexapod_time_test {

using ::testing::HasSubstr;
using test::TempDir;

const std::string kMachine = test::kHexamPaper + "machine.yaml";

// Five small circular pockets on a 300 x 300 x 60 mm block, four of them cut with the tool
// leaning 25 deg outwards, joined by rapids: the sliders' limits, not only the feed, set its time.
std::string pocket_job() {
  std::string apt = "PARTNO pockets\nUNIT/MM\nCUTTER/10,5\nLOAD/TOOL,1\nFEDRAT/2000,MMPM\n";
  const double lean = 25.0 * M_PI / 180.0;
  for (const auto& [x, y] : {std::pair{-120.0, -120.0}, {120.0, -120.0}, {120.0, 120.0}, {-120.0, 120.0}, {0.0, 0.0}}) {
    const double d = std::hypot(x, y);
    const Eigen::Vector3d axis = d > 0 ? Eigen::Vector3d(x / d * std::sin(lean), y / d * std::sin(lean), std::cos(lean))
                                       : Eigen::Vector3d::UnitZ();
    const std::string ijk = fmt::format("{:.6f},{:.6f},{:.6f}", axis.x(), axis.y(), axis.z());
    const Eigen::Vector3d above = Eigen::Vector3d(x, y, 60) + 60 * axis;
    const std::string clear = fmt::format("RAPID\nGOTO/{:.4f},{:.4f},{:.4f},{}\n", above.x(), above.y(), above.z(), ijk);
    apt += clear;
    for (int deg = 0; deg <= 360; deg += 15)
      apt += fmt::format("GOTO/{:.4f},{:.4f},55,{}\n", x + 15 * std::cos(deg * M_PI / 180), y + 15 * std::sin(deg * M_PI / 180), ijk);
    apt += clear;
  }
  return apt + "FINI\n";
}

std::string machine_text() {
  std::ifstream in(kMachine);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

Scene pocket_scene(const TempDir& dir, const std::string& machine = kMachine, double resolution_mm = 4) {
  dir.write("job.apt", pocket_job());
  return load_scene(dir.write("scene.yaml", fmt::format("machine: {}\n"
                                                        "tooling: {{tool_diameter_mm: 10, corner_radius_mm: 5, stick_out_mm: 50, "
                                                        "flute_length_mm: 20, chuck_diameter_mm: 60, chuck_length_mm: 45}}\n"
                                                        "workpiece: {{box: {{size: [300, 300, 60]}}}}\n"
                                                        "toolpath: job.apt\n"
                                                        "search: {{pad_max_mm: 200, resolution_mm: {}}}\n",
                                                        machine, resolution_mm)));
}

PlannedTime planner_at(const Scene& scene, double rotation_deg) {
  std::vector<PathPose> poses(scene.tips_mm.size());
  for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = {scene.tips_mm[i], scene.axes[i]};
  const auto path = scene.model->axis_path(poses, scene.feeds_mm_per_min, rotation_deg * M_PI / 180);
  EXPECT_TRUE(path && path->on_rails());
  return PlannedTime(*path);
}

// No placement of the scene's 4 mm grid at rotation 0, free or not, takes less than `bound`: 40
// drawn at random.
void expect_no_grid_placement_below(const Scene& scene, double bound, unsigned seed) {
  const PlannedTime planned = planner_at(scene, 0);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> xy(-35, 35), pad(0, 50);
  for (int k = 0; k < 40; ++k) {
    const Eigen::Vector3d at(4.0 * xy(rng), 4.0 * xy(rng), 4.0 * pad(rng));
    EXPECT_GE(planned.planned_s(at), bound - 1e-9) << at.transpose();
  }
}

TEST(HexapodTime, TheBoundOverABoxNeverExceedsThePlannedTimeAnywhereInIt) {
  TempDir dir;
  const Scene scene = pocket_scene(dir);
  const PlannedTime planned = planner_at(scene, 30);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  double widest_gap = 0.0;
  for (int k = 0; k < 12; ++k) {
    const Eigen::Vector3d c(150 * u(rng), 150 * u(rng), 100 + 80 * u(rng));
    const Eigen::Vector3d h(60 * std::abs(u(rng)), 60 * std::abs(u(rng)), 40 * std::abs(u(rng)));
    const double box = planned.lower_bound(c, h);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d o = c + h.cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
      const double at = planned.lower_bound(o, Eigen::Vector3d::Zero());
      const double t = planned.planned_s(o);
      EXPECT_LE(box, at + 1e-9) << "box " << k;  // a box's bound is below each of its points' ...
      EXPECT_LE(at, t + 1e-9) << "box " << k;    // ... which is below the planned time
      EXPECT_GE(t, planned.plan(o).velocity_only_s() - 1e-9);
      widest_gap = std::max(widest_gap, 1.0 - box / t);
    }
  }
  // The sliders' speeds matter on this job: the bound is not merely the feed's time everywhere.
  EXPECT_LT(widest_gap, 0.5);
  EXPECT_GT(planned.planned_s({150, 150, 20}), 1.001 * planned.planned_s({0, 0, 120}));
}

TEST(HexapodTime, TheSetupFoundIsCertifiedTimedAndNoGridPlacementBeatsItsBound) {
  TempDir dir;
  const Scene scene = pocket_scene(dir);
  Termination term;
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  o.time_gap_pct = 0.0;
  const PlacementResult r = place(scene, o, term);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  EXPECT_TRUE(r.verified);
  ASSERT_TRUE(r.travel && r.centre_travel);
  EXPECT_TRUE(r.travel->planned);
  EXPECT_EQ(r.travel->axes.size(), 6u);
  EXPECT_THAT(r.summary.full_report(), HasSubstr("slider travel"));
  EXPECT_THAT(r.summary.full_report(), HasSubstr("machining time by the feed planner"));
  EXPECT_NEAR(r.objective_value, r.travel->time_s, 1e-6);
  EXPECT_LE(r.time_lower_bound_s, r.objective_value + 1e-9);
  // Never slower than the lowest placement, which the search times first.
  const PlacementResult lowest = place(scene, PlacementOptions{}, term);
  ASSERT_TRUE(lowest.summary.done());
  EXPECT_FALSE(lowest.travel);  // the sliders' report costs their inverse kinematics: with `time` only
  EXPECT_LE(r.objective_value, planner_at(scene, 0).planned_s(lowest.placement.offset()) + 1e-9);
  expect_no_grid_placement_below(scene, r.time_lower_bound_s, 9);
}

TEST(HexapodTime, TheDefaultGapStopsEarlierWithABoundThatHoldsAndTheSameAnswerOnAnyThreads) {
  TempDir dir;
  const Scene scene = pocket_scene(dir);
  Termination term;
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  o.threads = 1;
  const PlacementResult one = place(scene, o, term);
  o.threads = 2;
  const PlacementResult two = place(scene, o, term);
  ASSERT_TRUE(one.summary.done() && two.summary.done());
  EXPECT_EQ(one.placement.offset(), two.placement.offset());
  EXPECT_EQ(one.objective_value, two.objective_value);
  EXPECT_EQ(one.time_lower_bound_s, two.time_lower_bound_s);
  // Within the gap of the least, or the search timed as many placements as it may; the bound the
  // report gives holds on the grid.
  EXPECT_LE(one.time_lower_bound_s, one.objective_value);
  if (one.time_lower_bound_s < 0.99 * one.objective_value)
    EXPECT_THAT(one.summary.message, HasSubstr("100 placements timed"));
  expect_no_grid_placement_below(scene, one.time_lower_bound_s, 4);
}

TEST(HexapodTime, SliderLimitsComeAllOrNoneAndTheTimeObjectiveNeedsThem) {
  const std::string machine = machine_text();
  const auto edited = [&](const std::string& from, const std::string& to) {
    std::string m = machine;
    const std::size_t at = m.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return m.replace(at, from.size(), to);
  };
  TempDir dir;
  const auto error_in = [&](const std::string& text) {
    const std::string file = dir.write("machine.yaml", text);
    return test::error_of([&] { hexam::load_machine(file); });
  };
  EXPECT_THAT(error_in(edited("  jerk_mm_per_s3: 100000\n", "")), HasSubstr("not jerk_mm_per_s3"));
  EXPECT_THAT(error_in(edited("accel_mm_per_s2: 5000", "accel_mm_per_s2: -5")), HasSubstr("machine.yaml:"));
  // None at all: the machine places by the lowest pad as before, and `time` is refused at its
  // sliders.
  std::string bare = edited("  feed_mm_per_min: 30000\n  rapid_mm_per_min: 60000\n  accel_mm_per_s2: 5000\n  jerk_mm_per_s3: 100000\n", "");
  const std::string file = dir.write("bare.yaml", bare);
  const Scene scene = pocket_scene(dir, file, 10);
  Termination term;
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  const std::string msg = test::error_of([&] { place(scene, o, term); });
  // (the block's first line, where the limits would go)
  const int sliders_line = 1 + static_cast<int>(std::count(bare.begin(), bare.begin() + bare.find("stroke_min_mm"), '\n'));
  EXPECT_THAT(msg, HasSubstr(fmt::format("bare.yaml:{}", sliders_line)));
  EXPECT_THAT(msg, HasSubstr("the sliders give no feed_mm_per_min"));
  // Travel needs axes affine in the placement, which a hexapod's sliders are not.
  o.objective = PlacementOptions::Objective::travel;
  EXPECT_THAT(test::error_of([&] { place(scene, o, term); }), HasSubstr("'travel' needs"));
  EXPECT_TRUE(place(scene, PlacementOptions{}, term).summary.done());
}

}  // namespace hexapod_time_test
}  // namespace machplan::placement
