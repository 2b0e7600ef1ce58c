// Sheet alignment (RunOptions::align_mm, run --align): two points on the sheet's edge set the
// program's zero and turn the program by the edge's angle; the turned job runs within the
// contour limits, is checked against the travel, and bad points are refused by their field.
#include <cmath>
#include <cstdio>
#include <numbers>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "solvers/motion/run.h"
#include "tests/support/datasets.h"

namespace machplan::motion {
namespace {

using test::gantry;
using test::part;

TEST(SheetAlignment, AnEdgeAtNinetyDegreesTurnsEveryPointAndArcAboutTheFirstPoint) {
  const cutting::MachineConfig m = gantry();
  RunOptions plain;
  plain.origin_mm = Eigen::Vector2d::Zero();
  const PlannedRun a = plan_program(part("bracket_l.ngc"), plain, m);
  RunOptions turned;
  const Eigen::Vector2d origin(1500.0, 300.0);
  turned.align_mm = std::make_pair(origin, Eigen::Vector2d(1500.0, 400.0));  // the edge along +Y
  const PlannedRun b = plan_program(part("bracket_l.ngc"), turned, m);
  ASSERT_TRUE(b.summary.done()) << b.summary.full_report();
  EXPECT_EQ(b.origin_from, "sheet alignment");
  EXPECT_NEAR(b.rotation_deg, 90.0, 1e-12);
  // The programmed cuts, point for point: (x, y) lands at origin + (-y, x); arcs keep their sense.
  const auto turn = [&](const Eigen::Vector2d& p) { return Eigen::Vector2d(origin.x() - p.y(), origin.y() + p.x()); };
  std::size_t cuts = 0, arcs = 0;
  ASSERT_EQ(a.programmed.stretches.size(), b.programmed.stretches.size());
  for (std::size_t k = 0; k < a.programmed.stretches.size(); ++k) {
    const Stretch &sa = a.programmed.stretches[k], &sb = b.programmed.stretches[k];
    if (!sa.cutting) continue;
    ++cuts;
    ASSERT_EQ(sa.segments.size(), sb.segments.size());
    for (std::size_t i = 0; i < sa.segments.size(); ++i) {
      EXPECT_LT((turn(sa.segments[i].end) - sb.segments[i].end).norm(), 1e-9);
      if (sa.segments[i].kind != Segment::Kind::arc) continue;
      ++arcs;
      EXPECT_LT((turn(sa.segments[i].center) - sb.segments[i].center).norm(), 1e-9);
      EXPECT_NEAR(sa.segments[i].sweep, sb.segments[i].sweep, 1e-12);
    }
  }
  EXPECT_GT(cuts, 0u);
  EXPECT_GT(arcs, 0u);
}

TEST(SheetAlignment, ATurnedJobRunsWithinTheContourLimitsAndOneOffTheTableIsRefused) {
  RunOptions o;
  o.session.machine_config = gantry();
  o.align_mm = std::make_pair(Eigen::Vector2d(500.0, 400.0), Eigen::Vector2d(600.0, 410.0));  // 5.71 deg
  const RunOutcome r = run_program(part("bracket_l.ngc"), o);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  EXPECT_NEAR(r.rotation_deg, std::atan2(10.0, 100.0) * 180.0 / std::numbers::pi, 1e-9);
  EXPECT_LT(r.result.max_true_contour_error_mm(), 0.1);
  // The same edge near the table's far side: the turned bracket leaves the travel.
  o.align_mm = std::make_pair(Eigen::Vector2d(2700.0, 400.0), Eigen::Vector2d(2800.0, 500.0));
  const PlannedRun off = plan_program(part("bracket_l.ngc"), o, gantry());
  EXPECT_FALSE(off.summary.done());
  EXPECT_NE(off.summary.message.find("outside the travel"), std::string::npos) << off.summary.message;
  // The advice is about the sheet and its points, not an origin (which an alignment replaces),
  // and taken, it fits.
  EXPECT_EQ(off.limit_field, "align_mm");
  const std::size_t at = off.summary.message.find("move the sheet by X ");
  ASSERT_NE(at, std::string::npos) << off.summary.message;
  double dx = 0, dy = 0;
  ASSERT_EQ(std::sscanf(off.summary.message.c_str() + at, "move the sheet by X %lf, Y %lf", &dx, &dy), 2);
  o.align_mm->first += Eigen::Vector2d(dx, dy);
  o.align_mm->second += Eigen::Vector2d(dx, dy);
  const PlannedRun moved = plan_program(part("bracket_l.ngc"), o, gantry());
  EXPECT_TRUE(moved.summary.done() || moved.summary.message.find("outside the travel") == std::string::npos)
      << moved.summary.message;
}

TEST(SheetAlignment, BadPointsAreRefusedNamingTheField) {
  const auto field_of = [](RunOptions o) {
    try {
      o.validate();
    } catch (const InputError& e) {
      return e.where() + ": " + e.message();
    }
    return std::string("accepted");
  };
  RunOptions o;
  o.align_mm = std::make_pair(Eigen::Vector2d(0, 0), Eigen::Vector2d(5, 0));
  EXPECT_NE(field_of(o).find("align_mm: the two points are 5.000 mm apart"), std::string::npos) << field_of(o);
  o.align_mm = std::make_pair(Eigen::Vector2d(0, 0), Eigen::Vector2d(NAN, 0));
  EXPECT_EQ(field_of(o).rfind("align_mm", 0), 0u) << field_of(o);
  o.align_mm = std::make_pair(Eigen::Vector2d(0, 0), Eigen::Vector2d(100, 0));
  EXPECT_EQ(field_of(o), "accepted");
  o.origin_mm = Eigen::Vector2d(1, 1);
  EXPECT_NE(field_of(o).find("give it or origin_mm, not both"), std::string::npos) << field_of(o);
}

}  // namespace
}  // namespace machplan::motion
