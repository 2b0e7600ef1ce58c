// The bounds the search screens boxes of placements with, checked against exact evaluations:
// the HexaM model's box ranges (slider stroke, tool assembly against a box peripheral) hold at
// every placement sampled in the box, corners included; the stroke keeps its pad rate; and
// class 1 walked as the parts of revolution and the plate apart finds what one walk of all the
// parts finds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "solvers/placement/check/checker.h"
#include "tests/support/datasets.h"
#include "engine/common/internal/numbers.h"
#include "solvers/placement/check/internal/class1.h"
#include "solvers/placement/machines/internal/bounds.h"
#include "solvers/placement/scene/internal/workpiece.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {
namespace {

constexpr int kStroke = 0;          // machines/hexam_model.cpp: the lower stroke margin ...
constexpr int kAssemblyMagazine = 5;  // ... and the tool assembly against the first peripheral


Scene bundled() { return load_scene(test::kHexamPaper + "scene.yaml"); }

// A pose of the path near the magazine's corner of the table at this rotation (the best of a
// few random ones), so that the assembly comes near the magazine, into it, or stays clear.
long pose_towards_magazine(const Scene& scene, double rotation_deg, std::mt19937& rng) {
  std::uniform_int_distribution<long> any(0, static_cast<long>(scene.tips_mm.size()) - 1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(rotation_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  long best = any(rng);
  for (int k = 0; k < 12; ++k) {
    const long i = any(rng);
    if ((R * scene.tips_mm[i]).head<2>().sum() > (R * scene.tips_mm[best]).head<2>().sum()) best = i;
  }
  return best;
}

struct Tally {
  int boxes = 0, near = 0, deep = 0, decided = 0;
};

// Samples boxes around placements near the bundled answer and checks constraint c's range
// against exact values at 24 points of each box (its 8 corners and 16 inside).
Tally check_ranges(int c, int boxes) {
  const Scene scene = bundled();
  const MachineModel& model = *scene.model;
  const double limit = model.constraints()[c].limit;
  auto e = model.evaluator();
  std::mt19937 rng(20261127);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), half(0.0, 6.0);
  std::vector<double> v(model.stride());
  Tally t;
  for (int b = 0; b < boxes; ++b) {
    const double rot = std::vector<double>{0.0, -106.0, 180.0, 45.0}[b % 4];
    const long i = pose_towards_magazine(scene, rot, rng);
    const PathPose pose{scene.tips_mm[i], scene.axes[i]};
    const Placement centre{60 * unit(rng), 60 * unit(rng), 40 + 30 * unit(rng), rot};
    const Eigen::Vector3d h(half(rng), half(rng), b % 3 == 0 ? 0.0 : half(rng));
    const auto r = e->box_range(c, pose, Where::of(centre), h);
    if (!r) continue;
    ++t.boxes;
    EXPECT_LE(r->lower, r->upper + 1e-9);
    t.decided += r->upper < limit || r->lower >= limit;
    for (int k = 0; k < 24; ++k) {
      Eigen::Vector3d d;
      if (k < 8)
        d = Eigen::Vector3d(k & 1 ? h.x() : -h.x(), k & 2 ? h.y() : -h.y(), k & 4 ? h.z() : -h.z());
      else
        d = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(h);
      const Placement p{centre.x_mm + d.x(), centre.y_mm + d.y(), centre.pad_mm + d.z(), rot};
      e->evaluate(pose, Where::of(p), bit(c), v.data());
      EXPECT_LE(v[c], r->upper) << "constraint " << c << ", pose " << i << ", box " << b << ", corner/sample " << k;
      // evaluate() may give a lower bound far above the limit; below that it is exact.
      if (v[c] < limit + 10.0)
        EXPECT_GE(v[c], r->lower) << "constraint " << c << ", pose " << i << ", box " << b << ", corner/sample " << k;
      t.near += v[c] < limit + 10.0;
      t.deep += v[c] < 0.0;
    }
  }
  std::printf("constraint %d: %d boxes, %d decided; %d values near the limit, %d below 0\n", c, t.boxes, t.decided, t.near, t.deep);
  return t;
}

TEST(BoxBounds, TheAssemblyAgainstTheMagazineStaysWithinItsRangeOverEveryBox) {
  const Tally t = check_ranges(kAssemblyMagazine, 300);
  EXPECT_GT(t.boxes, 250);
  // Not vacuous: values near the limit, overlaps, and boxes the range alone decides.
  EXPECT_GT(t.near, 1000);
  EXPECT_GT(t.deep, 500);
  EXPECT_GT(t.decided, 50);
}

TEST(BoxBounds, TheSliderStrokeStaysWithinItsRangeOverEveryBox) {
  const Tally t = check_ranges(kStroke, 300);
  EXPECT_GT(t.boxes, 200);
  EXPECT_GT(t.near, 300);
  EXPECT_GT(t.decided, 50);
}

TEST(BoxBounds, TheRangesAreTighterThanTheMotionBoundsAlone) {
  // Over a box flat in pad, the magazine's clearance from the spindle plate above its top changes
  // little with x and y: the range is narrower than the value plus or minus the box's radius
  // (what fall() allows) for most such boxes near the answer.
  const Scene scene = bundled();
  auto e = scene.model->evaluator();
  std::mt19937 rng(7);
  std::vector<double> v(scene.model->stride());
  int narrower = 0, measured = 0;
  for (int b = 0; b < 200; ++b) {
    const long i = pose_towards_magazine(scene, -106.0, rng);
    const PathPose pose{scene.tips_mm[i], scene.axes[i]};
    const Placement centre{-5, 45, 36, -106};
    const Eigen::Vector3d h(2.0, 2.0, 0.0);
    e->evaluate(pose, Where::of(centre), bit(kAssemblyMagazine), v.data());
    if (v[kAssemblyMagazine] > 20.0) continue;
    const auto r = e->box_range(kAssemblyMagazine, pose, Where::of(centre), h);
    ASSERT_TRUE(r);
    ++measured;
    narrower += r->upper - r->lower < 0.75 * 2 * h.norm();
  }
  EXPECT_GT(measured, 10);
  EXPECT_GT(narrower, measured / 2) << narrower << " of " << measured;
}

TEST(BoxBounds, TheLowerStrokeMarginFallsAtLeastAsMuchAsThePad) {
  // What lets one look at a box's top condemn the pads below it (machines/machine_model.h,
  // pad_rate).
  const Scene scene = bundled();
  const Constraint& con = scene.model->constraints()[kStroke];
  ASSERT_EQ(con.pad_trend, 1);
  ASSERT_GT(con.pad_rate, 0.0);
  auto e = scene.model->evaluator();
  std::mt19937 rng(11);
  std::uniform_int_distribution<long> any(0, static_cast<long>(scene.tips_mm.size()) - 1);
  std::uniform_real_distribution<double> xy(-150.0, 150.0), pad(0.0, 150.0), drop(0.1, 60.0), turn(-180.0, 180.0);
  std::vector<double> hi(scene.model->stride()), lo(scene.model->stride());
  int above = 0;
  for (int k = 0; k < 2000; ++k) {
    const long i = any(rng);
    const PathPose pose{scene.tips_mm[i], scene.axes[i]};
    Placement p{xy(rng), xy(rng), pad(rng), turn(rng)};
    e->evaluate(pose, Where::of(p), bit(kStroke), hi.data());
    const double d = drop(rng);
    p.pad_mm -= d;
    e->evaluate(pose, Where::of(p), bit(kStroke), lo.data());
    if (lo[kStroke] < con.limit) continue;
    ++above;
    EXPECT_LE(lo[kStroke], hi[kStroke] - con.pad_rate * d + 1e-9) << "pose " << i << ", drop " << d;
  }
  EXPECT_GT(above, 200);
}

TEST(Class1Parts, WalkedApartTheyFindWhatOneWalkOfAllThePartsFinds) {
  // With a safe distance close to the chuck's clearance, so that both walks pin it finely.
  for (const double safe : {5.0, 48.0}) {
    Scene scene = bundled();
    scene.safe_distance_mm = safe;
    Checker checker(scene);
    PoseTree tree(*scene.model, checker.poses());
    Class1Check whole(*scene.model, tree, scene.model->workpiece(), safe);
    Class1Check::Shapes shapes = whole.make_shapes();
    for (const double rot : {-106.0, 137.0}) {
      Termination term;
      const Finding apart = checker.class1(rot, term);
      const Class1Result one = whole.run(rot * kDeg, term, [&]() -> Class1Check::Shapes& { return shapes; });
      EXPECT_EQ(apart.interferes, one.finding.interferes) << "safe " << safe << ", rotation " << rot;
      const double margin = std::max(report_margin(apart.clearance_mm, safe, 0.25), report_margin(one.finding.clearance_mm, safe, 0.25));
      EXPECT_NEAR(apart.clearance_mm, one.finding.clearance_mm, margin) << "safe " << safe << ", rotation " << rot;
    }
  }
}

}  // namespace
}  // namespace machplan::placement
