// make_job: grouping of moves into stretches and steps, arc splitting, unit conversion and
// the refusals that name the line.
#include <cmath>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/common/internal/numbers.h"
#include "engine/geometry/contour.h"
#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "engine/programs/program.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using ::testing::HasSubstr;

// The reader wants a program end; append one after the lines under test.
Job job_of(const std::string& gcode, const JobOptions& o = {}) {
  return make_job(read_gcode(gcode + "M2\n", "part.ngc"), o);
}

double stretch_length(const Stretch& s) {
  double l = 0;
  for (const Segment& g : s.segments) l += length(g);
  return l;
}

TEST(MakeJob, GroupsRapidsFeedsAndTorchEvents) {
  const Job job = job_of(
      "G21 G90\n"              // 1
      "G0 X10 Y0\n"            // 2
      "G0 X10 Y10\n"           // 3
      "M3 S1\n"                // 4
      "G1 X20 Y10 F600\n"      // 5
      "G1 X20 Y20\n"           // 6
      "G0 X30 Y20\n"           // 7  rapid with the torch still on
      "G1 X40 Y20 F1200\n"     // 8
      "M5\n"                   // 9
      "G4 P0.5\n"              // 10
      "G0 X0 Y0\n");           // 11
  ASSERT_EQ(job.stretches.size(), 5u);
  EXPECT_EQ(job.source, "part.ngc");
  EXPECT_TRUE(job.stretches[0].rapid);
  EXPECT_FALSE(job.stretches[0].cutting);
  EXPECT_EQ(job.stretches[0].segments.size(), 2u);
  EXPECT_FALSE(job.stretches[1].rapid);
  EXPECT_TRUE(job.stretches[1].cutting);
  EXPECT_EQ(job.stretches[1].segments.size(), 2u);
  EXPECT_NEAR(job.stretches[1].feed_mm_per_s[0], 10.0, 1e-12);  // 600 mm/min
  EXPECT_EQ(job.stretches[1].source_lines, (std::vector<int>{5, 6}));
  EXPECT_TRUE(job.stretches[2].rapid);  // a change feed -> rapid splits
  EXPECT_NEAR(job.stretches[3].feed_mm_per_s[0], 20.0, 1e-12);
  EXPECT_TRUE(job.stretches[4].rapid);
  EXPECT_FALSE(job.stretches[4].cutting);
  EXPECT_NEAR(job.stretches[0].feed_mm_per_s[0], JobOptions{}.rapid_feed_mm_per_s, 1e-12);

  using K = Step::Kind;
  std::vector<K> kinds;
  for (const Step& s : job.steps) kinds.push_back(s.kind);
  EXPECT_EQ(kinds, (std::vector<K>{K::move, K::torch_on, K::move, K::move, K::move, K::torch_off, K::dwell, K::move}));
  EXPECT_EQ(job.steps[1].source_line, 4);
  EXPECT_NEAR(job.steps[6].seconds, 0.5, 1e-12);
  for (const Step& s : job.steps)
    if (s.kind == K::move) { EXPECT_LT(s.stretch, job.stretches.size()); }
  // Contiguity: every stretch starts where the tool is.
  Eigen::Vector2d at = job.start_mm;
  for (const Step& s : job.steps) {
    if (s.kind != K::move) continue;
    for (const Segment& g : job.stretches[s.stretch].segments) {
      EXPECT_LT((g.start - at).norm(), 1e-9);
      at = g.end;
    }
  }
}

TEST(MakeJob, FullCircleAndExtraTurnsAreSplitIntoArcsOfLessThanAFullTurn) {
  const Job job = job_of("G21 G90 G0 X10 Y0\nG3 X10 Y0 I-10 J0 F600\nG2 X0 Y10 I-10 J0 P3\n");
  ASSERT_EQ(job.stretches.size(), 2u);
  const Stretch& s = job.stretches[1];
  double ccw_sweep = 0, cw_sweep = 0;
  for (std::size_t i = 0; i < s.segments.size(); ++i) {
    const Segment& g = s.segments[i];
    ASSERT_TRUE(g.is_arc());
    EXPECT_LT(std::abs(g.sweep), 2 * kPi);
    EXPECT_NEAR(g.radius, 10.0, 1e-12);
    (s.source_lines[i] == 2 ? ccw_sweep : cw_sweep) += g.sweep;
    if (i > 0) { EXPECT_LT((g.start - s.segments[i - 1].end).norm(), 1e-9); }
    // The end point lies on the circle at the end angle.
    const Eigen::Vector2d e = g.center + g.radius * Eigen::Vector2d(std::cos(g.end_angle()), std::sin(g.end_angle()));
    EXPECT_LT((e - g.end).norm(), 1e-9);
  }
  EXPECT_NEAR(ccw_sweep, 2 * kPi, 1e-9);
  // Clockwise from (10,0) to (0,10) about the origin: 3/4 turn, plus 2 extra turns (P3).
  EXPECT_NEAR(cw_sweep, -(1.5 * kPi + 4 * kPi), 1e-9);
  EXPECT_NEAR(stretch_length(s), 10 * (2 * kPi + 5.5 * kPi), 1e-6);
}

TEST(MakeJob, ZeroLengthMovesAreDropped) {
  const Job job = job_of("G21 G90 G1 X0 Y0 F600\nG1 X5 F600\nG1 X5\nG0 X5\n");
  ASSERT_EQ(job.stretches.size(), 1u);
  EXPECT_EQ(job.stretches[0].segments.size(), 1u);
  EXPECT_EQ(job.stretches[0].source_lines[0], 2);
}

TEST(MakeJob, RefusesZMotionNamingTheLine) {
  const std::string msg = test::error_of([] { job_of("G21 G90\nG0 X1\nG0 Z5\n"); });
  EXPECT_THAT(msg, HasSubstr("part.ngc:3:"));
  EXPECT_THAT(msg, HasSubstr("Z is not programmable"));
}

TEST(MakeJob, RefusesHelicalArcs) {
  const std::string msg = test::error_of([] { job_of("G21 G90\nG0 X10\nG2 X0 Y-10 I-10 Z-1 F100\n"); });
  EXPECT_THAT(msg, HasSubstr("part.ngc:3:"));
  EXPECT_THAT(msg, HasSubstr("helical"));
}

TEST(MakeJob, RefusesFeedMovesWithoutFeed) {
  // The reader itself may refuse G1 without F; build the Program by hand to reach make_job.
  Program p;
  p.source = "hand.ngc";
  Move m;
  m.kind = Move::Kind::line;
  m.line = 7;
  m.end = Eigen::Vector3d(5, 0, 0);
  m.feed_mm_per_min = 0.0;
  p.moves.push_back(m);
  const std::string msg = test::error_of([&] { make_job(p); });
  EXPECT_THAT(msg, HasSubstr("hand.ngc:7:"));
  EXPECT_THAT(msg, HasSubstr("no feed"));
}

TEST(MakeJob, OptionsValidateNamesTheField) {
  JobOptions o;
  o.rapid_feed_mm_per_s = -1;
  try {
    o.validate();
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("rapid_feed_mm_per_s"));
    EXPECT_THAT(e.what(), HasSubstr("-1"));
  }
}

}  // namespace
}  // namespace machplan::motion
