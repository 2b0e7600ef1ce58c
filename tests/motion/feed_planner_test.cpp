// Feed planner: limits, rest-to-rest ends, path tolerance, look-ahead through short segments,
// the time lower bound (analytic cases and planner >= bound) and determinism.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/common/internal/numbers.h"
#include "engine/geometry/contour.h"
#include "engine/motion/feed_planner.h"
#include "engine/motion/interpolator.h"
#include "tests/support/stretches.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
using ::testing::HasSubstr;
constexpr double kT = 0.001;  // servo period

Segment line(Vector2d a, Vector2d b) { return make_segment(a, b, 0.0); }
Stretch stretch_of(const std::vector<Segment>& segs, double feed) { return test::make_stretch(segs, feed, true, false, 1); }
Stretch polyline(const std::vector<Vector2d>& pts, double feed) {
  return stretch_of(test::polyline_segments(pts, false), feed);
}

// The shapes of the issue, cut at 80 mm/s.
Stretch square() { return polyline({{0, 0}, {100, 0}, {100, 100}, {0, 100}, {0, 0}}, 80); }
Stretch triangle45() { return polyline({{0, 0}, {100, 0}, {100, 100}, {0, 0}}, 80); }
Stretch circle() { return stretch_of(Contour::circle({0, 0}, 50).segments(), 80); }
Stretch polygon200() {
  const double r = 0.25 / std::sin(kPi / 200);  // 0.5 mm sides
  std::vector<Vector2d> pts;
  for (int k = 0; k <= 200; ++k) pts.emplace_back(r * std::cos(2 * kPi * k / 200), r * std::sin(2 * kPi * k / 200));
  return polyline(pts, 80);
}
// A 60 x 30 rectangle with 5 mm corner radii: lines and arcs meeting tangentially.
Stretch rounded_rectangle() {
  const Contour c({{5, 0}, {55, 0}, {60, 5}, {60, 25}, {55, 30}, {5, 30}, {0, 25}, {0, 5}},
                  {0, std::tan(kPi / 8), 0, std::tan(kPi / 8), 0, std::tan(kPi / 8), 0, std::tan(kPi / 8)});
  return stretch_of(c.segments(), 80);
}
// Lines meeting arcs at corners (non-tangent junctions with arcs: the biarc blends).
Stretch slot_with_corners() {
  std::vector<Segment> s;
  s.push_back(line({0, 0}, {40, 0}));
  s.push_back(make_segment({40, 0}, {40, 20}, 0.6));  // bulging arc, not tangent to the lines
  s.push_back(line({40, 20}, {0, 20}));
  s.push_back(make_segment({0, 20}, {0, 0}, -0.3));
  return stretch_of(s, 80);
}

double distance_to_path(const Stretch& st, const Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : st.segments) best = std::min(best, (closest_point(s, p) - p).norm());
  return best;
}

struct Check {
  double max_speed = 0, min_speed_mid = 1e300, max_dev = 0;
  Vector2d max_v = Vector2d::Zero(), max_a = Vector2d::Zero(), max_a_fd = Vector2d::Zero();
};

// Samples the trajectory at the servo period and checks the contract; returns the figures.
Check check_trajectory(const Stretch& st, const PlannedTrajectory& tr, const PlannerOptions& o,
                       double mid_margin_s = 0.0) {
  Check c;
  const double d = tr.duration_s();
  EXPECT_GT(d, 0.0);
  Setpoint sp, prev, prev2;
  tr.sample(0.0, sp);
  EXPECT_LT((sp.position_mm - st.segments.front().start).norm(), 1e-9);
  EXPECT_EQ(sp.velocity_mm_per_s.norm(), 0.0);
  tr.sample(d, sp);
  EXPECT_LT((sp.position_mm - st.segments.back().end).norm(), 1e-9);
  EXPECT_EQ(sp.velocity_mm_per_s.norm(), 0.0);
  EXPECT_EQ(sp.acceleration_mm_per_s2.norm(), 0.0);
  tr.sample(d + 5.0, prev);
  EXPECT_EQ(prev.position_mm, sp.position_mm);
  tr.sample(-1.0, prev);
  EXPECT_LT((prev.position_mm - st.segments.front().start).norm(), 1e-9);

  const int n = static_cast<int>(std::ceil(d / kT));
  for (int k = 0; k <= n; ++k) {
    const double t = std::min(k * kT, d);
    tr.sample(t, sp);
    c.max_v = c.max_v.cwiseMax(sp.velocity_mm_per_s.cwiseAbs());
    c.max_a = c.max_a.cwiseMax(sp.acceleration_mm_per_s2.cwiseAbs());
    c.max_speed = std::max(c.max_speed, sp.velocity_mm_per_s.norm());
    if (t >= mid_margin_s && t <= d - mid_margin_s) c.min_speed_mid = std::min(c.min_speed_mid, sp.velocity_mm_per_s.norm());
    c.max_dev = std::max(c.max_dev, distance_to_path(st, sp.position_mm));
    if (k >= 2 && k < n) {  // finite differences on the regular grid
      c.max_a_fd = c.max_a_fd.cwiseMax(((sp.position_mm - 2 * prev.position_mm + prev2.position_mm) / (kT * kT)).cwiseAbs());
      const Vector2d v_fd = (sp.position_mm - prev.position_mm) / kT;
      EXPECT_LE(std::abs(v_fd.x()), o.max_velocity_mm_per_s.x() * (1 + 1e-9)) << "t=" << t;
      EXPECT_LE(std::abs(v_fd.y()), o.max_velocity_mm_per_s.y() * (1 + 1e-9)) << "t=" << t;
    }
    prev2 = prev;
    prev = sp;
  }
  for (int i = 0; i < 2; ++i) {
    EXPECT_LE(c.max_v[i], o.max_velocity_mm_per_s[i] * (1 + 1e-9));
    EXPECT_LE(c.max_a[i], o.max_acceleration_mm_per_s2[i] * (1 + 1e-6));
    // Second differences average the acceleration over two periods: same limit, small slack.
    EXPECT_LE(c.max_a_fd[i], o.max_acceleration_mm_per_s2[i] * 1.01 + 1.0);
  }
  EXPECT_LE(c.max_speed, *std::max_element(st.feed_mm_per_s.begin(), st.feed_mm_per_s.end()) * (1 + 1e-9));
  EXPECT_LE(tr.max_deviation_mm(), o.path_tolerance_mm);
  EXPECT_LE(c.max_dev, tr.max_deviation_mm() + 1e-9);
  return c;
}

double ratio_and_report(const char* name, const Stretch& st, const PlannedTrajectory& tr, const PlannerOptions& o) {
  const double bound_exec = time_lower_bound_s(tr.executed_path(), o);
  const double bound_prog = time_lower_bound_s(st, o);
  const double r = tr.duration_s() / bound_exec;
  std::printf("[ ratio    ] %-18s duration %.4f s, bound (executed path) %.4f s, ratio %.4f; "
              "bound (programmed path, stops at corners) %.4f s, ratio %.4f; %d blends, dev %.4f mm\n",
              name, tr.duration_s(), bound_exec, r, bound_prog, tr.duration_s() / bound_prog, tr.blended_junctions(),
              tr.max_deviation_mm());
  EXPECT_GE(tr.duration_s(), bound_exec * (1 - 1e-9)) << name;
  return r;
}

TEST(FeedPlanner, ShapesRespectLimitsToleranceAndStayNearTheBound) {
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  // The shapes must come within 10 % of the bound.
  const std::vector<std::pair<const char*, Stretch>> shapes = {
      {"square", square()}, {"circle r50", circle()}, {"polygon 200x0.5", polygon200()}, {"triangle 45deg", triangle45()}};
  for (const auto& [name, st] : shapes) {
    SCOPED_TRACE(name);
    const auto tr = plan_stretch_detailed(st, o);
    check_trajectory(st, *tr, o);
    EXPECT_LE(ratio_and_report(name, st, *tr, o), 1.10);
  }
  // Shapes with small programmed arcs: the planner keeps v^2/r <= 0.8 a (room for speed
  // changes) where the bound allows the full per-direction normal acceleration and ignores
  // its share of the tangential budget, so the measured gap is wider; pin it at 15 %.
  const std::vector<std::pair<const char*, Stretch>> arcs = {{"rounded rectangle", rounded_rectangle()},
                                                             {"slot with corners", slot_with_corners()}};
  for (const auto& [name, st] : arcs) {
    SCOPED_TRACE(name);
    const auto tr = plan_stretch_detailed(st, o);
    check_trajectory(st, *tr, o);
    EXPECT_LE(ratio_and_report(name, st, *tr, o), 1.15);
  }
}

TEST(FeedPlanner, XyTableLimitsHoldToo) {
  const PlannerOptions o = PlannerOptions::xy_table();
  Stretch st = polyline({{0, 0}, {300, 0}, {300, 250}, {0, 250}, {0, 0}}, 1000);
  const auto tr = plan_stretch_detailed(st, o);
  check_trajectory(st, *tr, o);
  EXPECT_LE(ratio_and_report("xy table rect", st, *tr, o), 1.10);
}

// The limits are per axis (a box): a diagonal gets sqrt(2) times an axis' acceleration and
// jerk along the path, and an arc away from the axes more normal acceleration than one
// through them, while every axis stays within its own limits.
TEST(FeedPlanner, PerAxisLimitsAreABox) {
  PlannerOptions o = PlannerOptions::thermal_gantry();
  const double a = o.max_acceleration_mm_per_s2.x(), j = o.max_jerk_mm_per_s3;
  const Stretch diag = polyline({{0, 0}, {200, 200}}, 80);
  const auto tr = plan_stretch_detailed(diag, o);
  const Check c = check_trajectory(diag, *tr, o);
  double path_a = 0, path_j = 0;
  for (const ProfilePhase& p : tr->profile()) {
    path_a = std::max(path_a, std::abs(p.a0_mm_per_s2));
    path_j = std::max(path_j, std::abs(p.jerk_mm_per_s3));
  }
  EXPECT_NEAR(path_a, a * std::sqrt(2.0), 1e-6 * a);
  EXPECT_NEAR(path_j, j * std::sqrt(2.0), 1e-6 * j);
  EXPECT_NEAR(c.max_a.x(), a, 0.01 * a);  // each axis at its own limit, not beyond
  // The same move along x takes longer by the slower rise of speed: (v / a)(1 - 1/sqrt 2)
  // plus (a / J)(1 - ...) -- both terms are saved on the diagonal.
  const auto along_x = plan_stretch_detailed(polyline({{0, 0}, {200 * std::sqrt(2.0), 0}}, 80), o);
  EXPECT_GT(along_x->duration_s(), tr->duration_s() + 0.5 * (80 / a) * (1 - 1 / std::sqrt(2.0)));

  // A 30-degree arc of radius 20 around the 45-degree direction, with no feed or axis speed
  // limit in the way: its cap is set by the normal acceleration. Through the axes (a full
  // circle) v^2 / r <= f a; here the axes give a / cos(30 deg) along the arc's normals.
  o.max_velocity_mm_per_s = Eigen::Vector2d(1000, 1000);
  const double r = 20, f = o.curve_normal_fraction;
  Segment arc;
  arc.kind = Segment::Kind::arc;
  arc.center = {0, 0};
  arc.radius = r;
  arc.start_angle = kPi / 4 - kPi / 12;
  arc.sweep = kPi / 6;
  arc.start = r * Vector2d(std::cos(arc.start_angle), std::sin(arc.start_angle));
  arc.end = r * Vector2d(std::cos(arc.end_angle()), std::sin(arc.end_angle()));
  // Long straight approaches along the tangents so the arc is run at its cap.
  const Vector2d t0(-std::sin(arc.start_angle), std::cos(arc.start_angle));
  const Vector2d t1(-std::sin(arc.end_angle()), std::cos(arc.end_angle()));
  const Stretch st = stretch_of({line(arc.start - 300 * t0, arc.start), arc, line(arc.end, arc.end + 300 * t1)}, 1000);
  const auto ta = plan_stretch_detailed(st, o);
  const Check ca = check_trajectory(st, *ta, o);
  double v_arc = 0;
  Setpoint sp;
  for (double t = 0; t < ta->duration_s(); t += 1e-4) {
    ta->sample(t, sp);
    if (std::abs(sp.position_mm.norm() - r) < 1e-6) v_arc = std::max(v_arc, sp.velocity_mm_per_s.norm());
  }
  EXPECT_GT(v_arc, 1.05 * std::sqrt(f * a * r));  // more than a circular limit allows
  EXPECT_NEAR(v_arc, std::sqrt(f * a / std::cos(kPi / 6) * r), 1e-3 * v_arc);
  EXPECT_LE(ca.max_a.maxCoeff(), a * (1 + 1e-6));
}

TEST(FeedPlanner, PolygonOfShortSegmentsIsRunWithoutStopping) {
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  const Stretch st = polygon200();
  const auto tr = plan_stretch_detailed(st, o);
  EXPECT_EQ(tr->blended_junctions(), 199);
  EXPECT_EQ(tr->stop_junctions(), 0);
  // Away from the start and the end (0.4 s to reach speed), the speed stays near the cap
  // sqrt(0.8 a r) of the blend arcs (r ~ 15.9 mm): nowhere does it dip towards zero.
  const Check c = check_trajectory(st, *tr, o, 0.4);
  EXPECT_GT(c.min_speed_mid, 70.0);
  // The same polygon followed exactly must stop at every vertex: the bound for that is far
  // above what the blended plan takes.
  EXPECT_LT(tr->duration_s(), 0.5 * time_lower_bound_s(st, o));
}

TEST(FeedPlanner, SharpCornersSlowDownButDoNotStop) {
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  const auto tr = plan_stretch_detailed(square(), o);
  EXPECT_EQ(tr->blended_junctions(), 3);
  EXPECT_NEAR(tr->max_deviation_mm(), o.path_tolerance_mm, 0.01 * o.path_tolerance_mm);
  // A reversal is not blended: the tool stops there.
  const auto back = plan_stretch_detailed(polyline({{0, 0}, {10, 0}, {0, 0}}, 80), o);
  EXPECT_EQ(back->stop_junctions(), 1);
  Setpoint sp;
  double min_speed = 1e300;
  for (double t = 0.05; t < back->duration_s() - 0.05; t += 1e-4) {
    back->sample(t, sp);
    min_speed = std::min(min_speed, sp.velocity_mm_per_s.norm());
  }
  EXPECT_LT(min_speed, 1.0);
}

TEST(FeedPlanner, ArcSamplesAreExactToTheGeometryWithoutDrift) {
  // Ten turns of a 20 mm circle as twenty half arcs: every setpoint on the circle, the last
  // one at the programmed end.
  std::vector<Segment> segs;
  for (int k = 0; k < 10; ++k) {
    const auto c = Contour::circle({3, -2}, 20).segments();
    segs.insert(segs.end(), c.begin(), c.end());
  }
  const Stretch st = stretch_of(segs, 80);
  const PlannerOptions o;
  const auto tr = plan_stretch_detailed(st, o);
  Setpoint sp;
  double worst = 0;
  for (double t = 0; t <= tr->duration_s(); t += kT) {
    tr->sample(t, sp);
    worst = std::max(worst, std::abs((sp.position_mm - Vector2d(3, -2)).norm() - 20.0));
  }
  EXPECT_LT(worst, 1e-9);
  tr->sample(tr->duration_s(), sp);
  EXPECT_LT((sp.position_mm - segs.back().end).norm(), 1e-9);
}

TEST(Interpolator, LineAndArcFollowKorensSteps) {
  // Koren: on a line dX = T V Lx / L; on an arc the angle advances by V T / R per period.
  const Segment l = line({1, 2}, {4, 6});  // L = 5
  const PathPoint p = interpolate(l, 2.5);
  EXPECT_NEAR(p.position_mm.x(), 1 + 2.5 * 3 / 5, 1e-15);
  EXPECT_NEAR(p.position_mm.y(), 2 + 2.5 * 4 / 5, 1e-15);
  EXPECT_EQ(p.curvature_per_mm, 0.0);
  const Segment a = make_segment({10, 0}, {-10, 0}, -1.0);  // clockwise half circle of radius 10
  const double V = 80, R = 10;
  for (int k = 0; k < 30; ++k) {
    const PathPoint q = interpolate(a, V * kT * k);
    const double th = -(V * kT / R) * k;  // starts at angle 0, clockwise
    EXPECT_NEAR(q.position_mm.x(), R * std::cos(th), 1e-12);
    EXPECT_NEAR(q.position_mm.y(), R * std::sin(th), 1e-12);
    EXPECT_NEAR(q.curvature_per_mm, -1.0 / R, 1e-15);
  }
}

TEST(TimeLowerBound, MatchesTheOneDimensionalAnswerOnLines) {
  PlannerOptions o;  // v 81.83, a 500
  const double a = 500;
  // Long axis-aligned line, feed 60: accelerate, cruise, brake.
  EXPECT_NEAR(time_lower_bound_s(polyline({{0, 0}, {100, 0}}, 60), o), 100 / 60.0 + 60 / a, 1e-12);
  // Short line: triangular profile, 2 sqrt(L / a).
  EXPECT_NEAR(time_lower_bound_s(polyline({{0, 0}, {0, 2}}, 60), o), 2 * std::sqrt(2 / a), 1e-12);
  // Diagonal: each axis gives sqrt(2) more along the path, speed capped by the feed 100 and
  // the axes (81.83 sqrt 2).
  const double v = std::min(100.0, o.max_velocity_mm_per_s.x() * std::sqrt(2.0)), ad = a * std::sqrt(2.0);
  EXPECT_NEAR(time_lower_bound_s(polyline({{0, 0}, {100, 100}}, 100), o), 100 * std::sqrt(2.0) / v + v / ad, 1e-9);
  // A square followed exactly stops at each corner: four times one side.
  EXPECT_NEAR(time_lower_bound_s(square(), o), 4 * (100 / 80.0 + 80 / a), 1e-9);
  // Collinear lines are one line.
  EXPECT_NEAR(time_lower_bound_s(polyline({{0, 0}, {30, 0}, {100, 0}}, 60), o), 100 / 60.0 + 60 / a, 1e-12);
}

TEST(TimeLowerBound, CirclesAreBoundedBelowByFeedAndCurvature) {
  PlannerOptions o;
  // Feed-limited circle: between L / f and the time of a simple feasible motion.
  const double L = 2 * kPi * 50;
  const double b = time_lower_bound_s(circle(), o);
  EXPECT_GE(b, L / 80);
  EXPECT_LE(b, L / 80 + 80 / 500.0);
  // Curvature-limited circle: r = 2, feed 80 > sqrt(a_n r) everywhere (a_n <= 500 sqrt 2).
  const Stretch small = stretch_of(Contour::circle({0, 0}, 2).segments(), 80);
  const double vmax_curv = std::sqrt(500 * std::sqrt(2.0) * 2);
  EXPECT_GE(time_lower_bound_s(small, o), 2 * kPi * 2 / vmax_curv);
}

TEST(TimeLowerBound, NeverAboveThePlannersDurationOnRandomPaths) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> step(-20, 20), len(0.2, 30), feed(5, 120), bulge(-1.5, 1.5);
  std::uniform_int_distribution<int> count(1, 25);
  for (const PlannerOptions& o : {PlannerOptions::thermal_gantry(), PlannerOptions::xy_table()}) {
    for (int trial = 0; trial < 40; ++trial) {
      SCOPED_TRACE(trial);
      Stretch st;
      Vector2d at(0, 0);
      const int n = count(rng);
      for (int k = 0; k < n; ++k) {
        Vector2d d(step(rng), step(rng));
        d = d.normalized() * len(rng);
        const double b = (k % 3 == 2) ? bulge(rng) : 0.0;
        st.segments.push_back(make_segment(at, at + d, b));
        st.feed_mm_per_s.push_back(feed(rng) * (o.max_velocity_mm_per_s.x() / 81.8));
        st.source_lines.push_back(k + 1);
        at += d;
      }
      const auto tr = plan_stretch_detailed(st, o);
      check_trajectory(st, *tr, o);
      EXPECT_GE(tr->duration_s(), time_lower_bound_s(tr->executed_path(), o) * (1 - 1e-9));
    }
  }
}

TEST(FeedPlanner, SameInputSameOutput) {
  const PlannerOptions o;
  const auto a = plan_stretch_detailed(slot_with_corners(), o);
  const auto b = plan_stretch_detailed(slot_with_corners(), o);
  ASSERT_EQ(a->duration_s(), b->duration_s());
  ASSERT_EQ(a->profile().size(), b->profile().size());
  Setpoint sa, sb;
  for (double t = 0; t <= a->duration_s(); t += 0.0137) {
    a->sample(t, sa);
    b->sample(t, sb);
    EXPECT_EQ(sa.position_mm, sb.position_mm);
    EXPECT_EQ(sa.velocity_mm_per_s, sb.velocity_mm_per_s);
    EXPECT_EQ(sa.acceleration_mm_per_s2, sb.acceleration_mm_per_s2);
  }
}

TEST(FeedPlanner, RejectsBadOptionsAndMalformedStretches) {
  PlannerOptions o;
  o.max_jerk_mm_per_s3 = 0;
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("max_jerk_mm_per_s3: 0"));
  }
  const PlannerOptions good;
  // A malformed stretch is the caller's construction, not the user's input: a bug.
  EXPECT_THROW(plan_stretch(Stretch{}, good), InternalError);
  Stretch gap = polyline({{0, 0}, {1, 0}}, 10);
  gap.segments.push_back(line({2, 0}, {3, 0}));
  gap.feed_mm_per_s.push_back(10);
  gap.source_lines.push_back(2);
  EXPECT_THROW(plan_stretch(gap, good), InternalError);
  Stretch nofeed = polyline({{0, 0}, {1, 0}}, 0);
  EXPECT_THROW(time_lower_bound_s(nofeed, good), InternalError);
}

}  // namespace
}  // namespace machplan::motion
