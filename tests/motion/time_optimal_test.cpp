// Time-optimal path parameterisation (engine/motion/time_optimal.h) against closed forms: a
// line (the bang-bang trapezoid, on and off the axes), a circle held at the speed the
// per-axis acceleration allows, a corner blend; and against the planner and the bound.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/common/internal/numbers.h"
#include "engine/geometry/contour.h"
#include "engine/motion/feed_planner.h"
#include "engine/motion/time_optimal.h"
#include "tests/support/stretches.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

Stretch stretch_of(const std::vector<Segment>& segs, double feed) { return test::make_stretch(segs, feed, true, false, 1); }

PlannerOptions limits(double v, double a) {
  PlannerOptions o;
  o.max_velocity_mm_per_s = Vector2d(v, v);
  o.max_acceleration_mm_per_s2 = Vector2d(a, a);
  return o;
}

// Rest-to-rest along a line of length L with speed cap v and acceleration a.
double trapezoid_s(double L, double v, double a) {
  if (L >= v * v / a) return L / v + v / a;
  return 2.0 * std::sqrt(L / a);
}

// Speed up from rest to at most v, then down to w <= v, over L (one axis-parallel line).
double up_down_s(double L, double v, double a, double w) {
  const double d_up = v * v / (2 * a), d_down = (v * v - w * w) / (2 * a);
  if (d_up + d_down <= L) return v / a + (L - d_up - d_down) / v + (v - w) / a;
  const double peak = std::sqrt(a * L + w * w / 2);  // peak^2 / 2a + (peak^2 - w^2) / 2a = L
  return peak / a + (peak - w) / a;
}

TEST(TimeOptimal, LineIsTheTrapezoidOnAndOffTheAxes) {
  const PlannerOptions o = limits(81.8, 500);
  // Along x: the feed and 500 mm/s^2.
  EXPECT_NEAR(time_optimal_s(stretch_of({make_segment({0, 0}, {100, 0}, 0)}, 80), o), trapezoid_s(100, 80, 500), 1e-12);
  // Short: a triangle profile.
  EXPECT_NEAR(time_optimal_s(stretch_of({make_segment({0, 0}, {5, 0}, 0)}, 80), o), trapezoid_s(5, 80, 500), 1e-12);
  // At 45 degrees both axes work: the path gets sqrt(2) times the acceleration (a box, not a
  // circle), and the speed up to sqrt(2) times an axis' limit when the feed allows.
  const double d = 100 / std::sqrt(2.0);
  EXPECT_NEAR(time_optimal_s(stretch_of({make_segment({0, 0}, {d, d}, 0)}, 80), o),
              trapezoid_s(100, 80, 500 * std::sqrt(2.0)), 1e-12);
  EXPECT_NEAR(time_optimal_s(stretch_of({make_segment({0, 0}, {d, d}, 0)}, 1000), o),
              trapezoid_s(100, 81.8 * std::sqrt(2.0), 500 * std::sqrt(2.0)), 1e-12);
  // Two collinear lines are one line; a corner is a stop.
  const Stretch two = stretch_of({make_segment({0, 0}, {40, 0}, 0), make_segment({40, 0}, {100, 0}, 0)}, 80);
  EXPECT_NEAR(time_optimal_s(two, o), trapezoid_s(100, 80, 500), 1e-9);
  const Stretch corner = stretch_of({make_segment({0, 0}, {50, 0}, 0), make_segment({50, 0}, {50, 50}, 0)}, 80);
  EXPECT_NEAR(time_optimal_s(corner, o), 2 * trapezoid_s(50, 80, 500), 1e-9);
}

// N full turns of a circle of radius r, counter-clockwise from angle 0.
Stretch turns(int n, double r, double feed) {
  std::vector<Segment> segs;
  for (int k = 0; k < n; ++k)
    for (const Segment& g : Contour::circle({0, 0}, r).segments()) segs.push_back(g);
  return stretch_of(segs, feed);
}

TEST(TimeOptimal, CircleAtTheSpeedThePerAxisAccelerationAllows) {
  // Where the tangent is along one axis, the other axis carries the whole normal acceleration
  // v^2 / r, so no constant speed above sqrt(a r) is possible; at that speed every point is
  // within the box. With the feed at sqrt(a r), each extra turn takes exactly 2 pi r / v.
  const double r = 20, a = 500, v = std::sqrt(a * r);
  const PlannerOptions o = limits(1000, a);
  const double t2 = time_optimal_s(turns(2, r, v), o), t4 = time_optimal_s(turns(4, r, v), o);
  EXPECT_NEAR((t4 - t2) / 2, 2 * kPi * r / v, 1e-6 * (2 * kPi * r / v));
  // Rest to rest, one turn at least takes the turn at that speed plus speeding up and down.
  EXPECT_GT(time_optimal_s(turns(1, r, v), o), 2 * kPi * r / v + v / (2 * a));

  // Without the feed cap the box lets the tool go faster between the axis points, where the
  // normal acceleration is shared by both axes (up to sqrt(sqrt(2) a r) at 45 degrees), so a
  // turn is faster than at sqrt(a r) (what a circular limit would give) and slower than at
  // the 45-degree speed everywhere.
  const double t2f = time_optimal_s(turns(2, r, 1e4), o), t4f = time_optimal_s(turns(4, r, 1e4), o);
  const double per_turn = (t4f - t2f) / 2;
  EXPECT_LT(per_turn, 0.99 * 2 * kPi * r / v);
  EXPECT_GT(per_turn, 2 * kPi * r / std::sqrt(std::sqrt(2.0) * a * r));
}

TEST(TimeOptimal, CornerBlendBetweenTheClosedFormsOfItsParts) {
  // +x for 100 mm, a quarter circle of radius 1 mm turning left, +y for 100 mm. At the arc's
  // ends the normal is along one axis, so the speed there is at most sqrt(a r); inside the
  // arc it is at most sqrt(sqrt(2) a r). The lines are closed forms (up to that speed and
  // away from it); the arc takes between its length over those two speeds.
  const double a = 500, r = 1, w = std::sqrt(a * r);
  const PlannerOptions o = limits(81.8, a);
  std::vector<Segment> segs{make_segment({0, 0}, {100, 0}, 0)};
  Segment arc = make_segment({100, 0}, {101, 1}, std::tan(kPi / 8));
  segs.push_back(arc);
  segs.push_back(make_segment({101, 1}, {101, 101}, 0));
  ASSERT_NEAR(arc.radius, r, 1e-12);
  const double lines = 2 * up_down_s(100, 80, a, w);
  const double arc_len = kPi / 2 * r;
  const double t = time_optimal_s(stretch_of(segs, 80), o);
  EXPECT_GE(t, lines + arc_len / std::sqrt(std::sqrt(2.0) * a * r));
  EXPECT_LE(t, lines + arc_len / w + 1e-9);
}

TEST(TimeOptimal, ConvergesWithTheGridAndSitsBetweenBoundAndPlanner) {
  // A rounded slot: lines and arcs of several radii, tangent and not.
  std::vector<Segment> segs;
  segs.push_back(make_segment({0, 0}, {40, 0}, 0));
  segs.push_back(make_segment({40, 0}, {40, 20}, 1.0));  // half circle r 10
  segs.push_back(make_segment({40, 20}, {0, 20}, 0));
  segs.push_back(make_segment({0, 20}, {0, 0}, 0.4));    // a shallow arc, corners at both ends
  const Stretch st = stretch_of(segs, 80);
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  const auto plan = plan_stretch_detailed(st, o);
  const Stretch& path = plan->executed_path();
  TimeOptimalOptions coarse, fine;
  fine.max_step_mm = coarse.max_step_mm / 4;
  fine.max_step_rad = coarse.max_step_rad / 4;
  const double t = time_optimal_s(path, o, coarse), tf = time_optimal_s(path, o, fine);
  EXPECT_NEAR(t, tf, 1e-3 * tf);
  EXPECT_GE(t, time_lower_bound_s(path, o) - 1e-9);
  EXPECT_LE(t, plan->duration_s());

  const TimeOptimalProfile p = time_optimal_profile(path, o);
  ASSERT_EQ(p.s_mm.size(), p.v_mm_per_s.size());
  EXPECT_EQ(p.v_mm_per_s.front(), 0.0);
  EXPECT_EQ(p.v_mm_per_s.back(), 0.0);
  EXPECT_NEAR(p.length_mm, plan->length_mm(), 1e-9);
  for (std::size_t k = 0; k < p.s_mm.size(); ++k) EXPECT_LE(p.v_mm_per_s[k], 80.0 + 1e-9);
}

TEST(TimeOptimal, BadInputIsRefused) {
  const Stretch st = stretch_of({make_segment({0, 0}, {10, 0}, 0)}, 80);
  TimeOptimalOptions bad;
  bad.max_step_mm = 0;
  EXPECT_THROW(time_optimal_s(st, PlannerOptions{}, bad), InputError);
  Stretch empty;
  EXPECT_THROW(time_optimal_s(empty, PlannerOptions{}), InternalError);  // a malformed stretch: a bug
  Stretch zero_feed = st;
  zero_feed.feed_mm_per_s[0] = 0;
  EXPECT_THROW(time_optimal_s(zero_feed, PlannerOptions{}), InternalError);
}

}  // namespace
}  // namespace machplan::motion
