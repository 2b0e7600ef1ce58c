// Contracts of engine/motion/kerf.h on hand-built Jobs: part boundaries grow and holes shrink
// by half the kerf (decided by nesting, whatever the direction of travel), lead-ins keep their
// pierce point, overcuts and lead-outs follow the new loop, the path stays continuous across
// stretches, and open cuts, vanishing holes, narrow features and self-crossing loops are
// reported with their program lines.
#include "engine/motion/kerf.h"
#include "engine/common/internal/numbers.h"

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/stretches.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

Segment straight(Vector2d a, Vector2d b) { return make_segment(a, b, 0.0); }

// A cutting stretch through `segs`; source lines first_line, first_line + 1, ...
Stretch cut(std::vector<Segment> segs, int first_line, double feed = 20.0) {
  return test::make_stretch(std::move(segs), feed, true, false, first_line);
}

Stretch rapid(Vector2d a, Vector2d b, int line_no) { return test::make_stretch({straight(a, b)}, 200.0, false, true, line_no); }

// Steps: a move per stretch, cuts wrapped in torch on / off.
Job make(std::vector<Stretch> stretches) {
  Job job;
  job.source = "hand.ngc";
  job.start_mm = stretches.front().segments.front().start;
  for (std::size_t i = 0; i < stretches.size(); ++i) {
    const int l = stretches[i].source_lines.front();
    if (stretches[i].cutting) job.steps.push_back({Step::Kind::torch_on, l, 0, 0.0});
    job.steps.push_back({Step::Kind::move, l, i, 0.0});
    if (stretches[i].cutting) job.steps.push_back({Step::Kind::torch_off, l, 0, 0.0});
  }
  job.stretches = std::move(stretches);
  return job;
}

// The rectangle loop (x0, y0) -> (x1, y0) -> (x1, y1) -> (x0, y1) -> back, ccw or cw.
std::vector<Segment> rect_loop(double x0, double y0, double x1, double y1, bool ccw = true) {
  std::vector<Vector2d> v = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  if (!ccw) std::swap(v[1], v[3]);
  std::vector<Segment> s;
  for (int i = 0; i < 4; ++i) s.push_back(straight(v[i], v[(i + 1) % 4]));
  return s;
}

// A full circle as two half arcs starting at centre + (r, 0).
std::vector<Segment> circle_loop(Vector2d c, double r, bool ccw = true) {
  const double b = ccw ? 1.0 : -1.0;
  return {make_segment(c + Vector2d(r, 0), c - Vector2d(r, 0), b), make_segment(c - Vector2d(r, 0), c + Vector2d(r, 0), b)};
}

std::vector<Segment> concat(std::vector<Segment> a, const std::vector<Segment>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// Every stretch is contiguous and consistent, and consecutive moves meet.
void expect_continuous(const Job& job) {
  Vector2d at = job.start_mm;
  for (const auto& step : job.steps) {
    if (step.kind != Step::Kind::move) continue;
    const Stretch& s = job.stretches.at(step.stretch);
    ASSERT_EQ(s.feed_mm_per_s.size(), s.segments.size());
    ASSERT_EQ(s.source_lines.size(), s.segments.size());
    for (const auto& seg : s.segments) {
      ASSERT_NEAR((seg.start - at).norm(), 0.0, 1e-6) << "stretch " << step.stretch;
      at = seg.end;
    }
  }
}

// The segments [from, from + count) of a stretch as a Contour (asserting that they close).
Contour loop_of(const Stretch& s, std::size_t from, std::size_t count) {
  std::vector<Vector2d> v;
  std::vector<double> b;
  for (std::size_t i = from; i < from + count; ++i) {
    v.push_back(s.segments[i].start);
    b.push_back(s.segments[i].is_arc() ? std::tan(s.segments[i].sweep / 4) : 0.0);
  }
  EXPECT_NEAR((s.segments[from + count - 1].end - s.segments[from].start).norm(), 0.0, 1e-6);
  return Contour(v, b);
}

void expect_all_at(const std::vector<Segment>& segs, const Contour& original, double d) {
  for (const auto& s : segs)
    for (double t : {0.0, 0.3, 0.5, 0.9, 1.0})
      ASSERT_NEAR(distance(original, point_at(s, t)), d, 1e-6);
}

int count_kind(const KerfReport& r, KerfIssue::Kind k) {
  int n = 0;
  for (const auto& i : r.issues) n += i.kind == k;
  return n;
}

// A 60 x 40 plate with a 10 mm hole: the hole is pierced at its centre and led in radially,
// the plate is pierced outside its corner and led in diagonally.
Job plate_job(bool plate_ccw, bool hole_ccw) {
  const Vector2d hc(30, 20);
  std::vector<Stretch> st;
  st.push_back(rapid({-20, -20}, hc, 1));
  st.push_back(cut(concat({straight(hc, hc + Vector2d(5, 0))}, circle_loop(hc, 5, hole_ccw)), 10));
  st.push_back(rapid(hc + Vector2d(5, 0), {-5, -5}, 20));
  st.push_back(cut(concat({straight({-5, -5}, {0, 0})}, rect_loop(0, 0, 60, 40, plate_ccw)), 30));
  st.push_back(rapid({0, 0}, {-20, -20}, 40));
  return make(st);
}

TEST(Kerf, PlateGrowsHoleShrinksWhateverTheDirection) {
  const double kerf = 2.0;
  for (bool plate_ccw : {true, false})
    for (bool hole_ccw : {true, false}) {
      const Job before = plate_job(plate_ccw, hole_ccw);
      Job job = before;
      const KerfReport r = apply_kerf(job, kerf);
      ASSERT_EQ(r.loops.size(), 2u);
      EXPECT_EQ(r.compensated_count(), 2u);
      EXPECT_TRUE(r.issues.empty()) << r.brief();
      for (const auto& l : r.loops) {
        EXPECT_EQ(l.depth, l.stretch == 1 ? 1 : 0);
        EXPECT_DOUBLE_EQ(l.offset_mm, l.stretch == 1 ? -1.0 : 1.0);
      }
      expect_continuous(job);

      // Hole: lead-in from the centre kept, a circle of radius 4.
      const Stretch& hole = job.stretches[1];
      EXPECT_EQ(hole.segments.front().start, Vector2d(30, 20));
      const Contour hole_loop = loop_of(hole, 1, hole.segments.size() - 1);
      EXPECT_NEAR(std::abs(signed_area(hole_loop)), kPi * 16, 1e-9);
      EXPECT_EQ(orientation(hole_loop), hole_ccw ? Orientation::ccw : Orientation::cw);
      EXPECT_NEAR((hole.segments.front().end - Vector2d(34, 20)).norm(), 0, 1e-9);

      // Plate: pierce kept, the loop 1 mm outside the rectangle with rounded corners.
      const Stretch& plate = job.stretches[3];
      EXPECT_EQ(plate.segments.front().start, Vector2d(-5, -5));
      const Contour plate_loop = loop_of(plate, 1, plate.segments.size() - 1);
      EXPECT_NEAR(std::abs(signed_area(plate_loop)), 2400 + 200 * 1 + kPi, 1e-9);
      EXPECT_EQ(orientation(plate_loop), plate_ccw ? Orientation::ccw : Orientation::cw);
      const Contour original = loop_of(before.stretches[3], 1, 4);
      expect_all_at({plate.segments.begin() + 1, plate.segments.end()}, original, 1.0);
      // The loop starts where the first side's offset starts: (0, -1) going along x, (-1, 0)
      // going along y.
      EXPECT_NEAR((plate.segments.front().end - (plate_ccw ? Vector2d(0, -1) : Vector2d(-1, 0))).norm(), 0, 1e-9);
      // Feeds and lines come from the programmed spans.
      for (std::size_t i = 1; i < plate.segments.size(); ++i) {
        EXPECT_GE(plate.source_lines[i], 31);
        EXPECT_LE(plate.source_lines[i], 34);
        EXPECT_EQ(plate.feed_mm_per_s[i], 20.0);
      }
      // Rapids and steps are untouched here (every cut has a lead-in and ends on its loop,
      // whose end moved: the following rapid starts at the new end).
      EXPECT_EQ(job.steps.size(), before.steps.size());
      EXPECT_EQ(job.stretches[2].segments.back().end, before.stretches[2].segments.back().end);
    }
}

// With kerf_from_materials each closed cut takes its material's kerf (the torch_on before it),
// a cut whose material gives none the width passed (0: as programmed).
TEST(Kerf, EachCutTakesItsMaterialsKerf) {
  Job job = plate_job(true, true);  // stretch 1 the hole, 3 the plate
  job.materials.resize(2);
  job.materials[0].kerf_mm = 3.0;
  job.materials[1].kerf_mm = 0.0;  // no KERF_WIDTH in the file
  int torch_ons = 0;
  for (Step& st : job.steps)
    if (st.kind == Step::Kind::torch_on) st.material = torch_ons++ == 0 ? 0 : 1;
  ASSERT_EQ(torch_ons, 2);
  KerfOptions o;
  o.kerf_from_materials = true;
  const auto offsets = [](const KerfReport& r) {
    std::map<std::size_t, double> m;
    for (const auto& l : r.loops) m[l.stretch] = l.compensated ? l.offset_mm : 0.0;
    return m;
  };
  Job a = job;
  const KerfReport none = apply_kerf(a, 0.0, o);  // the plate's material has no kerf: as programmed
  EXPECT_EQ(offsets(none), (std::map<std::size_t, double>{{1, -1.5}, {3, 0.0}})) << none.brief();
  EXPECT_TRUE(none.kerf_from_materials);
  EXPECT_NE(none.brief().find("kerf of each cut's material"), std::string::npos) << none.brief();
  Job b = job;
  const KerfReport fallback = apply_kerf(b, 1.0, o);  // ... or by the width given
  EXPECT_EQ(offsets(fallback), (std::map<std::size_t, double>{{1, -1.5}, {3, 0.5}})) << fallback.brief();
  expect_continuous(b);
  Job c = job;
  const KerfReport plain = apply_kerf(c, 1.0);  // materials ignored unless asked for
  EXPECT_EQ(offsets(plain), (std::map<std::size_t, double>{{1, -0.5}, {3, 0.5}})) << plain.brief();
}

TEST(Kerf, NestingDecidesTheSide) {
  // Sheet outline, a hole in it, a part inside the hole, a hole in that part.
  std::vector<Stretch> st;
  st.push_back(cut(rect_loop(30, 30, 70, 70), 100));   // depth 1: hole
  st.push_back(cut(rect_loop(0, 0, 100, 100), 200));   // depth 0: part
  st.push_back(cut(rect_loop(40, 40, 60, 60), 300));   // depth 2: part inside the hole
  st.push_back(cut(circle_loop({50, 50}, 4), 400));    // depth 3: its hole
  std::vector<Stretch> all;
  Vector2d at(-10, -10);
  int l = 1;
  for (auto& s : st) {
    all.push_back(rapid(at, s.segments.front().start, l++));
    at = s.segments.back().end;
    all.push_back(std::move(s));
  }
  Job job = make(all);
  const KerfReport r = apply_kerf(job, 3.0);
  ASSERT_EQ(r.loops.size(), 4u);
  const int depth_of[] = {1, 0, 2, 3};
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(r.loops[k].stretch, 2 * k + 1);
    EXPECT_EQ(r.loops[k].depth, depth_of[k]);
    EXPECT_DOUBLE_EQ(r.loops[k].offset_mm, depth_of[k] % 2 ? -1.5 : 1.5);
    EXPECT_TRUE(r.loops[k].compensated);
  }
  expect_continuous(job);
  auto area = [&](std::size_t stretch) {
    const Stretch& s = job.stretches[stretch];
    return std::abs(signed_area(loop_of(s, 0, s.segments.size())));
  };
  EXPECT_NEAR(area(1), 37.0 * 37.0, 1e-9);                          // hole 40 shrunk
  EXPECT_NEAR(area(3), 100 * 100 + 400 * 1.5 + kPi * 2.25, 1e-9);  // sheet outline grown
  EXPECT_NEAR(area(5), 20 * 20 + 80 * 1.5 + kPi * 2.25, 1e-9);      // inner part grown
  EXPECT_NEAR(area(7), kPi * 2.5 * 2.5, 1e-9);                      // its hole shrunk
  // No lead-ins: the rapids before and after each cut were re-aimed onto the new loops.
  EXPECT_NEAR((job.stretches[4].segments.back().end - Vector2d(40, 38.5)).norm(), 0, 1e-9);
  EXPECT_NEAR((job.stretches[2].segments.front().start - Vector2d(31.5, 31.5)).norm(), 0, 1e-9);
}

TEST(Kerf, OvercutFollowsTheNewLoopAndLeadOutKeepsItsEnd) {
  // A 12 mm radius hole: lead-in arc from inside, the circle, a 3 mm overcut along it, a
  // lead-out line back towards the centre.
  const Vector2d c(0, 0);
  const double r = 12.0, kerf = 2.0;
  const Vector2d p(r, 0);
  const Segment lead_in = make_segment({6, -6}, p, std::tan(kPi / 8));
  const double over_angle = 3.0 / r;
  const Vector2d q = c + r * Vector2d(std::cos(over_angle), std::sin(over_angle));
  const Segment over = make_segment(p, q, std::tan(over_angle / 4));
  const Segment lead_out = straight(q, {5, 2});
  std::vector<Segment> segs = concat({lead_in}, circle_loop(c, r));
  segs.push_back(over);
  segs.push_back(lead_out);
  Job job = make({rapid({-30, 0}, {6, -6}, 1), cut(segs, 5), rapid({5, 2}, {-30, 0}, 9)});
  const Job before = job;
  const KerfReport rep = apply_kerf(job, kerf);
  ASSERT_EQ(rep.compensated_count(), 1u);
  EXPECT_EQ(rep.loops[0].depth, 0);  // alone on the sheet, a loop is a part boundary
  const Stretch& s = job.stretches[1];
  expect_continuous(job);
  EXPECT_EQ(s.segments.front().start, Vector2d(6, -6));
  EXPECT_TRUE(s.segments.front().is_arc());
  EXPECT_NEAR(s.segments.front().sweep, before.stretches[1].segments.front().sweep, 1e-12);
  EXPECT_NEAR((s.segments.front().end - Vector2d(13, 0)).norm(), 0, 1e-9);
  EXPECT_EQ(s.segments.back().end, Vector2d(5, 2));
  // Segments 1, 2 are the loop (r = 13), then the overcut of the same 3 mm on r = 13.
  ASSERT_EQ(s.segments.size(), 5u);
  for (std::size_t i = 1; i <= 3; ++i) {
    ASSERT_TRUE(s.segments[i].is_arc());
    EXPECT_NEAR(s.segments[i].radius, 13.0, 1e-9);
  }
  EXPECT_NEAR(length(s.segments[3]), 3.0, 1e-9);
  EXPECT_EQ(s.source_lines[3], 8);  // the overcut keeps its line
  EXPECT_EQ(s.source_lines[4], 9);
  // As a hole (inside a sheet outline) the same cut shrinks to r = 11.
  Job job2 = make({rapid({-30, 0}, {6, -6}, 1), cut(segs, 5), rapid({5, 2}, {-50, -50}, 9),
                   cut(rect_loop(-50, -50, 50, 50), 20)});
  apply_kerf(job2, kerf);
  EXPECT_NEAR(job2.stretches[1].segments[1].radius, 11.0, 1e-9);
  EXPECT_NEAR(length(job2.stretches[1].segments[3]), 3.0, 1e-9);
  expect_continuous(job2);
}

TEST(Kerf, OpenCutsAreLeftAndReported) {
  Job job = make({rapid({0, 0}, {10, 10}, 1), cut({straight({10, 10}, {40, 10}), straight({40, 10}, {40, 30})}, 7),
                  rapid({40, 30}, {0, 0}, 9)});
  const Job before = job;
  const KerfReport r = apply_kerf(job, 2.0);
  EXPECT_TRUE(r.loops.empty());
  ASSERT_EQ(r.issues.size(), 1u);
  EXPECT_EQ(r.issues[0].kind, KerfIssue::Kind::open_cut);
  EXPECT_EQ(r.issues[0].source_line, 7);
  EXPECT_EQ(r.issues[0].stretch, 1u);
  EXPECT_EQ(job.stretches[1].segments.size(), 2u);
  EXPECT_EQ(job.stretches[1].segments[1].end, before.stretches[1].segments[1].end);
  EXPECT_NE(r.brief("hand.ngc").find("hand.ngc:7: open_cut"), std::string::npos) << r.brief("hand.ngc");
}

TEST(Kerf, HoleSmallerThanTheKerfIsLeftAsProgrammed) {
  Job job = make({rapid({-20, -20}, {11, 10}, 1), cut({straight({11, 10}, {10.8, 10})}, 3), rapid({10.8, 10}, {-5, -5}, 4),
                  cut(concat({straight({-5, -5}, {0, 0})}, rect_loop(0, 0, 40, 40)), 10)});
  // Replace the hole by a lead-in then a 0.8 mm circle.
  job.stretches[1] = cut(concat({straight({11, 10}, {10.8, 10})}, circle_loop({10, 10}, 0.8)), 3);
  const Job before = job;
  const KerfReport r = apply_kerf(job, 2.0);
  ASSERT_EQ(r.loops.size(), 2u);
  EXPECT_FALSE(r.loops[0].compensated);
  EXPECT_TRUE(r.loops[1].compensated);
  EXPECT_EQ(count_kind(r, KerfIssue::Kind::contour_vanished), 1);
  EXPECT_EQ(count_kind(r, KerfIssue::Kind::arc_collapsed), 2);
  for (const auto& i : r.issues) EXPECT_TRUE(i.source_line == 4 || i.source_line == 5) << i.message;
  ASSERT_EQ(job.stretches[1].segments.size(), before.stretches[1].segments.size());
  for (std::size_t i = 0; i < job.stretches[1].segments.size(); ++i)
    EXPECT_EQ(job.stretches[1].segments[i].end, before.stretches[1].segments[i].end);
  expect_continuous(job);
}

TEST(Kerf, SlotNarrowerThanTheKerfIsReportedWithItsLine) {
  // A 40 x 20 part with a 1.5 wide, 10 deep slot in its top edge; kerf 2 closes the slot.
  const std::vector<Vector2d> v = {{0, 0}, {40, 0}, {40, 20}, {20.75, 20}, {20.75, 10}, {19.25, 10}, {19.25, 20}, {0, 20}};
  std::vector<Segment> loop;
  for (std::size_t i = 0; i < v.size(); ++i) loop.push_back(straight(v[i], v[(i + 1) % v.size()]));
  Job job = make({rapid({-10, -10}, {-3, -3}, 1), cut(concat({straight({-3, -3}, {0, 0})}, loop), 50)});
  const KerfReport r = apply_kerf(job, 2.0);
  ASSERT_EQ(r.compensated_count(), 1u);
  ASSERT_EQ(count_kind(r, KerfIssue::Kind::feature_too_small), 1);
  for (const auto& i : r.issues)
    if (i.kind == KerfIssue::Kind::feature_too_small) { EXPECT_EQ(i.source_line, 54) << i.message; }  // first slot side
  expect_continuous(job);
  const Stretch& s = job.stretches[1];
  const Contour cut_loop = loop_of(s, 1, s.segments.size() - 1);
  EXPECT_TRUE(contains(cut_loop, {20, 15}));  // the torch does not enter the slot
  EXPECT_TRUE(self_intersections(cut_loop, 1e-7).empty());
}

TEST(Kerf, HoleWithANarrowNeckCutsThePieceNearTheLeadIn) {
  // A dumbbell hole (two 10 x 10 lobes, a 1 wide neck) inside a sheet; kerf 2.
  const std::vector<Vector2d> v = {{20, 20}, {30, 20}, {30, 24.5}, {40, 24.5}, {40, 20}, {50, 20},
                                   {50, 30}, {40, 30}, {40, 25.5}, {30, 25.5}, {30, 30}, {20, 30}};
  std::vector<Segment> loop;
  for (std::size_t i = 0; i < v.size(); ++i) loop.push_back(straight(v[i], v[(i + 1) % v.size()]));
  Job job = make({rapid({0, 0}, {25, 25}, 1), cut(concat({straight({25, 25}, {20, 20})}, loop), 10),
                  rapid({20, 20}, {-2, -2}, 30), cut(concat({straight({-2, -2}, {0, 0})}, rect_loop(0, 0, 70, 50)), 31)});
  const KerfReport r = apply_kerf(job, 2.0);
  ASSERT_EQ(r.loops.size(), 2u);
  EXPECT_EQ(r.loops[0].depth, 1);
  EXPECT_EQ(count_kind(r, KerfIssue::Kind::piece_not_cut), 1);
  EXPECT_GE(count_kind(r, KerfIssue::Kind::feature_too_small), 1);
  const Stretch& s = job.stretches[1];
  const Contour cut_loop = loop_of(s, 1, s.segments.size() - 1);
  EXPECT_NEAR(signed_area(cut_loop), 8.0 * 8.0, 1.0);  // the left lobe, 1 mm in
  EXPECT_TRUE(contains(cut_loop, {25, 25}));
  EXPECT_FALSE(contains(cut_loop, {45, 25}));
  EXPECT_NEAR((s.segments.front().end - Vector2d(21, 21)).norm(), 0, 1e-9);
  expect_continuous(job);
}

TEST(Kerf, ConcaveFilletSmallerThanHalfTheKerfIsReported) {
  // A square part with a concave quarter-circle notch of radius 0.5 at one corner.
  const double b = -std::tan(kPi / 8);
  const std::vector<Vector2d> v = {{0, 0}, {20, 0}, {20, 19.5}, {19.5, 20}, {0, 20}};
  std::vector<Segment> loop;
  for (std::size_t i = 0; i < v.size(); ++i) loop.push_back(make_segment(v[i], v[(i + 1) % v.size()], i == 2 ? b : 0.0));
  Job job = make({rapid({-5, -5}, {-2, 0}, 1), cut(concat({straight({-2, 0}, {0, 0})}, loop), 60)});
  const KerfReport r = apply_kerf(job, 3.0);
  ASSERT_EQ(count_kind(r, KerfIssue::Kind::arc_collapsed), 1);
  for (const auto& i : r.issues)
    if (i.kind == KerfIssue::Kind::arc_collapsed) { EXPECT_EQ(i.source_line, 63); }
  expect_continuous(job);
}

TEST(Kerf, LeadOutBackToThePierceIsNotPartOfTheLoop) {
  std::vector<Segment> segs = concat({straight({-4, 5}, {0, 5})}, {straight({0, 5}, {0, 0}), straight({0, 0}, {10, 0}),
                                                                straight({10, 0}, {10, 10}), straight({10, 10}, {0, 10}),
                                                                straight({0, 10}, {0, 5})});
  segs.push_back(straight({0, 5}, {-4, 5}));
  Job job = make({rapid({-10, 5}, {-4, 5}, 1), cut(segs, 2)});
  const KerfReport r = apply_kerf(job, 1.0);
  ASSERT_EQ(r.compensated_count(), 1u);
  const Stretch& s = job.stretches[1];
  EXPECT_EQ(s.segments.front().start, Vector2d(-4, 5));
  EXPECT_EQ(s.segments.back().end, Vector2d(-4, 5));
  EXPECT_NEAR((s.segments.front().end - Vector2d(-0.5, 5)).norm(), 0, 1e-9);
  const Contour l = loop_of(s, 1, s.segments.size() - 2);
  EXPECT_NEAR(signed_area(l), 100 + 40 * 0.5 + kPi * 0.25, 1e-9);
  expect_continuous(job);
}

TEST(Kerf, RandomStarPartsWithHolesKeepTheDistanceProperty) {
  // Seeded random star-shaped parts (about the origin, pierced outside on the ray through
  // their first vertex) with a round hole at the origin (pierced at its centre).
  std::mt19937 rng(1234);
  std::uniform_real_distribution<double> ur(8.0, 25.0), ua(0.0, 2 * kPi), uk(0.3, 3.0);
  int used = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const int n = 3 + trial % 13;
    std::vector<double> ang(n);
    for (auto& a : ang) a = ua(rng);
    std::sort(ang.begin(), ang.end());
    std::vector<Vector2d> v;
    for (double a : ang) v.push_back(ur(rng) * Vector2d(std::cos(a), std::sin(a)));
    if (trial % 2) std::reverse(v.begin(), v.end());
    std::vector<Segment> part;
    for (int i = 0; i < n; ++i) part.push_back(straight(v[i], v[(i + 1) % n]));
    const Contour part_c = loop_of(cut(part, 1), 0, n);
    if (std::abs(signed_area(part_c)) < 1.0 || !self_intersections(part_c, 1e-6).empty()) continue;
    if (!contains(part_c, Vector2d::Zero())) continue;  // the origin must be inside for a hole there
    const double kerf = uk(rng);
    // A hole well clear of the part's edge and larger than the kerf.
    const double hole_r = 0.5 * distance(part_c, Vector2d::Zero());
    if (hole_r < kerf) continue;
    ++used;
    const Vector2d pierce = 1.2 * v[0];
    Job job = make({rapid({-60, -60}, Vector2d::Zero(), 1),
                    cut(concat({straight(Vector2d::Zero(), {hole_r, 0})}, circle_loop({0, 0}, hole_r, trial % 3 == 0)), 10),
                    rapid({hole_r, 0}, pierce, 20), cut(concat({straight(pierce, v[0])}, part), 30)});
    const KerfReport r = apply_kerf(job, kerf);
    const std::string what = "trial " + std::to_string(trial);
    ASSERT_EQ(r.compensated_count(), 2u) << what << "\n" << r.brief();
    expect_continuous(job);
    const Stretch& hole = job.stretches[1];
    const Stretch& p = job.stretches[3];
    EXPECT_EQ(hole.segments.front().start, Vector2d::Zero()) << what;
    EXPECT_EQ(p.segments.front().start, pierce) << what;
    for (std::size_t i = 1; i < hole.segments.size(); ++i)
      for (double t : {0.0, 0.5, 1.0})
        ASSERT_NEAR(point_at(hole.segments[i], t).norm(), hole_r - kerf / 2, 1e-9) << what;
    expect_all_at({p.segments.begin() + 1, p.segments.end()}, part_c, kerf / 2);
    const Contour new_part = loop_of(p, 1, p.segments.size() - 1);
    EXPECT_EQ(orientation(new_part), orientation(part_c)) << what;
    for (const auto& q : part_c.vertices()) EXPECT_TRUE(contains(new_part, q)) << what;
  }
  EXPECT_GE(used, 20);  // the generator gives enough usable parts
}

TEST(Kerf, FirstMoveWithoutLeadInGetsAConnector) {
  Job job = make({cut(rect_loop(0, 0, 10, 10), 4)});
  const KerfReport r = apply_kerf(job, 1.0);
  EXPECT_EQ(count_kind(r, KerfIssue::Kind::connector_added), 1);
  const Stretch& s = job.stretches[0];
  EXPECT_EQ(s.segments.front().start, Vector2d(0, 0));
  EXPECT_NEAR((s.segments.front().end - Vector2d(0, -0.5)).norm(), 0, 1e-9);
  expect_continuous(job);
}

TEST(Kerf, SelfCrossingLoopThrowsWithItsLine) {
  std::vector<Segment> bow = {straight({0, 0}, {10, 10}), straight({10, 10}, {10, 0}), straight({10, 0}, {0, 10}),
                              straight({0, 10}, {-3, 0}), straight({-3, 0}, {0, 0})};
  Job job = make({rapid({-9, -9}, {0, 0}, 1), cut(bow, 12)});
  const Job before = job;
  try {
    apply_kerf(job, 2.0);
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 12);
    EXPECT_NE(std::string(e.what()).find("hand.ngc:12: kerf: the closed cut starting here crosses itself"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(job.stretches[1].segments.size(), before.stretches[1].segments.size());
}

TEST(Kerf, BadWidthAndZeroWidth) {
  Job job = plate_job(true, true);
  try {
    apply_kerf(job, -1.0);
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "kerf_width_mm: is -1, must be finite, >= 0 and <= 100 mm");
  }
  EXPECT_THROW(apply_kerf(job, std::nan("")), InputError);
  KerfOptions o;
  o.closure_tolerance_mm = 0;
  EXPECT_THROW(apply_kerf(job, 1.0, o), InputError);
  const Job before = job;
  const KerfReport r = apply_kerf(job, 0.0);
  EXPECT_TRUE(r.loops.empty());
  EXPECT_EQ(job.stretches[3].segments.size(), before.stretches[3].segments.size());
}

}  // namespace
}  // namespace machplan::motion
