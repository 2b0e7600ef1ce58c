// The answers do not depend on the number of threads: searches, certified reports and dense
// re-checks with one thread and with several give the same placement, the same verdicts and
// the same figures (the work done may differ; it is not part of the answer).
#include <string>

#include <gtest/gtest.h>

#include "solvers/placement/search/search.h"

namespace machplan::placement {
namespace {

const std::string kData = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/";

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

PlacementResult search(const Scene& scene, PlacementOptions o, int threads) {
  o.threads = threads;
  Termination term;
  return place(scene, o, term);
}

TEST(Threads, TheHexapodSearchGivesTheSameAnswerOnOneAndSeveralThreads) {
  const Scene scene = load_scene(kData + "hexam-paper/scene.yaml");
  PlacementOptions o;
  const PlacementResult one = search(scene, o, 1);
  ASSERT_EQ(one.threads, 1);
  ASSERT_TRUE(one.summary.done());
  expect_same(one, search(scene, o, 4), "threads 4");
  // A list of rotations, and the paper's search.
  o.rotations_deg = {0, 180};
  const PlacementResult turned = search(scene, o, 1);
  expect_same(turned, search(scene, o, 3), "rotations, 3 threads");
  PlacementOptions paper;
  paper.strategy = PlacementOptions::Strategy::paper;
  expect_same(search(scene, paper, 1), search(scene, paper, 2), "paper");
}

TEST(Threads, ChecksGiveTheSameFiguresOnOneAndSeveralThreads) {
  const Scene scene = load_scene(kData + "hexam-paper/scene.yaml");
  for (const bool dense : {false, true}) {
    CheckOptions o;
    o.dense = dense;
    o.threads = 1;
    Termination term;
    // A free placement and one that interferes, turned (dense: the one that interferes only, the
    // free one's dense check being the slowest of all under the sanitizers).
    for (const Placement p : {Placement{-68, -22, 57, 0}, Placement{-35, -35, 70, 10}}) {
      if (dense && p.x_mm == -68) continue;
      const CheckResult one = check(scene, p, o, term);
      o.threads = 3;
      const CheckResult three = check(scene, p, o, term);
      o.threads = 1;
      expect_same(one.report, three.report, dense ? "dense" : "certified");
    }
  }
}

TEST(Threads, TheTrunnionSearchGivesTheSameAnswerOnOneAndSeveralThreads) {
  const Scene scene = load_scene(kData + "trunnion-5axis/scene.yaml");
  expect_same(search(scene, {}, 1), search(scene, {}, 2), "trunnion");
}

}  // namespace
}  // namespace machplan::placement
