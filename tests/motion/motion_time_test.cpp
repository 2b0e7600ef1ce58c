// Planned motion time on the bundled parts through the pipeline of `machplan run`
// (solvers/motion/run.h), measured as motion only (the sum of the planned trajectories,
// rapids included; torch sequence and dwells excluded), against:
//   * the time-optimal motion on the same executed paths (engine/motion/time_optimal.h),
//   * the motion times a trajectory planner with per-axis limits and exact stops reaches on
//     the same parts with the same limits (81.8 mm/s, 500 mm/s^2, path tolerance 0.01 mm):
//     triangle 12.155 s, contour 17.640 s, an L bracket of lines, fillets and holes 28.459 s,
//     nested sheet 271.303 s. Our planner limits jerk as well and must still be no slower.
// And the rapids: straight between a part's holes and from its holes to its outline, and on
// the nested sheet every detour is round a part already cut, with its extra length reported.
#include <cstdio>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli/json/run.h"
#include "tests/support/datasets.h"
#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "solvers/motion/run.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using ::testing::HasSubstr;

using test::part;

RunOutcome run(const std::string& name) {
  RunOptions o;  // thermal_gantry, planned mode, its jerk limit on
  o.session.executor.record_trace = false;
  RunOutcome r = run_program(part(name), o);
  std::printf("%-24s planned motion %.3f s  optimum %.3f s (ratio %.4f)  bound %.3f s  rapids %.1f mm (straight %.1f)\n",
              name.c_str(), r.planned_motion_s, r.motion_optimum_s, r.optimum_ratio, r.motion_lower_bound_s,
              r.rapids.length_mm, r.rapids.straight_length_mm);
  EXPECT_EQ(r.result.summary.status, Status::done) << r.summary.full_report();
  EXPECT_LE(r.result.max_contour_error_mm(), 0.1) << name;
  // bound <= optimum <= planned.
  EXPECT_GE(r.motion_optimum_s, r.motion_lower_bound_s * (1 - 1e-9)) << name;
  EXPECT_GE(r.planned_motion_s, r.motion_optimum_s) << name;
  EXPECT_NEAR(r.optimum_ratio, r.planned_motion_s / r.motion_optimum_s, 1e-12);
  return r;
}

TEST(MotionTime, TriangleAndContourWithinThreePercentOfTheOptimum) {
  const RunOutcome t = run("triangle_45.ngc");
  EXPECT_LE(t.planned_motion_s, 12.155);
  EXPECT_LE(t.optimum_ratio, 1.03);
  const RunOutcome c = run("contour_lines_arcs.ngc");
  EXPECT_LE(c.planned_motion_s, 17.640);
  EXPECT_LE(c.optimum_ratio, 1.03);
  // A single part: no detour at all.
  EXPECT_EQ(t.rapids.detours, 0u);
  EXPECT_EQ(c.rapids.detours, 0u);
}

TEST(MotionTime, BracketHolesAreReachedStraight) {
  const RunOutcome b = run("bracket_l.ngc");
  EXPECT_LE(b.planned_motion_s, 28.459);
  EXPECT_EQ(b.rapids.small_slugs, 4u);  // four 12 mm holes
  EXPECT_EQ(b.rapids.detours, 0u);
  EXPECT_LE(b.rapids.length_mm, 1.10 * b.rapids.straight_length_mm);
  // Holes at 40 mm/s, the outline at 80.
  bool slow = false, fast = false;
  for (const Stretch& s : b.job.stretches)
    if (s.cutting)
      for (double f : s.feed_mm_per_s) (f == 40.0 ? slow : fast) = true;
  EXPECT_TRUE(slow);
  EXPECT_TRUE(fast);
}

TEST(MotionTime, NestedSheetDetoursOnlyRoundCutParts) {
  const RunOutcome n = run("nested_sheet.ngc");
  EXPECT_LE(n.planned_motion_s, 271.303);
  EXPECT_GT(n.rapids.detours, 0u);
  for (const RapidReport& r : n.rapids.rapids) {
    if (!r.replaced) continue;
    EXPECT_THAT(r.reason, HasSubstr("part cut at line")) << "rapid at line " << r.source_line;
    EXPECT_THAT(r.reason, ::testing::Not(HasSubstr("slug"))) << "rapid at line " << r.source_line;
  }
  const std::string report = n.summary.full_report();
  EXPECT_THAT(report, HasSubstr("detour at line"));
  EXPECT_THAT(report, HasSubstr("time-optimal on the same paths"));
  const nlohmann::json j = cli::to_json(n);
  EXPECT_EQ(j["rapids"]["detours"].size(), n.rapids.detours);
  EXPECT_DOUBLE_EQ(j["motion_optimum_s"].get<double>(), n.motion_optimum_s);
}

TEST(MotionTime, SlugTipSizeComesFromTheMachineFile) {
  const std::string gantry = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml";
  std::string yaml = read_text_file(gantry);
  const std::string key = "slug_tip_size_mm: 50";
  const auto at = yaml.find(key);
  ASSERT_NE(at, std::string::npos);
  test::TempDir dir;
  RunOptions o;
  o.session.executor.record_trace = false;
  // 10 mm: the bracket's 12 mm slugs may tip up, so they are zones like the outline.
  o.session.machine = dir.write("small.yaml", std::string(yaml).replace(at, key.size(), "slug_tip_size_mm: 10"));
  const RunOutcome r = run_program(part("bracket_l.ngc"), o);
  EXPECT_EQ(r.machine.slug_tip_size_mm, 10.0);
  EXPECT_EQ(r.rapids.small_slugs, 0u);
  EXPECT_EQ(r.rapids.cut_zones, 5u);
  // A negative size is refused, naming the file and line.
  o.session.machine = dir.write("bad.yaml", std::string(yaml).replace(at, key.size(), "slug_tip_size_mm: -1"));
  try {
    (void)run_program(part("bracket_l.ngc"), o);
    FAIL() << "a negative slug size was accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("bad.yaml:"));
    EXPECT_THAT(e.what(), HasSubstr("slug_tip_size_mm"));
  }
}

}  // namespace
}  // namespace machplan::motion
