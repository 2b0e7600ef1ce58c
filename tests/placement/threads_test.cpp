// The answers do not depend on the number of threads: searches, certified reports and dense
// re-checks with one thread and with several give the same placement, the same verdicts and
// the same figures (the work done may differ; it is not part of the answer).
#include <string>

#include <gtest/gtest.h>

#include "solvers/placement/search/search.h"
#include "tests/support/datasets.h"

namespace machplan::placement {
namespace {


void expect_same(const CheckReport& a, const CheckReport& b, const std::string& what) {
  EXPECT_EQ(a.free(), b.free()) << what;
  EXPECT_EQ(a.stroke_margin_mm, b.stroke_margin_mm) << what;
  EXPECT_EQ(a.joint_margin_deg, b.joint_margin_deg) << what;
  for (int k = 0; k < kKindCount; ++k) {
    const Finding &x = a.kinds[k], &y = b.kinds[k];
    const std::string kind = what + " " + kind_name(static_cast<Kind>(k));
    EXPECT_EQ(x.interferes, y.interferes) << kind;
    EXPECT_EQ(x.clearance_mm, y.clearance_mm) << kind;
    EXPECT_EQ(x.pose, y.pose) << kind;
    EXPECT_EQ(x.t, y.t) << kind;
    EXPECT_EQ(x.what, y.what) << kind;
  }
}

void expect_same(const PlacementResult& a, const PlacementResult& b, const std::string& what) {
  EXPECT_EQ(a.summary.status, b.summary.status) << what;
  EXPECT_EQ(a.placement.x_mm, b.placement.x_mm) << what;
  EXPECT_EQ(a.placement.y_mm, b.placement.y_mm) << what;
  EXPECT_EQ(a.placement.pad_mm, b.placement.pad_mm) << what;
  EXPECT_EQ(a.placement.rotation_deg, b.placement.rotation_deg) << what;
  EXPECT_EQ(a.rotation_tolerance_deg, b.rotation_tolerance_deg) << what;
  EXPECT_EQ(a.verified, b.verified) << what;
  EXPECT_EQ(a.objective_value, b.objective_value) << what;
  expect_same(a.report, b.report, what);
}

// The scene with only the first `n` poses of its tool path. The number of threads may change
// no answer on any path; a shorter one keeps the slowest comparisons (dense checks, the paper's
// search) within seconds under the sanitizers.
Scene first_poses(Scene s, std::size_t n) {
  EXPECT_LT(n, s.tips_mm.size());
  s.tips_mm.resize(n);
  s.axes.resize(n);
  s.lines.resize(n);
  s.feeds_mm_per_min.resize(n);
  while (s.runs.back().first >= n) s.runs.pop_back();
  s.runs.back().end = n;
  return s;
}

PlacementResult search(const Scene& scene, PlacementOptions o, int threads) {
  o.threads = threads;
  Termination term;
  return place(scene, o, term);
}

TEST(Threads, TheHexapodSearchGivesTheSameAnswerOnOneAndSeveralThreads) {
  const Scene scene = load_scene(test::kDatasets + "hexam-paper/scene.yaml");
  PlacementOptions o;
  const PlacementResult one = search(scene, o, 1);
  ASSERT_EQ(one.threads, 1);
  ASSERT_TRUE(one.summary.done());
  expect_same(one, search(scene, o, 4), "threads 4");
  // A list of rotations, and the paper's search, on the first tenth of the path.
  const Scene part = first_poses(scene, scene.tips_mm.size() / 10);
  o.rotations_deg = {0, 180};
  const PlacementResult turned = search(part, o, 1);
  ASSERT_TRUE(turned.summary.done());
  expect_same(turned, search(part, o, 3), "rotations, 3 threads");
  PlacementOptions paper;
  paper.strategy = PlacementOptions::Strategy::paper;
  expect_same(search(part, paper, 1), search(part, paper, 2), "paper");
}

TEST(Threads, ChecksGiveTheSameFiguresOnOneAndSeveralThreads) {
  const Scene whole = load_scene(test::kDatasets + "hexam-paper/scene.yaml");
  // The dense checks on the first twentieth of the path (a dense check of the whole path is the
  // slowest of all under the sanitizers).
  const Scene part = first_poses(whole, whole.tips_mm.size() / 20);
  for (const bool dense : {false, true}) {
    const Scene& scene = dense ? part : whole;
    CheckOptions o;
    o.dense = dense;
    o.threads = 1;
    Termination term;
    // A free placement and one that interferes, turned.
    for (const Placement p : {Placement{-68, -22, 57, 0}, Placement{-35, -35, 70, 10}}) {
      const CheckResult one = check(scene, p, o, term);
      o.threads = 3;
      const CheckResult three = check(scene, p, o, term);
      o.threads = 1;
      expect_same(one.report, three.report, dense ? "dense" : "certified");
    }
  }
}

TEST(Threads, TheTrunnionSearchGivesTheSameAnswerOnOneAndSeveralThreads) {
  const Scene scene = load_scene(test::kDatasets + "trunnion-5axis/scene.yaml");
  expect_same(search(scene, {}, 1), search(scene, {}, 2), "trunnion");
}

TEST(Threads, TheTimeSearchTimesTheSamePlacementsOnOneAndSeveralThreads) {
  // The channel's first two passes: the placements are timed in the order of their bounds
  // whatever the batches screened in parallel, so the answer, its time, the bound of the rest
  // and the count in the message agree.
  const Scene scene = first_poses(load_scene(test::kDatasets + "wei-lee-2020/scene.yaml"), 600);
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  const PlacementResult one = search(scene, o, 1), two = search(scene, o, 2);
  expect_same(one, two, "time");
  EXPECT_EQ(one.time_lower_bound_s, two.time_lower_bound_s);
  EXPECT_EQ(one.summary.message, two.summary.message);
}

}  // namespace
}  // namespace machplan::placement
