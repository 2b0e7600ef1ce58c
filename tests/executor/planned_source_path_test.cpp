// What the planned source gives contour and preview controllers beside r, v and a: the
// segment of the followed path the tool is on, and the setpoints of the next periods.
#include <gtest/gtest.h>

#include "engine/executor/planned_source.h"
#include "engine/motion/feed_planner.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

MachineSetup machine(int read_latency) {
  MachineSetup m;
  m.name = "test";
  for (int i = 0; i < hardware::kAxes; ++i) {
    m.signals[i].reading_latency_ticks = read_latency;
    m.signals[i].command_latency_ticks = 1;
    m.max_speed_mm_per_s[i] = 100;
  }
  return m;
}

// A closed triangle, each leg rest to rest: the cursor must start on the first leg (the last
// one ends at the same point) and follow the legs in order.
TEST(PlannedSourcePath, FollowsTheSegmentsOfAClosedContourInOrder) {
  const Eigen::Vector2d a(0, 0), b(60, 0), c(30, 40);
  auto chain = std::make_unique<test::ChainTrajectory>();
  chain->add(std::make_unique<test::LineTrajectory>(a, b, 50, 500));
  chain->add(std::make_unique<test::LineTrajectory>(b, c, 50, 500));
  chain->add(std::make_unique<test::LineTrajectory>(c, a, 50, 500));
  test::OneCut cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b, c}, true), 50, true), std::move(chain));
  const std::vector<Segment>& segs = cut.job.stretches[0].segments;
  ASSERT_EQ(segs.size(), 3u);
  const MachineSetup m = machine(1);
  PlannedSource s;
  s.prepare({&cut.job, &cut.trajectories, &m, 0.001}, a);
  Demand d;
  s.demand(d);
  EXPECT_EQ(d.track.path, nullptr);  // holding before the move
  EXPECT_EQ(d.track.preview_ticks, 0);
  s.begin_move(1, a);
  std::size_t last = 0;
  std::array<int, 3> ticks_on{};
  Eigen::Vector2d tool = a;  // a tool that follows the setpoint exactly
  while (!s.move_done()) {
    s.demand(d);
    ASSERT_NE(d.track.path, nullptr);
    const std::size_t k = static_cast<std::size_t>(d.track.path - segs.data());
    ASSERT_LT(k, 3u);
    ASSERT_GE(k, last);  // never back
    last = k;
    ++ticks_on[k];
    const Eigen::Vector2d r(d.track.r_mm[0], d.track.r_mm[1]);
    // r lies on the segment given (to within the one period the tool trails it by, at a
    // corner the legs reach at rest)
    ASSERT_LT((closest_point(segs[k], r) - r).norm(), 1e-6);
    tool = r;
    s.advance(tool, {});
  }
  for (int n : ticks_on) EXPECT_GT(n, 500);
}

// At a cusp (the path turns back on itself) the tool lags on the first leg, which is also the
// nearest to it for the whole way back: the setpoint running back against that leg moves the
// cursor on, or a contour controller would hold the tool on the leg it has to leave.
TEST(PlannedSourcePath, ACuspMovesTheCursorOnWhenTheSetpointTurnsBack) {
  const Eigen::Vector2d a(0, 0), b(60, 0), c(20, 0.5);
  auto chain = std::make_unique<test::ChainTrajectory>();
  chain->add(std::make_unique<test::LineTrajectory>(a, b, 50, 500));
  chain->add(std::make_unique<test::LineTrajectory>(b, c, 50, 500));
  test::OneCut cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b, c}, false), 50, true), std::move(chain));
  const std::vector<Segment>& segs = cut.job.stretches[0].segments;
  const MachineSetup m = machine(1);
  PlannedSource s;
  s.prepare({&cut.job, &cut.trajectories, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  // A tool on the first leg, a little behind the setpoint, all the way.
  bool turned_back = false;
  while (!s.move_done()) {
    s.demand(d);
    const double x = std::max(0.0, d.track.r_mm[0] - 0.5);
    if (d.track.v_ff_mm_per_s[0] < -1.0) turned_back = true;
    if (turned_back && d.track.r_mm[0] < 50.0) break;
    s.advance(Eigen::Vector2d(x, 0.0), {});
  }
  ASSERT_TRUE(turned_back);
  EXPECT_EQ(d.track.path, &segs[1]);
}

// The segment given is the TOOL's: a tool lagging behind a corner keeps the leg it is on.
TEST(PlannedSourcePath, ALaggingToolKeepsItsSegmentAtACorner) {
  const Eigen::Vector2d a(0, 0), b(60, 0), c(60, 40);
  auto chain = std::make_unique<test::ChainTrajectory>();
  chain->add(std::make_unique<test::LineTrajectory>(a, b, 50, 500));
  chain->add(std::make_unique<test::LineTrajectory>(b, c, 50, 500));
  test::OneCut cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b, c}, false), 50, true), std::move(chain));
  const std::vector<Segment>& segs = cut.job.stretches[0].segments;
  const MachineSetup m = machine(1);
  PlannedSource s;
  s.prepare({&cut.job, &cut.trajectories, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  const Eigen::Vector2d lagging(59.0, 0.0);  // 1 mm before the corner
  while (!s.move_done()) {
    s.advance(lagging, {});
    s.demand(d);
  }
  EXPECT_GT(d.track.r_mm[1], 39.0);  // the setpoint is at the end of the second leg
  EXPECT_EQ(d.track.path, &segs[0]);  // the tool is still on the first
  s.advance(Eigen::Vector2d(60.0, 2.0), {});  // it turns
  s.demand(d);
  EXPECT_EQ(d.track.path, &segs[1]);
}

// A planner that rounds corners: the path given is its executed path, so at the corner the
// tool following the setpoint is given the blend arc it is on, not the programmed corner it
// is cutting short (a contour controller would pull it off the blend towards that corner).
TEST(PlannedSourcePath, ABlendedCornerGivesTheBlendArc) {
  const Eigen::Vector2d a(0, 0), b(30, 0), c(30, 20);
  test::OneCut cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b, c}, false), 50, true), nullptr);
  std::unique_ptr<motion::PlannedTrajectory> tr =
      motion::plan_stretch_detailed(cut.job.stretches[0], motion::PlannerOptions::xy_table());
  ASSERT_EQ(tr->blended_junctions(), 1);
  const motion::Stretch& executed = tr->executed_path();
  ASSERT_EQ(tr->followed_path(), &executed);
  cut.trajectories[1] = std::move(tr);
  const MachineSetup m = machine(1);
  PlannedSource s;
  s.prepare({&cut.job, &cut.trajectories, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  bool on_arc = false;
  Eigen::Vector2d tool = a;  // a tool that follows the setpoint exactly, one period behind
  while (!s.move_done()) {
    s.demand(d);
    ASSERT_NE(d.track.path, nullptr);
    const std::size_t k = static_cast<std::size_t>(d.track.path - executed.segments.data());
    ASSERT_LT(k, executed.segments.size()) << "a segment of the executed path";
    if (d.track.path->is_arc()) {
      on_arc = true;
      EXPECT_LT((closest_point(*d.track.path, tool) - tool).norm(), 1e-6);  // the tool is on the blend
    }
    tool = Eigen::Vector2d(d.track.r_mm[0], d.track.r_mm[1]);
    s.advance(tool, {});
  }
  EXPECT_TRUE(on_arc);
}

TEST(PlannedSourcePath, PreviewIsTheTrajectoryOneToEightPeriodsAfterR) {
  const Eigen::Vector2d a(10, 20), b(110, 70);
  test::OneCut c = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                                 std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  const MachineSetup m = machine(2);
  PlannedSource s;
  s.prepare({&c.job, &c.trajectories, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  double t = 0;
  for (int k = 0; k < 200; ++k) {
    s.advance(a, {});
    t += 0.001;
  }
  s.demand(d);
  ASSERT_EQ(d.track.preview_ticks, control::ControllerInput::kMaxPreviewTicks);
  for (int j = 0; j < d.track.preview_ticks; ++j) {
    motion::Setpoint p;
    c.trajectories[1]->sample(t - 2 * 0.001 + (j + 1) * 0.001, p);
    EXPECT_NEAR(d.track.r_preview_mm[j][0], p.position_mm[0], 1e-12) << j;
    EXPECT_NEAR(d.track.r_preview_mm[j][1], p.position_mm[1], 1e-12) << j;
  }
  EXPECT_GT(d.track.r_preview_mm[0][0], d.track.r_mm[0]);  // moving on
}

}  // namespace
}  // namespace machplan::executor
