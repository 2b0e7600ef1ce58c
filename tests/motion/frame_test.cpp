// Contracts of engine/motion/frame.h on jobs made from G-code: the outline is the rectangle
// round the cuts as they run (arcs by their true extent), grown by the margin; the frame starts
// and ends where the job starts, never lights the torch, traces the outline once; a job with
// no cut is framed by its feed moves, one with no feed move is refused, bad options name their
// field.
#include "engine/motion/frame.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

Job gcode_job(const std::string& gcode) { return make_job(read_gcode(gcode, "part.ngc")); }

// Valid options: 25 mm/s along the outline, rapids at 200 mm/s.
FrameOptions valid() {
  FrameOptions o;
  o.feed_mm_per_s = 25;
  o.rapid_feed_mm_per_s = 200;
  return o;
}

// A square 100..150 x 100..150 and a circle of radius 20 about (300, 120): the circle's
// extent (280 .. 320, 100 .. 140) is wider than its end points (320, 120).
const char* kTwoParts =
    "G21 G90 G17\n"
    "G0 X10 Y20\n"
    "G0 X100 Y100\nM3 S1\nG1 X150 Y100 F3000\nG1 X150 Y150\nG1 X100 Y150\nG1 X100 Y100\nM5\n"
    "G0 X320 Y120\nM3 S1\nG3 X320 Y120 I-20 J0 F3000\nM5\n"
    "G0 X10 Y20\nM2\n";

TEST(Frame, TheOutlineIsTheRectangleRoundTheCutsArcsByTheirExtent) {
  const Job job = gcode_job(kTwoParts);
  const Frame f = frame_job(job, valid());
  EXPECT_TRUE(f.from_cuts);
  EXPECT_NEAR(f.outline.min().x(), 100.0, 1e-9);
  EXPECT_NEAR(f.outline.min().y(), 100.0, 1e-9);
  EXPECT_NEAR(f.outline.max().x(), 320.0, 1e-9);
  EXPECT_NEAR(f.outline.max().y(), 150.0, 1e-9);  // the circle reaches 140 only
  FrameOptions o = valid();
  o.margin_mm = 5;
  const Frame grown = frame_job(job, o);
  EXPECT_NEAR(grown.outline.min().x(), 95.0, 1e-9);
  EXPECT_NEAR(grown.outline.max().y(), 155.0, 1e-9);
}

TEST(Frame, StartsAndEndsAtTheJobsStartTorchOffTracingTheOutlineOnce) {
  const Job job = gcode_job(kTwoParts);
  const Frame f = frame_job(job, valid());
  EXPECT_EQ(f.job.start_mm, job.start_mm);
  ASSERT_EQ(f.job.steps.size(), 3u);
  double traced = 0;
  Vector2d at = f.job.start_mm;
  for (const Step& s : f.job.steps) {
    ASSERT_EQ(s.kind, Step::Kind::move);  // never a torch_on
    const Stretch& st = f.job.stretches.at(s.stretch);
    EXPECT_FALSE(st.cutting);
    for (std::size_t i = 0; i < st.segments.size(); ++i) {
      EXPECT_LT((st.segments[i].start - at).norm(), 1e-9) << "the path is continuous";
      at = st.segments[i].end;
      EXPECT_EQ(st.feed_mm_per_s[i], st.rapid ? 200.0 : 25.0);
      if (!st.rapid) {
        traced += length(st.segments[i]);
        // Every traced point lies on the outline's boundary.
        const Vector2d m = point_at(st.segments[i], 0.5);
        const bool on_x = std::abs(m.x() - f.outline.min().x()) < 1e-9 || std::abs(m.x() - f.outline.max().x()) < 1e-9;
        const bool on_y = std::abs(m.y() - f.outline.min().y()) < 1e-9 || std::abs(m.y() - f.outline.max().y()) < 1e-9;
        EXPECT_TRUE(on_x || on_y);
      }
    }
  }
  EXPECT_LT((at - job.start_mm).norm(), 1e-9) << "back where the job starts";
  EXPECT_NEAR(traced, 2 * (220.0 + 50.0), 1e-9);
  EXPECT_TRUE(f.job.stretches[0].rapid);
  EXPECT_FALSE(f.job.stretches[1].rapid);
  EXPECT_TRUE(f.job.stretches[2].rapid);
}

TEST(Frame, AJobThatCutsNothingIsFramedByItsFeedMovesOneWithoutIsRefused) {
  const Frame marking = frame_job(gcode_job("G21 G90\nG0 X0 Y0\nG1 X40 Y10 F600\nG1 X60 Y-5\nM2\n"), valid());
  EXPECT_FALSE(marking.from_cuts);
  EXPECT_NEAR(marking.outline.min().y(), -5.0, 1e-9);
  EXPECT_NEAR(marking.outline.max().x(), 60.0, 1e-9);
  try {
    frame_job(gcode_job("G21 G90\nG0 X0 Y0\nG0 X50 Y50\nM2\n"), valid());
    FAIL() << "a job of rapids only has no outline";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("part.ngc"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no outline to frame"), std::string::npos) << e.what();
  }
}

TEST(Frame, BadOptionsNameTheirField) {
  const Job job = gcode_job(kTwoParts);
  const auto field_of = [&](FrameOptions o) {
    try {
      frame_job(job, o);
    } catch (const InputError& e) {
      return e.where();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(field_of(valid()), "accepted");
  FrameOptions o = valid();
  o.feed_mm_per_s = 0;  // plan_frame's "the machine's rapid speed"; frame_job needs a speed
  EXPECT_EQ(field_of(o), "feed_mm_per_s");
  o = valid();
  o.rapid_feed_mm_per_s = NAN;
  EXPECT_EQ(field_of(o), "rapid_feed_mm_per_s");
  o = valid();
  o.margin_mm = -1;
  EXPECT_EQ(field_of(o), "margin_mm");
  o.margin_mm = 2000;
  EXPECT_EQ(field_of(o), "margin_mm");
}

// A laser pointer's offset: the outline stays the cuts' rectangle, the axes trace it less the
// offset (so that the dot traces it), from the job's start and back.
TEST(Frame, APointerOffsetShiftsTheTracedPathNotTheOutline) {
  const Job job = gcode_job(kTwoParts);
  FrameOptions o = valid();
  const Frame plain = frame_job(job, o);
  o.pointer_offset_mm = {60.0, -5.0};
  const Frame laser = frame_job(job, o);
  EXPECT_TRUE(laser.outline.isApprox(plain.outline));
  ASSERT_EQ(laser.job.stretches.size(), 3u);
  const Stretch& traced = laser.job.stretches[1];
  EXPECT_TRUE(traced.segments.front().start.isApprox(plain.outline.min() - o.pointer_offset_mm));
  for (std::size_t k = 0; k < traced.segments.size(); ++k)
    EXPECT_TRUE((traced.segments[k].end + o.pointer_offset_mm).isApprox(plain.job.stretches[1].segments[k].end));
  EXPECT_TRUE(laser.job.stretches.back().segments.back().end.isApprox(job.start_mm));
  o.pointer_offset_mm = {NAN, 0.0};
  EXPECT_THROW(frame_job(job, o), InputError);
  o.pointer_offset_mm = {2000.0, 0.0};
  EXPECT_THROW(frame_job(job, o), InputError);
}

}  // namespace
}  // namespace machplan::motion
