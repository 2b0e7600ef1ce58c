// The setpoint sources alone: what each demands, period by period.
#include <cmath>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/executor/blu_vector_source.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/planned_source.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

MachineSetup machine(int read_latency, int command_latency) {
  MachineSetup m;
  m.name = "test";
  for (int i = 0; i < hardware::kAxes; ++i) {
    m.signals[i].reading_latency_ticks = read_latency;
    m.signals[i].command_latency_ticks = command_latency;
    m.max_speed_mm_per_s[i] = 100;
  }
  m.max_acceleration_mm_per_s2 = 500;
  m.max_jerk_mm_per_s3 = 20000;
  return m;
}

TEST(PlannedSource, SamplesBehindForFeedbackAndAheadForFeedForward) {
  const Eigen::Vector2d a(10, 20), b(110, 70);
  test::OneCut c = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                                 std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  const MachineSetup m = machine(2, 1);
  PlannedSource s;
  s.prepare({&c.job, &c.trajectories, &m, 0.001}, a);
  Demand d;
  s.demand(d);  // before any move: hold the start
  EXPECT_EQ(d.track.r_mm[0], 10.0);
  EXPECT_EQ(d.track.v_ff_mm_per_s[1], 0.0);
  s.begin_move(1, a);
  const motion::Trajectory& tr = *c.trajectories[1];
  double t = 0.0;  // accumulated as the source does
  for (int k = 1; k <= 300; ++k) {
    s.advance(a, {});
    s.demand(d);
    t += 0.001;
    motion::Setpoint fb, ff;
    tr.sample(t - 2 * 0.001, fb);
    tr.sample(t + (1 + 1) * 0.001, ff);
    ASSERT_EQ(d.track.r_mm[0], fb.position_mm[0]);
    ASSERT_EQ(d.track.v_ff_mm_per_s[1], ff.velocity_mm_per_s[1]);
    ASSERT_EQ(d.track.a_ff_mm_per_s2[0], ff.acceleration_mm_per_s2[0]);
  }
  EXPECT_FALSE(s.move_done());
  while (!s.move_done()) s.advance(a, {});
  s.demand(d);
  EXPECT_NEAR((d.commanded_mm - b).norm(), 0.0, 1e-9);
  EXPECT_EQ(d.track.v_ff_mm_per_s[0], 0.0);
}

TEST(PlannedSource, RefusesAMissingOrMisplacedTrajectory) {
  const Eigen::Vector2d a(10, 20), b(110, 70);
  test::OneCut c = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                                 std::make_unique<test::LineTrajectory>(a + Eigen::Vector2d(1, 0), b, 80, 500));
  const MachineSetup m = machine(1, 1);
  PlannedSource s;
  EXPECT_THROW(s.prepare({&c.job, &c.trajectories, &m, 0.001}, a), InputError);
  c.trajectories[1].reset();
  EXPECT_THROW(s.prepare({&c.job, &c.trajectories, &m, 0.001}, a), InputError);
}

TEST(BluVectorSource, OpenLoopRunsEachVectorForItsTimeAtItsSpeed) {
  // A 10 mm line at 4 mm/s in vectors of 3 mm: four vectors of 2.5 mm, 0.625 s each.
  const Eigen::Vector2d a(0, 0), b(6, 8);
  test::OneCut c = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 4, true), nullptr);
  const MachineSetup m = machine(1, 1);
  BluVectorOptions o;
  o.blu_mm = 3;
  o.calibration_factor = 1.5;
  BluVectorSource s(o);
  s.prepare({&c.job, nullptr, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  double t = 0, travelled = 0;
  int zero_ticks = 0;
  while (!s.move_done() && t < 10) {
    s.advance(a, {});
    s.demand(d);
    ASSERT_EQ(d.kind, Demand::Kind::speed);
    if (d.speed_mm_per_s.norm() == 0) ++zero_ticks;
    else EXPECT_NEAR(d.speed_mm_per_s.norm(), 6.0, 1e-9);  // 1.5 x 4 mm/s along the line
    travelled += d.speed_mm_per_s.norm() * 0.001;
    t += 0.001;
  }
  EXPECT_NEAR(travelled, 1.5 * 10, 0.01);  // calibration x programmed length
  EXPECT_NEAR(t, 2.5 + 0.002 + 0.1, 0.003);  // vectors, zero-first + start, settle
  EXPECT_GE(zero_ticks, 100);
}

TEST(BluVectorSource, ClosedLoopReaimsFromTheMeasuredPositionAfterTheComputation) {
  const Eigen::Vector2d a(0, 0), b(9, 0);
  test::OneCut c = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 4, true), nullptr);
  const MachineSetup m = machine(1, 1);
  BluVectorOptions o;
  o.closed_loop = true;
  o.blu_mm = 3;
  o.compute_s = 0.2;
  BluVectorSource s(o);
  s.prepare({&c.job, nullptr, &m, 0.001}, a);
  s.begin_move(1, a);
  Demand d;
  // The machine lags 1 mm in Y (a disturbance) when the first vector ends.
  const Eigen::Vector2d measured(3.0, -1.0);
  for (int k = 0; k < 2 + 750; ++k) s.advance(k < 2 ? a : measured, {});  // zero-first, start, first vector
  s.demand(d);
  const Eigen::Vector2d during = d.speed_mm_per_s;
  EXPECT_NEAR(during.y(), 0.0, 1e-12);  // the old command runs on during the computation
  for (int k = 0; k < 210; ++k) s.advance(measured, {});
  s.demand(d);
  EXPECT_GT(d.speed_mm_per_s.y(), 0.0);  // re-aimed toward (6, 0) from (3, -1)
  EXPECT_NEAR(d.speed_mm_per_s.normalized().dot(Eigen::Vector2d(3, 1).normalized()), 1.0, 1e-9);
}

TEST(JogSource, FollowsTheStickWithinSpeedAccelerationAndJerk) {
  const MachineSetup m = machine(1, 1);
  motion::Job empty;
  JogOptions o;
  o.speed_mm_per_s = 30;
  JogSource s(o);
  s.prepare({&empty, nullptr, &m, 0.001}, {100, 100});
  hardware::OperatorInputs op;
  Demand d;
  double v_prev = 0, a_prev = 0, vmax = 0;
  for (int k = 0; k < 3000; ++k) {
    op.jog = {k < 1000 ? 1.0 : (k < 2000 ? -0.5 : 0.0), 0.0};
    s.advance({}, op);
    s.demand(d);
    const double v = s.velocity_mm_per_s().x(), a = s.acceleration_mm_per_s2().x();
    EXPECT_LE(std::abs(a), 500 + 1e-9);
    EXPECT_LE(std::abs(a - a_prev), 20000 * 0.001 + 1e-9) << k;
    EXPECT_NEAR(v - v_prev, a * 0.001, 1e-9);
    vmax = std::max(vmax, std::abs(v));
    v_prev = v, a_prev = a;
    if (k == 999) { EXPECT_NEAR(v, 30, 1e-6); }
    if (k == 1999) { EXPECT_NEAR(v, -15, 1e-6); }
  }
  EXPECT_LE(vmax, 30 + 1e-6);  // no overshoot past the stick's speed
  EXPECT_EQ(s.velocity_mm_per_s().x(), 0.0);
  EXPECT_EQ(s.velocity_mm_per_s().y(), 0.0);
  EXPECT_EQ(d.kind, Demand::Kind::track);
  // Moved: 1 s forward at up to 30, 1 s back at up to 15, then stop.
  EXPECT_GT(d.commanded_mm.x(), 100 + 10);
  EXPECT_LT(d.commanded_mm.x(), 100 + 30);
  EXPECT_DOUBLE_EQ(d.commanded_mm.y(), 100);
}

TEST(JogSource, NonFiniteStickReadsAsCentred) {
  const MachineSetup m = machine(1, 1);
  motion::Job empty;
  JogSource s;
  s.prepare({&empty, nullptr, &m, 0.001}, {0, 0});
  hardware::OperatorInputs op;
  op.jog = {std::nan(""), std::numeric_limits<double>::infinity()};
  for (int k = 0; k < 100; ++k) s.advance({}, op);
  EXPECT_EQ(s.velocity_mm_per_s().x(), 0.0);
  EXPECT_EQ(s.velocity_mm_per_s().y(), 0.0);
}

}  // namespace
}  // namespace machplan::executor
