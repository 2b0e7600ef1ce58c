// Rapid planning round no-go zones: solvers/motion/rapid_planner.h, solvers/motion/rapids.h
// and the declared-zones reader engine/programs/zones.h.
//
// Clearance is checked here with geometry of the test's own (axis-aligned boxes and
// segment-to-segment distance by a separate formula), not with the planner's functions.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/common/internal/numbers.h"
#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/programs/zones.h"
#include "solvers/motion/rapid_planner.h"
#include "solvers/motion/rapids.h"
#include "tests/support/stretches.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
using Polyline = std::vector<Vector2d>;

// --- the test's own geometry ------------------------------------------------------------

struct Box {
  double x0, y0, x1, y1;
  Contour contour() const { return Contour({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, {0, 0, 0, 0}); }
  bool inside(const Vector2d& p) const { return p.x() > x0 && p.x() < x1 && p.y() > y0 && p.y() < y1; }
};

double point_seg(const Vector2d& p, const Vector2d& a, const Vector2d& b) {
  // Minimum over the segment by the closed form of the quadratic |a + t (b - a) - p|^2.
  const Vector2d d = b - a;
  double t = d.squaredNorm() > 0 ? (p - a).dot(d) / d.squaredNorm() : 0.0;
  t = std::min(1.0, std::max(0.0, t));
  return (a + t * d - p).norm();
}

// Segment-segment distance: 0 when the parametric solution lies in both unit intervals,
// else the least end-point-to-segment distance.
double seg_seg(const Vector2d& a, const Vector2d& b, const Vector2d& c, const Vector2d& d) {
  const Vector2d r = b - a, s = d - c;
  const double den = r.x() * s.y() - r.y() * s.x();
  if (std::abs(den) > 1e-15) {
    const Vector2d w = c - a;
    const double t = (w.x() * s.y() - w.y() * s.x()) / den, u = (w.x() * r.y() - w.y() * r.x()) / den;
    if (t >= 0 && t <= 1 && u >= 0 && u <= 1) return 0.0;
  }
  return std::min({point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b)});
}

double box_distance(const Vector2d& a, const Vector2d& b, const Box& box) {
  if (box.inside(a) || box.inside(b)) return 0.0;
  const Vector2d p[4] = {{box.x0, box.y0}, {box.x1, box.y0}, {box.x1, box.y1}, {box.x0, box.y1}};
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) best = std::min(best, seg_seg(a, b, p[i], p[(i + 1) % 4]));
  return best;
}

double polyline_box_distance(const Polyline& p, const std::vector<Box>& boxes, std::size_t first = 0,
                             std::size_t last = std::numeric_limits<std::size_t>::max()) {
  last = std::min(last, p.size() - 1);
  double best = std::numeric_limits<double>::infinity();
  for (const Box& box : boxes)
    for (std::size_t i = first + 1; i <= last; ++i) best = std::min(best, box_distance(p[i - 1], p[i], box));
  return best;
}

double length_of(const Polyline& p) {
  double s = 0;
  for (std::size_t i = 1; i < p.size(); ++i) s += (p[i] - p[i - 1]).norm();
  return s;
}

std::vector<Contour> contours(const std::vector<Box>& boxes) {
  std::vector<Contour> out;
  for (const Box& b : boxes) out.push_back(b.contour());
  return out;
}

// Shortest curve from P to Q = (-P.x, P.y) over the top of the box grown by r (a rounded
// rectangle), P level with the box and left of it, the box centred on x = 0: two tangents,
// two corner arcs and the top edge. No clear curve is shorter.
double optimum_over_box(const Vector2d& P, const Box& box, double r) {
  const Vector2d C(box.x0, box.y1);  // upper-left corner, centre of the corner arc
  const Vector2d v = P - C;
  const double dist = v.norm();
  const double tangent = std::sqrt(dist * dist - r * r);
  const double beta = std::acos(r / dist);
  const double angle_t = std::atan2(v.y(), v.x()) + (v.y() < 0 ? 2 * kPi : 0.0) - beta;
  const double arc = r * (angle_t - kPi / 2);
  return 2 * (tangent + arc) + (box.x1 - box.x0);
}

// The planners under a Termination that never ends (the tests' own limits are the options').
RapidPlan plan_rapid(const Vector2d& from, const Vector2d& to, const std::vector<Contour>& zones, const RapidOptions& o,
                     std::size_t first_part = static_cast<std::size_t>(-1)) {
  Termination never;
  return motion::plan_rapid(from, to, zones, o, never, first_part);
}
RapidsReport plan_rapids(Job& job, const std::vector<Contour>& zones, const RapidOptions& o, bool from_cuts) {
  Termination never;
  return motion::plan_rapids(job, zones, o, from_cuts, never);
}

// --- plan_rapid -----------------------------------------------------------------------------

const Box kClamp{-50, -20, 50, 20};

TEST(RapidPlanner, StraightWhenFree) {
  RapidOptions o;
  const RapidPlan p = plan_rapid({-150, 40}, {150, 60}, contours({kClamp}), o);
  ASSERT_TRUE(p.status == Status::done && p.straight) << p.message;
  EXPECT_FALSE(p.straight_blocked);
  ASSERT_EQ(p.polyline.size(), 2u);
  EXPECT_EQ(p.polyline[0], Vector2d(-150, 40));
  EXPECT_EQ(p.polyline[1], Vector2d(150, 60));
  EXPECT_EQ(p.samples, 0);  // OMPL not called
  EXPECT_NEAR(p.length_mm, std::hypot(300.0, 20.0), 1e-9);
  EXPECT_NEAR(p.min_clearance_mm, polyline_box_distance(p.polyline, {kClamp}), 1e-9);
}

TEST(RapidPlanner, ZeroLengthRapidOnAZoneMovesNothing) {
  const RapidPlan p = plan_rapid({50, 0}, {50, 0}, contours({kClamp}), RapidOptions{});
  EXPECT_TRUE(p.status == Status::done && p.straight);
  EXPECT_FALSE(p.straight_blocked);
  EXPECT_EQ(p.polyline.size(), 2u);
  EXPECT_EQ(p.length_mm, 0.0);
}

TEST(RapidPlanner, StraightTestIsExactAtTheClearance) {
  // A horizontal move passing the clamp's top edge at clearance + 1 um is straight; at
  // clearance - 1 um it is blocked (the straight check is not sampled).
  RapidOptions o;
  const double y_free = kClamp.y1 + o.clearance_mm + 1e-3;
  const double y_near = kClamp.y1 + o.clearance_mm - 1e-3;
  const RapidPlan clear = plan_rapid({-150, y_free}, {150, y_free}, contours({kClamp}), o);
  EXPECT_TRUE(clear.status == Status::done && clear.straight);
  const RapidPlan p = plan_rapid({-150, y_near}, {150, y_near}, contours({kClamp}), o);
  EXPECT_TRUE(p.straight_blocked);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  EXPECT_GE(polyline_box_distance(p.polyline, {kClamp}), o.clearance_mm - 1e-9);
  // A diagonal move passing the corner (50, 20) at clearance +- 1 um: the line x + y = k is
  // (k - 70) / sqrt(2) from the corner.
  for (const double delta : {1e-3, -1e-3}) {
    const double k = 70 + std::sqrt(2.0) * (o.clearance_mm + delta);
    const RapidPlan q = plan_rapid({0, k}, {k, 0}, contours({kClamp}), o);
    EXPECT_EQ(q.straight_blocked, delta < 0) << delta;
    EXPECT_EQ(q.straight_blocked, box_distance({0, k}, {k, 0}, kClamp) < o.clearance_mm);
  }
}

TEST(RapidPlanner, AroundABoxClampKeepsClearanceAndIsNearTheShortest) {
  RapidOptions o;
  const Vector2d from(-150, 0), to(150, 0);
  const RapidPlan p = plan_rapid(from, to, contours({kClamp}), o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  EXPECT_TRUE(p.straight_blocked);
  EXPECT_GT(p.samples, 0);
  ASSERT_GE(p.polyline.size(), 3u);
  EXPECT_EQ(p.polyline.front(), from);
  EXPECT_EQ(p.polyline.back(), to);
  EXPECT_TRUE(p.start_zones.empty() && p.end_zones.empty());

  // Clearance, checked against the box itself.
  const double clear = polyline_box_distance(p.polyline, {kClamp});
  EXPECT_GE(clear, o.clearance_mm - 1e-9);
  EXPECT_NEAR(p.min_clearance_mm, clear, 1e-6);
  EXPECT_NEAR(p.length_mm, length_of(p.polyline), 1e-9);
  EXPECT_DOUBLE_EQ(p.straight_length_mm, 300.0);

  // No clear curve is shorter than the optimum; the plan is within 0.5 % of it, and far
  // shorter than the naive detour (up to clearance above the box, across, down).
  const double best = optimum_over_box(from, kClamp, o.clearance_mm);
  EXPECT_GE(p.length_mm, best - 1e-6);
  EXPECT_LE(p.length_mm, best * 1.005);
  const double naive = 300.0 + 2 * (kClamp.y1 + o.clearance_mm);
  EXPECT_LT(p.length_mm - 300.0, 0.2 * (naive - 300.0));
}

TEST(RapidPlanner, SeveralZonesClearanceOnEverySegment) {
  const std::vector<Box> boxes = {{-60, -40, -40, 40}, {0, -100, 20, 10}, {60, -10, 80, 100}, {-20, 30, 30, 45}};
  RapidOptions o;
  o.clearance_mm = 4.0;
  const RapidPlan p = plan_rapid({-120, 0}, {140, 0}, contours(boxes), o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  EXPECT_GE(polyline_box_distance(p.polyline, boxes), o.clearance_mm - 1e-9);
  EXPECT_GE(p.min_clearance_mm, o.clearance_mm - 1e-9);
}

TEST(RapidPlanner, ArcZoneClearance) {
  // A round zone (two half circles): the planned path keeps the clearance from the circle.
  RapidOptions o;
  const Vector2d centre(10, -5);
  const double radius = 30;
  const RapidPlan p = plan_rapid({-100, -5}, {120, -4}, {Contour::circle(centre, radius)}, o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  double clear = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < p.polyline.size(); ++i)
    clear = std::min(clear, point_seg(centre, p.polyline[i - 1], p.polyline[i]) - radius);
  EXPECT_GE(clear, o.clearance_mm - 1e-9);
  // Round a circle the shortest curve is two tangents and an arc of radius R = r + c
  // sweeping the angle between the end points seen from the centre less the two tangent
  // angles.
  const double R = radius + o.clearance_mm;
  const Vector2d ua = Vector2d(-100, -5) - centre, ub = Vector2d(120, -4) - centre;
  const double sweep = std::acos(ua.normalized().dot(ub.normalized())) - std::acos(R / ua.norm()) -
                       std::acos(R / ub.norm());
  const double best =
      std::sqrt(ua.squaredNorm() - R * R) + std::sqrt(ub.squaredNorm() - R * R) + R * sweep;
  EXPECT_GE(p.length_mm, best - 1e-6);
  EXPECT_LE(p.length_mm, best * 1.01);
}

TEST(RapidPlanner, DeterministicForASeedWhateverRanBefore) {
  const std::vector<Box> boxes = {{-50, -20, 50, 20}, {80, -60, 100, 30}};
  RapidOptions o;
  o.seed = 7;
  const RapidPlan a = plan_rapid({-150, 0}, {150, 0}, contours(boxes), o);
  RapidOptions other = o;
  other.seed = 8;
  (void)plan_rapid({-150, 5}, {150, -5}, contours(boxes), other);  // a different plan in between
  const RapidPlan b = plan_rapid({-150, 0}, {150, 0}, contours(boxes), o);
  ASSERT_TRUE(a.status == Status::done && !a.straight);
  EXPECT_EQ(a.polyline, b.polyline);
  EXPECT_EQ(a.samples, b.samples);

  // The seed is really used: the raw tree paths of two seeds differ.
  RapidOptions raw = o;
  raw.simplify = raw.smooth = false;
  raw.attempts = 1;
  const RapidPlan r1 = plan_rapid({-150, 0}, {150, 0}, contours(boxes), raw);
  raw.seed = 8;
  const RapidPlan r2 = plan_rapid({-150, 0}, {150, 0}, contours(boxes), raw);
  ASSERT_TRUE(r1.ok() && r2.ok());
  EXPECT_NE(r1.polyline, r2.polyline);
  EXPECT_GE(polyline_box_distance(r1.polyline, boxes), o.clearance_mm - 1e-9);  // unshortened paths are clear too
}

// Four walls round the goal with gaps of `gap` mm at the middle of each side.
std::vector<Box> walls_with_gaps(double gap) {
  const double h = gap / 2;
  return {{-60, 50, -h, 60},  {h, 50, 60, 60},  {-60, -60, -h, -50}, {h, -60, 60, -50},
          {-60, -50, -50, -h}, {-60, h, -50, 50}, {50, -50, 60, -h},   {50, h, 60, 50}};
}

TEST(RapidPlanner, WalledInGoalGivesNoPath) {
  RapidOptions o;  // clearance 5: a gap narrower than 10 mm cannot be passed
  o.max_samples = 1500;
  const RapidPlan p = plan_rapid({-150, 0}, {0, 0}, contours(walls_with_gaps(8.0)), o);
  EXPECT_EQ(p.status, Status::infeasible) << p.message;
  EXPECT_TRUE(p.polyline.empty());
  EXPECT_GE(p.samples, o.max_samples);
  EXPECT_LE(p.samples, o.max_samples + 2);
  EXPECT_FALSE(p.ok());

  // The same walls with 24 mm gaps: a way in through a gap (not in line with the start).
  o.max_samples = 20000;
  const std::vector<Box> open = walls_with_gaps(24.0);
  const RapidPlan q = plan_rapid({-150, 40}, {0, 0}, contours(open), o);
  EXPECT_TRUE(q.straight_blocked);
  ASSERT_TRUE(q.status == Status::done && !q.straight) << q.message;
  EXPECT_GE(polyline_box_distance(q.polyline, open), o.clearance_mm - 1e-9);
}

TEST(RapidPlanner, StartOnAZoneLeavesItByTheShortestWay) {
  // The torch stops on the clamp's right edge; the goal is beyond its left side.
  RapidOptions o;
  const Vector2d from(50, 3), to(-150, 0);
  const RapidPlan p = plan_rapid(from, to, contours({kClamp}), o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  EXPECT_EQ(p.start_zones, std::vector<std::size_t>{0});
  EXPECT_TRUE(p.end_zones.empty());
  ASSERT_GE(p.polyline.size(), 3u);
  EXPECT_EQ(p.polyline.front(), from);
  // The escape leg runs along the outward normal (+x) to the edge of the band.
  EXPECT_NEAR(p.polyline[1].y(), 3.0, 1e-9);
  EXPECT_NEAR(p.polyline[1].x(), 50 + o.clearance_mm, 1e-4);
  EXPECT_GE(p.polyline[1].x(), 50 + o.clearance_mm);
  // Everything after the escape leg keeps the clearance.
  EXPECT_GE(polyline_box_distance(p.polyline, {kClamp}, 1), o.clearance_mm - 1e-9);
  EXPECT_GE(p.min_clearance_mm, o.clearance_mm - 1e-9);
}

TEST(RapidPlanner, EndInsideAClampCrossesOnlyInTheLastLeg) {
  RapidOptions o;
  const Vector2d from(-150, 0), to(40, 15);  // pierce point under the clamp, 5 mm from its top
  const RapidPlan p = plan_rapid(from, to, contours({kClamp}), o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  EXPECT_EQ(p.end_zones, std::vector<std::size_t>{0});
  const std::size_t n = p.polyline.size();
  ASSERT_GE(n, 3u);
  EXPECT_EQ(p.polyline.back(), to);
  EXPECT_NEAR(p.polyline[n - 2].x(), 40, 1e-9);  // the shortest way out is through the top
  EXPECT_NEAR(p.polyline[n - 2].y(), kClamp.y1 + o.clearance_mm, 1e-4);
  EXPECT_GE(polyline_box_distance(p.polyline, {kClamp}, 0, n - 2), o.clearance_mm - 1e-9);
}

TEST(RapidPlanner, StartWedgedBetweenTwoZonesIsBlocked) {
  // 6 mm between two clamps: the start is within 5 mm of both, and pushing out of one
  // pushes into the other.
  RapidOptions o;
  const std::vector<Box> boxes = {{-50, -20, -3, 20}, {3, -20, 50, 20}};
  const RapidPlan p = plan_rapid({0, 0}, {0, 200}, contours(boxes), o);
  EXPECT_EQ(p.status, Status::infeasible) << p.message;
  EXPECT_TRUE(p.polyline.empty());
  EXPECT_EQ(p.start_zones, (std::vector<std::size_t>{0, 1}));
}

TEST(RapidPlanner, OutsideTheTravelBox) {
  RapidOptions o;
  o.bounds = Eigen::AlignedBox2d(Vector2d(-100, -100), Vector2d(100, 100));
  EXPECT_EQ(plan_rapid({-150, 0}, {50, 50}, contours({kClamp}), o).status, Status::infeasible);
  // Inside a tight box the detour must stay inside it too.
  const RapidPlan p = plan_rapid({-90, 0}, {90, 0}, contours({kClamp}), o);
  ASSERT_TRUE(p.status == Status::done && !p.straight) << p.message;
  for (const Vector2d& q : p.polyline) EXPECT_TRUE(o.bounds.contains(q));
}

TEST(RapidPlanner, OptionsAreValidated) {
  RapidOptions o;
  o.clearance_mm = 0.0;
  try {
    o.validate();
    FAIL() << "clearance 0 accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(std::string(e.what()), "clearance_mm: is 0, must be finite and > 0");
  }
  o = RapidOptions{};
  o.max_samples = 0;
  EXPECT_THROW(plan_rapid({0, 0}, {1, 1}, {}, o), InputError);
  o = RapidOptions{};
  o.attempts = 0;
  EXPECT_THROW(o.validate(), InputError);
  o = RapidOptions{};
  o.travel_height_over_cut_mm = -1;
  EXPECT_THROW(o.validate(), InputError);
}

TEST(RapidPlanner, SegmentDistanceMatchesDenseSampling) {
  // The exact distance lies between the sampled minimum minus half the sample spacing and
  // the sampled minimum (a sampled value is an actual distance, so never below the exact).
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-50, 50), bulge(-3, 3);
  int arcs = 0;
  for (int k = 0; k < 400; ++k) {
    const Vector2d a(u(rng), u(rng)), b(u(rng), u(rng)), p(u(rng), u(rng)), q(u(rng), u(rng));
    const Segment span = make_segment(p, q, k % 4 == 0 ? 0.0 : bulge(rng));
    arcs += span.is_arc();
    const double exact = segment_distance_mm(a, b, span);
    constexpr int kN = 4000;
    double sampled = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= kN; ++i) {
      const Vector2d x = a + (b - a) * (double(i) / kN);
      sampled = std::min(sampled, (closest_point(span, x) - x).norm());
    }
    const double spacing = (b - a).norm() / kN;
    EXPECT_LE(exact, sampled + 1e-9) << k;
    EXPECT_GE(exact, sampled - spacing) << k;
  }
  EXPECT_GT(arcs, 200);
}

// --- plan_rapids on a Job ------------------------------------------------------------------

Stretch line_stretch(const Polyline& pts, bool cutting, bool rapid, double feed, int line) {
  return test::make_stretch(test::polyline_segments(pts, false), feed, cutting, rapid, line);
}

// Rapid to part A's pierce point, cut A (a lead-in and the square [100, 200] x [0, 100]),
// rapid straight across A to part B's pierce point, cut B.
Job two_parts() {
  Job job;
  job.source = "two_parts.ngc";
  job.start_mm = {0, 0};
  job.stretches.push_back(line_stretch({{0, 0}, {90, 50}}, false, true, 400, 10));
  job.stretches.push_back(
      line_stretch({{90, 50}, {100, 50}, {100, 0}, {200, 0}, {200, 100}, {100, 100}, {100, 50}}, true, false, 20, 11));
  job.stretches.push_back(line_stretch({{100, 50}, {300, 50}}, false, true, 400, 20));
  job.stretches.push_back(line_stretch({{300, 50}, {310, 50}, {310, 0}, {360, 0}, {310, 50}}, true, false, 20, 21));
  using K = Step::Kind;
  job.steps = {{K::move, 10, 0, 0}, {K::torch_on, 11, 0, 0}, {K::move, 11, 1, 0}, {K::torch_off, 17, 0, 0},
               {K::move, 20, 2, 0}, {K::torch_on, 21, 0, 0}, {K::move, 21, 3, 0}, {K::torch_off, 25, 0, 0}};
  return job;
}

TEST(Rapids, ZonesFromCutsReRouteRoundTheCutPart) {
  Job job = two_parts();
  RapidOptions o;
  const RapidsReport r = plan_rapids(job, {}, o, true);
  ASSERT_EQ(r.rapids.size(), 2u);
  EXPECT_EQ(r.cut_zones, 2u);  // A and the triangle B (B counts after the last rapid)
  EXPECT_EQ(r.open_cuts, 0u);

  // The first rapid sees no zone and stays.
  EXPECT_EQ(r.rapids[0].zone_count, 0u);
  EXPECT_TRUE(r.rapids[0].status == Status::done && r.rapids[0].straight);
  EXPECT_FALSE(r.rapids[0].replaced);
  EXPECT_EQ(job.stretches[0].segments.size(), 1u);

  // The second crossed part A: re-routed, starting with the way off A's edge.
  const RapidReport& second = r.rapids[1];
  EXPECT_EQ(second.stretch, 2u);
  EXPECT_EQ(second.zone_count, 1u);
  EXPECT_TRUE(second.straight_blocked);
  ASSERT_TRUE(second.replaced) << second.message;
  const Stretch& s = job.stretches[2];
  ASSERT_GE(s.segments.size(), 3u);
  EXPECT_TRUE(s.rapid);
  EXPECT_FALSE(s.cutting);
  ASSERT_EQ(s.feed_mm_per_s.size(), s.segments.size());
  ASSERT_EQ(s.source_lines.size(), s.segments.size());
  Polyline route{s.segments.front().start};
  for (std::size_t i = 0; i < s.segments.size(); ++i) {
    EXPECT_FALSE(s.segments[i].is_arc());
    EXPECT_EQ(s.feed_mm_per_s[i], 400);
    EXPECT_EQ(s.source_lines[i], 20);
    if (i > 0) { EXPECT_LT((s.segments[i].start - s.segments[i - 1].end).norm(), 1e-9); }
    route.push_back(s.segments[i].end);
  }
  EXPECT_EQ(route.front(), Vector2d(100, 50));
  EXPECT_EQ(route.back(), Vector2d(300, 50));
  const Box part_a{100, 0, 200, 100};
  EXPECT_NEAR(route[1].x(), 100 - o.clearance_mm, 1e-4);  // leaves A outwards, to the left
  EXPECT_GE(polyline_box_distance(route, {part_a}, 1), o.clearance_mm - 1e-9);
  EXPECT_NEAR(second.length_mm, length_of(route), 1e-9);
  EXPECT_NEAR(r.length_mm, r.rapids[0].length_mm + second.length_mm, 1e-9);
  EXPECT_GT(second.length_mm, second.straight_length_mm + 50);  // round the 100 mm part
  EXPECT_EQ(r.replaced, 1u);
  EXPECT_EQ(r.blocked, 1u);
  EXPECT_TRUE(r.ok());
  EXPECT_NE(r.summary.full_report().find("re-routed"), std::string::npos);
}

TEST(Rapids, WithoutZonesFromCutsNothingChanges) {
  Job job = two_parts();
  const Job before = two_parts();
  const RapidsReport r = plan_rapids(job, {}, RapidOptions{}, false);
  EXPECT_EQ(r.cut_zones, 0u);
  EXPECT_EQ(r.replaced, 0u);
  for (std::size_t i = 0; i < job.stretches.size(); ++i)
    EXPECT_EQ(job.stretches[i].segments.size(), before.stretches[i].segments.size());
}

TEST(Rapids, DeclaredClampReRoutesTheFirstRapid) {
  Job job = two_parts();
  const Box clamp{40, 15, 50, 35};  // on the line from (0, 0) to (90, 50)
  const RapidsReport r = plan_rapids(job, contours({clamp}), RapidOptions{}, false);
  ASSERT_EQ(r.rapids.size(), 2u);
  EXPECT_TRUE(r.rapids[0].replaced);
  Polyline route{job.stretches[0].segments.front().start};
  for (const Segment& g : job.stretches[0].segments) route.push_back(g.end);
  EXPECT_GE(polyline_box_distance(route, {clamp}), 5.0 - 1e-9);
  EXPECT_FALSE(r.rapids[1].straight_blocked);  // the clamp is not near the second rapid
}

TEST(Rapids, AStopRequestCancelsPlanningAndProgressIsReported) {
  // Not stopped: the progress reaches 1 over the job's two rapids.
  Job job = two_parts();
  RapidOptions o;
  Termination never;
  Progress progress;
  const RapidsReport done = motion::plan_rapids(job, contours({Box{40, 15, 50, 35}}), o, false, never, &progress);
  EXPECT_EQ(done.summary.status, Status::done) << done.summary.full_report();
  EXPECT_FALSE(done.ended_early());
  EXPECT_EQ(progress.share(), 1.0);
  EXPECT_NE(done.summary.brief_report().find("2 rapids"), std::string::npos) << done.summary.brief_report();
  // Stopped: a blocked rapid ends as cancelled, and plan_rapids plans nothing further.
  StopSource source;
  source.request_stop();
  Termination stopped_work(source.token());
  const RapidPlan p = motion::plan_rapid({-150, 0}, {150, 0}, contours({kClamp}), o, stopped_work);
  EXPECT_EQ(p.status, Status::cancelled);
  EXPECT_FALSE(p.ok());
  EXPECT_TRUE(p.polyline.empty());
  EXPECT_NE(p.message.find("stopped on request"), std::string::npos) << p.message;
  Job again = two_parts();
  Termination stopped_plan(source.token());
  const RapidsReport stopped = motion::plan_rapids(again, contours({Box{40, 15, 50, 35}}), o, false, stopped_plan);
  EXPECT_EQ(stopped.summary.status, Status::cancelled);
  EXPECT_TRUE(stopped.ended_early());
  EXPECT_FALSE(stopped.ok());
  EXPECT_TRUE(stopped.rapids.empty());
}

TEST(Rapids, TheCallersBudgetEndsPlanningTheSameWayEveryTime) {
  // A budget of 2 samples for the whole planning (the blocked first rapid needs 4 over its
  // three attempts): it is spent on the first rapid. The
  // answer depends on the work done, not on time, so two runs end identically.
  std::vector<std::int64_t> spent;
  for (int run = 0; run < 2; ++run) {
    Job job = two_parts();
    Termination work;
    work.set_budget(2, "samples");
    const RapidsReport r = motion::plan_rapids(job, contours({Box{40, 15, 50, 35}}), RapidOptions{}, false, work);
    EXPECT_EQ(r.summary.status, Status::budget) << r.summary.full_report();
    EXPECT_TRUE(r.rapids.empty());
    EXPECT_GE(work.units_spent(), 2);
    EXPECT_LE(work.units_spent(), 4);
    spent.push_back(work.units_spent());
    EXPECT_NE(r.summary.message.find("the budget of 2 samples was spent"), std::string::npos) << r.summary.message;
  }
  EXPECT_EQ(spent[0], spent[1]);
  // A deadline in seconds of work: each sample is charged kSampleWorkS.
  Termination deadline;
  deadline.set_deadline(20 * kSampleWorkS, "planning work");
  const RapidPlan p = motion::plan_rapid({-150, 0}, {150, 0}, contours({kClamp}), RapidOptions{}, deadline);
  EXPECT_EQ(p.status, Status::deadline);
  EXPECT_LE(p.samples, 22);
  EXPECT_EQ(deadline.reason(), Termination::Reason::deadline);
}

TEST(Rapids, ProgrammedDetourThatIsClearIsKept) {
  Job job = two_parts();
  // Program the second rapid as a dog-leg over part A, high enough to be clear.
  job.stretches[2] = line_stretch({{100, 50}, {100, 120}, {300, 120}, {300, 50}}, false, true, 400, 20);
  const RapidsReport r = plan_rapids(job, {}, RapidOptions{}, true);
  // It starts on A's edge, so it is not clear in the strict sense; it must be re-planned.
  EXPECT_TRUE(r.rapids[1].replaced);
  Job job2 = two_parts();
  job2.stretches[2] = line_stretch({{100, 50}, {90, 50}, {90, 120}, {300, 120}, {300, 50}}, false, true, 400, 20);
  // Declared clamp only (no cut zones): the programmed dog-leg keeps 5 mm from it.
  const RapidsReport r2 = plan_rapids(job2, contours({Box{150, 40, 200, 60}}), RapidOptions{}, false);
  EXPECT_TRUE(r2.rapids[1].programmed_clear);
  EXPECT_FALSE(r2.rapids[1].replaced);
  EXPECT_EQ(job2.stretches[2].segments.size(), 4u);
}

TEST(Rapids, ClosedLoopTakesTheLoopAfterALeadInAndArcs) {
  // Lead-in, then a circle of radius 20 about (50, 50) as two half arcs, then a lead-out.
  Stretch s;
  s.cutting = true;
  s.segments = {make_segment({50, 50}, {70, 50}, 0.0), make_segment({70, 50}, {30, 50}, 1.0),
                make_segment({30, 50}, {70, 50}, 1.0), make_segment({70, 50}, {75, 55}, 0.0)};
  const auto loop = closed_loop(s);
  ASSERT_TRUE(loop.has_value());
  EXPECT_EQ(loop->size(), 2u);
  EXPECT_NEAR(std::abs(signed_area(*loop)), kPi * 400, 1e-6);
  EXPECT_TRUE(contains(*loop, {50, 50}));
  EXPECT_FALSE(contains(*loop, {75, 55}));

  // A single arc of three quarters closed by a line: the arc is split, bulges stay <= 1.
  Stretch t;
  t.cutting = true;
  t.segments = {make_segment({0, 0}, {10, 10}, std::tan(3 * kPi / 8)), make_segment({10, 10}, {0, 0}, 0.0)};
  const auto loop2 = closed_loop(t);
  ASSERT_TRUE(loop2.has_value());
  EXPECT_EQ(loop2->size(), 3u);
  for (double b : loop2->bulges()) EXPECT_LE(std::abs(b), 1.0);
  EXPECT_NEAR(std::abs(signed_area(*loop2)), std::abs(signed_area(Contour({{0, 0}, {10, 10}}, {std::tan(3 * kPi / 8), 0}))),
              1e-6);

  // A slit never closes.
  Stretch slit;
  slit.cutting = true;
  slit.segments = {make_segment({0, 0}, {10, 0}, 0.0), make_segment({10, 0}, {10, 10}, 0.0)};
  EXPECT_FALSE(closed_loop(slit).has_value());
}

TEST(Rapids, OpenCutsAreCounted) {
  Job job = two_parts();
  job.stretches[1] = line_stretch({{90, 50}, {100, 50}, {100, 0}, {200, 0}}, true, false, 20, 11);
  const RapidsReport r = plan_rapids(job, {}, RapidOptions{}, true);
  EXPECT_EQ(r.open_cuts, 1u);
  EXPECT_EQ(r.cut_zones, 1u);  // B only
  EXPECT_FALSE(r.rapids[1].straight_blocked);
}

// A 200 x 100 plate at [100, 300] x [0, 100] with three round holes: each hole is pierced at
// its centre, reached by a 10 mm lead-in and cut counter-clockwise; the outline is cut from a
// pierce 6 mm to its left, after the holes (or, `outline_first`, before them, as a naive
// program does). `hole_d` is the holes' diameter.
Job plate_with_holes(double hole_d, bool outline_first = false) {
  Job job;
  job.source = "plate.ngc";
  job.start_mm = {0, 0};
  using K = Step::Kind;
  const std::vector<Vector2d> centres = {{140, 50}, {200, 30}, {260, 70}};
  Vector2d at = job.start_mm;
  int line = 10;
  const auto rapid_to = [&](const Vector2d& p) {
    job.stretches.push_back(line_stretch({at, p}, false, true, 80, line));
    job.steps.push_back({K::move, line, job.stretches.size() - 1, 0});
    at = p;
    line += 10;
  };
  const auto cut = [&](std::vector<Segment> segs) {
    job.steps.push_back({K::torch_on, line, 0, 0});
    job.stretches.push_back(test::make_stretch(std::move(segs), 40, true, false, line));
    job.steps.push_back({K::move, line, job.stretches.size() - 1, 0});
    job.steps.push_back({K::torch_off, line, 0, 0});
    at = job.stretches.back().segments.back().end;
    line += 10;
  };
  const auto outline = [&] {
    rapid_to({94, 50});
    cut(test::polyline_segments({{94, 50}, {100, 50}, {100, 100}, {300, 100}, {300, 0}, {100, 0}, {100, 50}}, false));
  };
  if (outline_first) outline();
  for (const Vector2d& c : centres) {
    rapid_to(c);
    const double r = hole_d / 2;
    std::vector<Segment> segs{make_segment(c, c + Vector2d(r, 0), 0.0)};
    for (const Segment& g : Contour::circle(c, r).segments()) segs.push_back(g);  // starts at angle 0
    cut(segs);
  }
  if (!outline_first) outline();
  rapid_to({0, 0});
  return job;
}

TEST(Rapids, SmallHolesAreCrossedStraightAndThePartIsLeftDirectly) {
  Job job = plate_with_holes(20.0);
  ASSERT_EQ(Contour::circle({0, 0}, 1).segments().front().start.x(), 1.0);  // the circle starts at angle 0
  const RapidsReport r = plan_rapids(job, {}, RapidOptions{}, true);  // slugs up to 50 mm are crossed
  ASSERT_EQ(r.rapids.size(), 5u);
  EXPECT_EQ(r.small_slugs, 3u);
  EXPECT_EQ(r.cut_zones, 1u);  // the outline, counted after the last rapid
  EXPECT_EQ(r.detours, 0u);
  for (const RapidReport& rr : r.rapids) {
    EXPECT_TRUE(rr.status == Status::done && rr.straight) << rr.source_line << ": " << rr.message;
    EXPECT_FALSE(rr.replaced);
    EXPECT_TRUE(rr.reason.empty());
  }
  // The rapid home leaves the plate's outline where it ends, at (100, 50), going away from it.
  EXPECT_NEAR(r.length_mm, r.straight_length_mm, 1e-9);
  EXPECT_LE(r.length_mm, 1.10 * r.straight_length_mm);
}

TEST(Rapids, LargeSlugsAndPartsAreDetouredWithAReason) {
  // Holes of 20 mm with a 15 mm tip size: their slugs are zones; the rapid from the first hole
  // to the second passes over nothing, but the one from the second to the third crosses the
  // second's slug only at its start, and the lead-in leaves the slug's edge inwards.
  Job job = plate_with_holes(20.0);
  RapidOptions o;
  o.slug_tip_size_mm = 15.0;
  const RapidsReport r = plan_rapids(job, {}, o, true);
  EXPECT_EQ(r.small_slugs, 0u);
  EXPECT_EQ(r.cut_zones, 4u);
  // From hole 1's edge (150, 50) to hole 2's centre (200, 30): straight, leaving hole 1 outwards.
  EXPECT_TRUE(r.rapids[1].status == Status::done && r.rapids[1].straight) << r.rapids[1].message;
  // From hole 3's edge (270, 70) to the outline's pierce (94, 50): it would cross hole 3's slug.
  const RapidReport& over = r.rapids[3];
  EXPECT_TRUE(over.replaced) << over.message;
  EXPECT_GT(over.extra_length_mm, 0.0);
  EXPECT_NEAR(over.extra_length_mm, over.length_mm - over.straight_length_mm, 1e-9);
  EXPECT_NE(over.reason.find("slug of the hole cut at line"), std::string::npos) << over.reason;
  EXPECT_GE(r.detours, 1u);
  double extra = 0;
  for (const RapidReport& rr : r.rapids)
    if (!rr.reason.empty()) extra += rr.extra_length_mm;
  EXPECT_NEAR(r.detour_extra_mm, extra, 1e-9);
  EXPECT_NE(r.summary.full_report().find("round slug of the hole"), std::string::npos);

  // A part is always a zone: a rapid straight across the plate after its outline is cut is
  // re-routed and names the part.
  Job across = plate_with_holes(20.0);
  across.stretches.back() = line_stretch({{94, 50}, {320, 50}}, false, true, 80, 200);
  // The outline ends at (100, 50): the rapid goes from there across the plate.
  across.stretches.back().segments.front().start = {100, 50};
  const RapidsReport a = plan_rapids(across, {}, RapidOptions{}, true);
  ASSERT_TRUE(a.rapids.back().replaced) << a.rapids.back().message;
  EXPECT_NE(a.rapids.back().reason.find("part cut at line"), std::string::npos) << a.rapids.back().reason;
}

TEST(Rapids, RapidsIntoAPartAlreadyCutCrossItRaised) {
  // Outline first: each rapid to a hole's pierce point lies inside the plate just cut. It
  // crosses the plate straight instead of leaving it, going round and coming back in, and the
  // torch is raised to the travel height over cut parts before it.
  Job job = plate_with_holes(20.0, true);
  RapidOptions o;
  o.travel_height_over_cut_mm = 40.0;
  const RapidsReport r = plan_rapids(job, {}, o, true);
  ASSERT_EQ(r.rapids.size(), 5u);
  EXPECT_EQ(r.detours, 0u);
  EXPECT_NEAR(r.length_mm, r.straight_length_mm, 1e-9);
  // The rapid to the outline crosses nothing; the three into the plate and the one out of it
  // (from the last hole, inside the plate) cross it.
  EXPECT_TRUE(r.rapids[0].crossed.empty());
  for (std::size_t k = 1; k < 5; ++k) {
    const RapidReport& rr = r.rapids[k];
    EXPECT_TRUE(rr.status == Status::done && rr.straight) << rr.source_line << ": " << rr.message;
    ASSERT_EQ(rr.crossed.size(), 1u) << rr.source_line;
    EXPECT_EQ(rr.crossed[0], "part cut at line 20");
    EXPECT_EQ(rr.travel_height_mm, 40.0);
    EXPECT_NE(rr.why().find("straight over part cut at line 20 (torch at 40 mm)"), std::string::npos) << rr.why();
  }
  EXPECT_EQ(r.crossings, 4u);
  // The torch_off before each crossing rapid retracts to 40 mm; the first cut's too (the
  // rapid after it enters the plate), so every torch_off step carries it.
  int raised = 0;
  for (const Step& st : job.steps)
    if (st.kind == Step::Kind::torch_off) raised += st.height_mm == 40.0;
  EXPECT_EQ(raised, 4);
  EXPECT_EQ(r.summary.status, Status::done);
  EXPECT_NE(r.summary.full_report().find("over part cut at line 20"), std::string::npos);

  // Without a travel height (0): the same route, nothing raised.
  Job flat = plate_with_holes(20.0, true);
  const RapidsReport f = plan_rapids(flat, {}, RapidOptions{}, true);
  EXPECT_EQ(f.crossings, 4u);
  for (const Step& st : flat.steps) EXPECT_EQ(st.height_mm, 0.0);
}

TEST(Rapids, InsideAPartOtherZonesAreStillAvoided) {
  // Holes of 60 mm (slugs that may tip, above the 50 mm tip size): the rapid from the first
  // hole to the second crosses the plate (it is inside it) but goes round the first hole's
  // slug; and a declared clamp on the plate is avoided whatever is crossed.
  Job job = plate_with_holes(36.0, true);
  RapidOptions o;
  o.slug_tip_size_mm = 30.0;
  const Box clamp{225, 40, 240, 60};  // between the second hole (200, 30) and the third (260, 70)
  const RapidsReport r = plan_rapids(job, contours({clamp}), o, true);
  ASSERT_EQ(r.rapids.size(), 5u);
  // Hole 1 -> hole 2: straight from hole 1's edge (leaving its slug directly), over the plate.
  EXPECT_EQ(r.rapids[2].crossed, (std::vector<std::string>{"part cut at line 20"}));
  // Hole 2 -> hole 3: round the clamp, still over the plate.
  const RapidReport& round = r.rapids[3];
  EXPECT_TRUE(round.replaced) << round.message;
  EXPECT_NE(round.reason.find("declared zone 1"), std::string::npos) << round.reason;
  EXPECT_EQ(round.reason.find("part cut at line 20"), std::string::npos) << round.reason;
  EXPECT_EQ(round.crossed, (std::vector<std::string>{"part cut at line 20"}));
  Polyline route{job.stretches[round.stretch].segments.front().start};
  for (const Segment& g : job.stretches[round.stretch].segments) route.push_back(g.end);
  EXPECT_GE(polyline_box_distance(route, {clamp}), o.clearance_mm - 1e-9);
}

TEST(Rapids, APartNestedInAHoleIsAPart) {
  // A 100 x 100 frame with an 80 x 80 hole, and a 20 x 20 part cut inside the hole before
  // the hole itself: the small part is enclosed by two larger cuts, so it is a part (a zone)
  // whatever its size; a rapid straight across it afterwards is re-routed.
  Job job;
  job.source = "nested.ngc";
  using K = Step::Kind;
  const auto add = [&](Stretch s, int line) {
    if (s.cutting) job.steps.push_back({K::torch_on, line, 0, 0});
    job.stretches.push_back(std::move(s));
    job.steps.push_back({K::move, line, job.stretches.size() - 1, 0});
    if (job.stretches.back().cutting) job.steps.push_back({K::torch_off, line, 0, 0});
  };
  add(line_stretch({{0, 0}, {140, 140}}, false, true, 80, 10), 10);
  add(line_stretch({{140, 140}, {160, 140}, {160, 160}, {140, 160}, {140, 140}}, true, false, 40, 20), 20);
  add(line_stretch({{140, 140}, {170, 170}}, false, true, 80, 30), 30);  // across the small part
  add(line_stretch({{170, 170}, {150, 110}, {190, 110}, {190, 190}, {110, 190}, {110, 110}, {150, 110}}, true, false,
                   40, 40), 40);
  add(line_stretch({{150, 110}, {100, 100}, {200, 100}, {200, 200}, {100, 200}, {100, 100}}, true, false, 40, 50), 50);
  const RapidsReport r = plan_rapids(job, {}, RapidOptions{}, true);
  EXPECT_EQ(r.small_slugs, 0u);
  ASSERT_EQ(r.rapids.size(), 2u);
  EXPECT_TRUE(r.rapids[1].replaced) << r.rapids[1].message;
  EXPECT_NE(r.rapids[1].reason.find("part cut at line 20"), std::string::npos) << r.rapids[1].reason;
}

TEST(Rapids, DeclaredZoneAtAnEndIsNeverLeftDirectly) {
  // The same straight geometry as leaving a part, but the zone is declared (a clamp): the
  // planner escapes by the shortest way instead of taking the straight move.
  const Box clamp{100, 0, 200, 100};
  const RapidPlan declared = plan_rapid({100, 50}, {0, 80}, contours({clamp}), RapidOptions{});
  EXPECT_FALSE(declared.status == Status::done && declared.straight);
  const RapidPlan part = plan_rapid({100, 50}, {0, 80}, contours({clamp}), RapidOptions{}, 0);
  EXPECT_TRUE(part.status == Status::done && part.straight) << part.message;
  EXPECT_FALSE(part.straight_blocked);
  // Leaving the part across it is never direct.
  const RapidPlan across = plan_rapid({100, 50}, {320, 50}, contours({clamp}), RapidOptions{}, 0);
  EXPECT_FALSE(across.status == Status::done && across.straight);
  // Leaving along its edge (within the clearance of it beyond the end leg) is not either.
  const RapidPlan along = plan_rapid({100, 50}, {100, 300}, contours({clamp}), RapidOptions{}, 0);
  EXPECT_FALSE(along.status == Status::done && along.straight);
}

// --- declared zones file ----------------------------------------------------------------------

TEST(Zones, ReadsPolygons) {
  test::TempDir dir;
  const std::string path = dir.write("zones.yaml",
                                     "no_go:\n"
                                     "  - name: clamp 1\n"
                                     "    polygon: [[-50, -20], [50, -20], [50, 20], [-50, 20]]\n"
                                     "  - name: magnet\n"
                                     "    polygon:\n"
                                     "      - [400, 0]\n"
                                     "      - [420, 0]\n"
                                     "      - [420, 30]\n");
  const auto zones = load_zones(path);
  ASSERT_EQ(zones.size(), 2u);
  EXPECT_EQ(zones[0].name, "clamp 1");
  EXPECT_EQ(zones[0].line, 2);
  EXPECT_EQ(zones[1].line, 4);
  EXPECT_NEAR(std::abs(signed_area(zones[0].contour)), 4000.0, 1e-9);
  EXPECT_NEAR(std::abs(signed_area(zones[1].contour)), 300.0, 1e-9);
  EXPECT_EQ(zone_contours(zones).size(), 2u);
  EXPECT_TRUE(load_zones(dir.write("none.yaml", "no_go: []\n")).empty());
}

TEST(Zones, BadFilesNameFileAndLine) {
  test::TempDir dir;
  const auto err = [&](const std::string& text) {
    const std::string path = dir.write("z.yaml", text);
    return test::error_of([&] { load_zones(path); });
  };
  const std::string f = (dir.path() / "z.yaml").string();
  EXPECT_EQ(err("no_go:\n  - name: a\n"), f + ":2: missing required key 'no_go[0].polygon'");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1, 0]]\n"),
            f + ":3: key 'no_go[0].polygon' must hold at least 3 points, got 2");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon:\n      - [0, 0]\n      - [1, x]\n      - [1, 1]\n"),
            f + ":5: key 'no_go[0].polygon[1][1]' must be a number, got 'x'");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1, 0], [1, 1]]\n    colour: red\n"),
            f + ":4: unknown key 'no_go[0].colour' (known keys here: name, polygon)");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1, 0], [1, 1]]\n"
                "  - name: a\n    polygon: [[5, 0], [6, 0], [6, 1]]\n"),
            f + ":4: key 'no_go[1].name' 'a' names another zone already");
  const std::string bow = err("no_go:\n  - name: bow\n    polygon: [[0, 0], [10, 10], [10, 0], [0, 10]]\n");
  EXPECT_EQ(bow.rfind(f + ":3: key 'no_go[0].polygon' of zone 'bow' crosses itself at (5, 5)", 0), 0u) << bow;
  // Points on one line fold back over themselves.
  EXPECT_EQ(err("no_go:\n  - name: flat\n    polygon: [[0, 0], [1, 1], [2, 2]]\n"),
            f + ":3: key 'no_go[0].polygon' of zone 'flat' crosses itself at (1, 1) (edges 0 and 2)");
  EXPECT_EQ(err("no_go:\n  - name: sliver\n    polygon: [[0, 0], [1000000, 0], [1000000, 0.000001]]\n"),
            f + ":3: key 'no_go[0].polygon' of zone 'sliver' encloses no area");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1, 0], [1, 1], [0, 0]]\n"),
            f + ":3: key 'no_go[0].polygon[3]' repeats the first point; the polygon closes by itself, leave it out");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1e12, 0], [1, 1]]\n"),
            f + ":3: key 'no_go[0].polygon[1][0]' must be <= 1000000000, got 1000000000000");
  EXPECT_EQ(err("zones: []\n"), f + ":1: unknown key 'zones' (known keys here: no_go)");
  EXPECT_EQ(err("no_go:\n  - name: a\n    polygon: [[0, 0], [1, 0], [1, 1]\n").rfind(f + ":", 0), 0u);
}

}  // namespace
}  // namespace machplan::motion
