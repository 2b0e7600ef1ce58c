// The 5-axis feed planner (engine/motion/axis_planner.h): closed forms, the effect of the
// rotary axes' lever on the linear ones, the limits on a sampled plan, and the velocity-only
// time as a lower bound.
#include "engine/motion/axis_planner.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

constexpr double kDegRad = std::numbers::pi / 180.0;

AxisLimits vmc_limits() {
  AxisLimits l;
  l.velocity = five_axis(250, 250, 250, 90 * kDegRad, 180 * kDegRad);
  l.rapid_velocity = five_axis(500, 500, 500, 150 * kDegRad, 300 * kDegRad);
  l.acceleration = five_axis(3000, 3000, 3000, 600 * kDegRad, 1200 * kDegRad);
  l.jerk = five_axis(50000, 50000, 50000, 6000 * kDegRad, 12000 * kDegRad);
  return l;
}

JointMove move_to(double x, double y, double z, double a, double c, double tip, double feed) {
  JointMove m;
  m.end = five_axis(x, y, z, a, c);
  m.tip_mm = tip;
  m.feed_mm_per_s = feed;
  return m;
}

TEST(AxisPlanner, OneLongMoveTakesTheSCurveTrapezoidsTime) {
  const AxisLimits l = vmc_limits();
  const double a = 3000, j = 50000, length = 400;
  // Feed 100 mm/s: a speed change of 100 <= a^2 / j = 180 is a triangular-acceleration pulse
  // of 2 sqrt(dv / j); 200 mm/s is trapezoidal, dv / a + a / j. Both pulses cover (dv / 2) T, so
  // the move takes length / F + T.
  for (const double feed : {100.0, 200.0}) {
    const double pulse = feed <= a * a / j ? 2 * std::sqrt(feed / j) : feed / a + a / j;
    const JointPlan p = plan_joint_moves(JointVector::Zero(), {move_to(length, 0, 0, 0, 0, length, feed)}, l);
    EXPECT_NEAR(p.duration_s(), length / feed + pulse, 1e-9) << feed;
    EXPECT_NEAR(p.velocity_only_s(), length / feed, 1e-12);
  }
  // A rapid along the diagonal of X and Y runs at rapid speed on both: the path speed is
  // sqrt(2) 500, and the path acceleration and jerk sqrt(2) times an axis's.
  const double d = 300, len = d * std::sqrt(2.0);
  const JointPlan r = plan_joint_moves(JointVector::Zero(), {move_to(d, d, 0, 0, 0, len, 0)}, l);
  const double v = 500 * std::sqrt(2.0), aa = a * std::sqrt(2.0), jj = j * std::sqrt(2.0);
  EXPECT_NEAR(r.duration_s(), len / v + v / aa + aa / jj, 1e-9);
}

// A pocket's circular wall of radius 20 mm around `centre` (workpiece coordinates, on the table
// at C = 0), cut with the tool leaning out of the wall so that the table turns with it: at
// the wall's angle phi the table is at C = phi and the linear axes follow the wall's point
// turned by C. The tip's path relative to the workpiece is the same wherever the pocket is.
std::vector<JointMove> turning_wall(double cx, double cy, double feed) {
  std::vector<JointMove> moves;
  const double r = 20, step = 1.0 * kDegRad;
  for (int k = 1; k <= 360; ++k) {
    const double phi = k * step, c = phi;
    const double px = cx + r * std::cos(phi), py = cy + r * std::sin(phi);
    // The point p turned by -C about the table's axis lands where the spindle must be.
    const double x = std::cos(-c) * px - std::sin(-c) * py, y = std::sin(-c) * px + std::cos(-c) * py;
    moves.push_back(move_to(x, y, 0, 20 * kDegRad, c, r * step, feed));
  }
  return moves;
}

JointVector wall_start(double cx, double cy) {
  JointVector q;
  q = five_axis(cx + 20, cy, 0, 20 * kDegRad, 0);
  return q;
}

TEST(AxisPlanner, TheSameCutFarFromTheRotaryAxisIsSlowerThanNearIt) {
  const AxisLimits l = vmc_limits();
  const double feed = 2000.0 / 60.0;
  const JointPlan near = plan_joint_moves(wall_start(0, 0), turning_wall(0, 0, feed), l);
  const JointPlan far = plan_joint_moves(wall_start(200, 0), turning_wall(200, 0, feed), l);
  // Near the axis the linear axes move with the wall (20 mm from it); 200 mm away every degree
  // of C drags them 3.5 mm and their speed, not the feed, sets the pace.
  EXPECT_GT(far.duration_s(), 1.2 * near.duration_s());
  EXPECT_GE(near.duration_s(), near.velocity_only_s());
  EXPECT_GE(far.duration_s(), far.velocity_only_s());
}

// A path that mixes everything: a rapid in, a zigzag of feed moves, a wall with the table
// turning, a pure reorientation, random 5-axis moves, a rapid out.
std::vector<JointMove> mixed_path(JointVector& start) {
  start = JointVector::Zero();
  std::vector<JointMove> m;
  m.push_back(move_to(50, 40, -30, 0, 0, std::sqrt(50 * 50 + 40 * 40 + 30 * 30.0), 0));
  for (int k = 1; k <= 20; ++k) m.push_back(move_to(50 + 2 * k, 40 + (k % 2) * 3, -30, 0, 0, std::hypot(2.0, 3.0), 30));
  const JointVector here = m.back().end;
  for (const JointMove& w : turning_wall(here.x() - 20, here.y(), 40)) {
    JointMove c = w;
    c.end.z() = -30;
    m.push_back(c);
  }
  JointMove turn = m.back();
  turn.end[3] += 30 * kDegRad;
  turn.tip_mm = 0;
  m.push_back(turn);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  JointVector q = turn.end;
  for (int k = 0; k < 200; ++k) {
    JointVector d;
    d = five_axis(2 * u(rng), 2 * u(rng), 0.5 * u(rng), 2 * kDegRad * u(rng), 5 * kDegRad * u(rng));
    q += d;
    JointMove mv;
    mv.end = q;
    mv.tip_mm = d.head<3>().norm() + 0.1;
    mv.feed_mm_per_s = 25;
    m.push_back(mv);
  }
  m.push_back(move_to(0, 0, 0, 0, 0, 80, 0));
  return m;
}

TEST(AxisPlanner, ASampledPlanKeepsEveryAxisWithinItsLimits) {
  const AxisLimits l = vmc_limits();
  JointVector start;
  const std::vector<JointMove> path = mixed_path(start);
  const JointPlan p = plan_joint_moves(start, path, l);
  ASSERT_GT(p.duration_s(), 0.0);
  const auto& mv = p.moves();
  // Per move: the speed, acceleration and jerk (between two samples in the same move) of every
  // axis inside it.
  const double dt = 2e-4;
  double worst_v = 0, worst_a = 0, worst_j = 0;
  std::size_t k = 0, k_before = 0;
  JointState before;
  for (double t = 0; t <= p.duration_s(); t += dt) {
    const ProfileState s = p.path_state(t);
    const JointState q = p.sample(t);
    while (k + 1 < mv.size() && mv[k + 1].s0 <= s.s) ++k;
    const bool rapid = k == 0 || k + 1 == mv.size();
    for (int a = 0; a < kJointAxes; ++a) {
      const double vmax = rapid ? l.rapid_velocity[a] : l.velocity[a];
      worst_v = std::max(worst_v, std::abs(q.velocity[a]) / vmax);
      worst_a = std::max(worst_a, std::abs(q.acceleration[a]) / l.acceleration[a]);
      if (t > 0 && k == k_before)
        worst_j = std::max(worst_j, std::abs(q.acceleration[a] - before.acceleration[a]) / dt / l.jerk[a]);
    }
    before = q;
    k_before = k;
  }
  EXPECT_LE(worst_v, 1.0 + 1e-9);
  EXPECT_LE(worst_a, 1.0 + 1e-9);
  EXPECT_LE(worst_j, 1.0 + 1e-6);
  EXPECT_GT(worst_v, 0.5);  // the limits are reached, not idle
  EXPECT_GT(worst_a, 0.5);
  // Per corner: the jump of each axis's velocity spread over a blend L_b long, at the speed
  // the plan passes the corner with, needs at most the axis's acceleration, where L_b is at
  // most the shorter leg and keeps the blend within the corner tolerance (computed here from
  // the file comment, not by the planner's own function).
  const JointVector tol = five_axis(0.01, 0.01, 0.01, 0.0002, 0.0002);
  int corners = 0;
  double t = 0;
  for (std::size_t k = 0; k + 1 < mv.size(); ++k) {
    // The time the path reaches the corner, by bisection on the monotone path length.
    double lo = t, hi = p.duration_s();
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      (p.path_state(mid).s < mv[k + 1].s0 ? lo : hi) = mid;
    }
    t = lo;
    const double v = p.path_state(hi).v;
    const JointVector du = (mv[k + 1].rate - mv[k].rate).cwiseAbs();
    if (du.maxCoeff() < 1e-9) continue;
    double blend = std::min(mv[k].length, mv[k + 1].length);
    for (int a = 0; a < kJointAxes; ++a)
      if (du[a] > 0) blend = std::min(blend, 8 * tol[a] / du[a]);
    for (int a = 0; a < kJointAxes; ++a)
      EXPECT_LE(v * v * du[a] / blend, l.acceleration[a] * (1 + 1e-6)) << "corner " << k << " axis " << a;
    ++corners;
  }
  EXPECT_GT(corners, 100);
  EXPECT_GE(p.duration_s(), p.velocity_only_s());
}

TEST(AxisPlanner, TheVelocityOnlyTimeIsALowerBoundAndStaysBelowThePlannedOne) {
  const AxisLimits l = vmc_limits();
  for (const double cx : {0.0, 40.0, 80.0, 160.0}) {
    const JointPlan p = plan_joint_moves(wall_start(cx, 10), turning_wall(cx, 10, 30), l);
    // The velocity-only time: each move at its speed cap (feed, axis speeds).
    double vel = 0;
    JointVector q = wall_start(cx, 10);
    for (const JointMove& m : turning_wall(cx, 10, 30)) {
      const JointVector d = (m.end - q).cwiseAbs();
      double t = m.tip_mm / 30;
      for (int a = 0; a < kJointAxes; ++a) t = std::max(t, d[a] / l.velocity[a]);
      vel += t;
      q = m.end;
    }
    EXPECT_NEAR(p.velocity_only_s(), vel, 1e-9 * vel);
    EXPECT_GE(p.duration_s(), vel) << cx;
  }
}

TEST(AxisPlanner, TheFeedCapsTheTipOrTheAxesCombinedSpeed) {
  AxisLimits tip = vmc_limits(), axes = vmc_limits();
  axes.feed = AxisLimits::Feed::axes;
  const double feed = 20, a = 1200 * kDegRad, j = 12000 * kDegRad;
  // A pure turn of the table by 90 deg: with the feed on the tip it has no feed cap and runs at
  // C's own 180 deg/s; read on the axes, 90 "mm" of degrees at 20 mm/s. Both are one long move
  // from rest to rest: length / speed + the S-curve pulse (as in the first test).
  const auto pulse = [&](double dv) { return dv <= a * a / j ? 2 * std::sqrt(dv / j) : dv / a + a / j; };
  const JointVector start = JointVector::Zero();
  const std::vector<JointMove> turn = {move_to(0, 0, 0, 0, 90 * kDegRad, 0, feed)};
  const double v_tip = 180 * kDegRad, v_axes = feed * kDegRad;  // rad/s
  EXPECT_NEAR(plan_joint_moves(start, turn, tip).duration_s(), 90 * kDegRad / v_tip + pulse(v_tip), 1e-9);
  EXPECT_NEAR(plan_joint_moves(start, turn, axes).duration_s(), 90 * kDegRad / v_axes + pulse(v_axes), 1e-9);
  // A straight cut along X: the same either way.
  const std::vector<JointMove> cut = {move_to(100, 0, 0, 0, 0, 100, feed)};
  EXPECT_NEAR(plan_joint_moves(start, cut, tip).duration_s(), plan_joint_moves(start, cut, axes).duration_s(), 1e-12);
  // A cut far from the table's axis while it turns: on the axes the linear axes' travel counts,
  // so the same tip path takes longer far from the axis than near it.
  EXPECT_GT(plan_joint_moves(wall_start(150, 0), turning_wall(150, 0, feed), axes).duration_s(),
            1.5 * plan_joint_moves(wall_start(0, 0), turning_wall(0, 0, feed), axes).duration_s());
}

TEST(AxisPlanner, ABadLimitIsRefusedByName) {
  AxisLimits l = vmc_limits();
  l.acceleration[4] = 0;
  EXPECT_THAT(test::error_of([&] { plan_joint_moves(JointVector::Zero(), {}, l); }),
              testing::HasSubstr("acceleration.rotary 2"));
  l = vmc_limits();
  l.jerk[0] = std::nan("");
  EXPECT_THAT(test::error_of([&] { l.validate(); }), testing::HasSubstr("jerk.x"));
}

// A hexapod: six linear sliders and no rotary axis. A move where the tip stands still and the
// tool turns is measured by the turn, and every slider keeps its own limits.
TEST(AxisPlanner, SixLinearSlidersAreTimedByTheirOwnLimitsAndATurnByItsAngle) {
  AxisLimits l;
  l.names = {"slider 1", "slider 2", "slider 3", "slider 4", "slider 5", "slider 6"};
  l.rotary_axes = 0;
  l.velocity.setConstant(500);
  l.rapid_velocity.setConstant(1000);
  l.acceleration.setConstant(5000);
  l.jerk.setConstant(1e9);
  JointMove turn;
  turn.end << 0, 0, 0, 0, 0, 80;  // slider 6 moves 80 mm ...
  turn.turn_rad = 0.2;            // ... while the tool turns 0.2 rad about its tip
  turn.feed_mm_per_s = 30;        // no feed cap: the tip stands still
  const JointPlan p = plan_joint_moves(JointVector::Zero(), {turn}, l);
  ASSERT_EQ(p.moves().size(), 1u);
  EXPECT_DOUBLE_EQ(p.length(), 0.2);
  EXPECT_NEAR(p.moves()[0].rate[5], 400.0, 1e-9);
  // Rest to rest over 80 mm at 5000 mm/s^2 and 500 mm/s: 0.1 s to speed and back (25 mm each),
  // 30 mm at speed.
  EXPECT_NEAR(p.duration_s(), 0.2 + 30.0 / 500.0, 1e-3);
  // Feed on the axes counts the sliders' combined speed, all linear.
  l.feed = AxisLimits::Feed::axes;
  JointMove cut;
  cut.end << 30, 40, 0, 0, 0, 0;  // 50 mm of the sliders' combined travel for 10 mm of tip path
  cut.tip_mm = 10;
  cut.feed_mm_per_s = 25;
  EXPECT_NEAR(plan_joint_moves(JointVector::Zero(), {cut}, l).velocity_only_s(), 50.0 / 25.0, 1e-9);
  l.velocity[5] = -1;
  EXPECT_THAT(test::error_of([&] { l.validate(); }), testing::HasSubstr("velocity.slider 6"));
}

}  // namespace
}  // namespace machplan::motion
