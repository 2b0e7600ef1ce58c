// Paused motion on the simulated gantry: a cut held, the machine moved along the program's path
// with the torch off (across a corner, back into an earlier cut, at a speed held), and resumed:
// where the arc burned, pass by pass, from the simulator's truth. And the operator's torch
// switch: a job run dry, a cut held by switching the torch off.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/hardware/operator_events.h"
#include "models/cutting/machine_config.h"
#include "solvers/motion/run.h"
#include "tests/support/cut_coverage.h"
#include "tests/support/datasets.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using executor::PausedMotionReport;
using executor::TraceSample;

// Two rectangles, each pierced at its lower left corner and cut anticlockwise at 50 mm/s.
// Lines: 4-7 the first cut's sides, 11-14 the second's.
constexpr const char* kTwoCuts = R"(G21 G90 G17 G40 G94
G0 X100 Y100
M3 S1
G1 X300 Y100 F3000
G1 X300 Y200
G1 X100 Y200
G1 X100 Y100
M5
G0 X400 Y100
M3 S1
G1 X500 Y100 F3000
G1 X500 Y150
G1 X400 Y150
G1 X400 Y100
M5
G0 X0 Y0
M2
)";

constexpr double kKerf = 1.5;

struct PausedRun {
  RunOutcome out;
  Job job;  // the job as run (its stretches, for the coverage)
};

// The time the commanded point first comes within 0.05 mm of `at` with the torch firing, in a
// run without events.
double time_at(const std::vector<TraceSample>& trace, const Eigen::Vector2d& at) {
  for (const TraceSample& s : trace)
    if (s.torch_fire && (s.commanded_mm - at).norm() < 0.05) return s.t_s;
  ADD_FAILURE() << "the cut never passes (" << at.x() << ", " << at.y() << ")";
  return 0.0;
}

// The rapid that ends at `end`, and a stretch's length.
const Stretch& rapid_to(const Job& job, const Eigen::Vector2d& end) {
  for (const Stretch& s : job.stretches)
    if (s.rapid && !s.segments.empty() && (s.segments.back().end - end).norm() < 1e-6) return s;
  throw std::runtime_error("no rapid ends there");
}
double path_mm(const Stretch& s) {
  double l = 0.0;
  for (const Segment& seg : s.segments) l += length(seg);
  return l;
}

class PausedMotion : public ::testing::Test {
 protected:
  void SetUp() override {
    program_ = (dir_.path() / "two_cuts.ngc").string();
    std::ofstream(program_) << kTwoCuts;
    plain_ = run("");
    ASSERT_TRUE(plain_.out.summary.done()) << plain_.out.summary.full_report();
  }
  PausedRun run(const std::string& events) const {
    RunOptions o;
    o.session.machine_config = test::gantry();
    o.session.executor.record_trace = true;
    if (!events.empty())
      o.session.backend.sim.operator_events = hardware::parse_operator_events("t_s,event,value\n" + events, "events.csv").states;
    PausedRun r{run_program(program_, o), {}};
    r.job = r.out.job;
    return r;
  }
  // Held where the cut passes `at`, moved `mm` along the path, resumed `resume_s` later: a run
  // that completes with one paused motion, the torch off while it moved.
  PausedRun held_and_moved(const Eigen::Vector2d& at, double mm, double resume_s) const {
    const double t = time_at(plain_.out.result.trace, at);
    PausedRun r = run(fmt::format("{:.3f},hold,\n{:.3f},paused_motion,{}\n{:.3f},start,\n", t, t + 0.2, mm, t + resume_s));
    const executor::ExecutionResult& x = r.out.result;
    EXPECT_TRUE(r.out.summary.done()) << r.out.summary.full_report();
    EXPECT_EQ(x.paused_motions.size(), 1u) << x.report();
    if (x.paused_motions.empty()) throw std::runtime_error("no paused motion");
    const PausedMotionReport& p = x.paused_motions.front();
    for (const TraceSample& s : x.trace)
      if (s.t_s > p.t_s && s.t_s < p.end_s) EXPECT_FALSE(s.torch_fire) << "the torch fired at " << s.t_s << " s";
    return r;
  }
  // The cutting stretch whose first segment starts at `start`.
  const Stretch& cut_from(const Job& job, const Eigen::Vector2d& start) const {
    for (const Stretch& s : job.stretches)
      if (s.cutting && !s.segments.empty() && (s.segments.front().start - start).norm() < 1e-6) return s;
    throw std::runtime_error("no cut starts there");
  }
  test::TempDir dir_;
  std::string program_;
  PausedRun plain_;
};

// The tracker's case: held 10 mm past a corner, backed up 30 mm along the path (20 mm into the
// previous side), resumed. The arc leaves no gap over half the kerf, and burns twice no more
// than the 30 mm backed over.
TEST_F(PausedMotion, BackedThirtyMillimetresAcrossACornerTheCutHasNoGapAndNoDoublePassBeyondIt) {
  const PausedRun r = held_and_moved({300.0, 110.0}, -30.0, 6.0);
  const executor::ExecutionResult& x = r.out.result;
  const PausedMotionReport& p = x.paused_motions.front();
  EXPECT_NEAR(p.moved_mm, -30.0, 0.05);
  EXPECT_EQ(p.from_line, 5);  // the side along Y ...
  EXPECT_EQ(p.to_line, 4);    // ... back into the side along X
  EXPECT_FALSE(p.by_arc_loss);
  // Where it stopped: 30 mm back along the (blended) path from about (300, 110).
  EXPECT_NEAR(p.to_mm.y(), 100.0, 0.05);
  EXPECT_NEAR(p.to_mm.x(), 300.0 - (30.0 - (p.from_mm.y() - 100.0)), 0.5);
  ASSERT_EQ(x.holds.size(), 1u);
  EXPECT_NEAR(x.holds.front().recovered_mm, p.moved_mm, 1e-9);
  // The resume probed and pierced where it stood.
  ASSERT_EQ(x.probes.size(), 3u);
  EXPECT_LT((x.probes[1].position_mm - p.to_mm).norm(), 0.1);
  const test::CutCoverage c = test::cut_coverage(cut_from(r.job, {100.0, 100.0}), x.trace, kKerf / 2);
  std::printf("held 10 mm past the corner, backed 30 mm: longest gap %.3f mm, cut twice %.3f mm, %d passes\n",
              c.longest_gap_mm, c.double_mm, c.passes);
  EXPECT_EQ(c.passes, 2);
  EXPECT_LE(c.longest_gap_mm, kKerf / 2);
  EXPECT_LE(c.double_mm, 30.0);
  EXPECT_GE(c.double_mm, 29.0);  // it did go back over what was cut
}

// Back from the second cut, over its pierce and the rapid, into the first cut's last side: the
// resume pierces there, finishes the first cut, and cuts the second again from its start.
TEST_F(PausedMotion, BackIntoAnEarlierCutPiercesThereAndRunsOnFromIt) {
  const PausedRun r = held_and_moved({420.0, 100.0}, -330.0, 40.0);
  const executor::ExecutionResult& x = r.out.result;
  const PausedMotionReport& p = x.paused_motions.front();
  EXPECT_NEAR(p.moved_mm, -330.0, 0.05);
  EXPECT_EQ(p.from_line, 11);
  EXPECT_EQ(p.to_line, 7);
  // On the first cut's last side, 330 mm back along the path: over the second cut's first
  // 20 mm and the rapid between the cuts (planned round the part cut first).
  EXPECT_NEAR(p.to_mm.x(), 100.0, 0.05);
  EXPECT_NEAR(p.to_mm.y(), 100.0 + 330.0 - (p.from_mm.x() - 400.0) - path_mm(rapid_to(r.job, {400.0, 100.0})), 0.1);
  // Probes: the two cuts, the re-pierce in the first, the second cut again.
  ASSERT_EQ(x.probes.size(), 4u) << x.report();
  EXPECT_LT((x.probes[2].position_mm - p.to_mm).norm(), 0.1);
  EXPECT_LT((x.probes[3].position_mm - Eigen::Vector2d(400.0, 100.0)).norm(), 0.1);
  const test::CutCoverage first = test::cut_coverage(cut_from(r.job, {100.0, 100.0}), x.trace, kKerf / 2);
  const test::CutCoverage second = test::cut_coverage(cut_from(r.job, {400.0, 100.0}), x.trace, kKerf / 2);
  EXPECT_LE(first.longest_gap_mm, kKerf / 2);
  EXPECT_LE(second.longest_gap_mm, kKerf / 2);
  // The first cut's sides from where the motion stopped, and the second's first 20 mm, twice.
  EXPECT_NEAR(first.double_mm, p.to_mm.y() - 100.0, 0.3);
  EXPECT_NEAR(second.double_mm, p.from_mm.x() - 400.0, 0.3);
}

// The paused-motion speed held (a joystick, HAL's paused-motion-speed): back at the machine's
// paused-motion speed while it is held, at rest once let go; the resume pierces there.
TEST_F(PausedMotion, ASpeedHeldMovesAlongThePathUntilLetGo) {
  const double t = time_at(plain_.out.result.trace, {200.0, 100.0});
  const PausedRun r = run(fmt::format("{:.3f},hold,\n{:.3f},paused_motion_speed,-1\n{:.3f},paused_motion_speed,0\n{:.3f},start,\n",
                                      t, t + 1.0, t + 3.0, t + 5.0));
  const executor::ExecutionResult& x = r.out.result;
  ASSERT_TRUE(r.out.summary.done()) << r.out.summary.full_report();
  ASSERT_EQ(x.paused_motions.size(), 1u) << x.report();
  const double top = test::gantry().setup().torch.paused_motion_speed_mm_per_s;
  // 2 s at the top speed (the ramp down after it is let go makes up for the ramp up).
  EXPECT_NEAR(x.paused_motions.front().moved_mm, -2.0 * top, 0.05);
  EXPECT_LE(x.paused_motions.front().end_s, t + 3.0 + top / 200.0 + 0.01);
}

// At the job's first move the motion stops: it never runs off the program.
TEST_F(PausedMotion, StopsAtTheStartOfTheJob) {
  const PausedRun r = held_and_moved({150.0, 100.0}, -1000.0, 60.0);
  const PausedMotionReport& p = r.out.result.paused_motions.front();
  // Back over the cut (about 50 mm, and the braking) and the first rapid: where the job started.
  const Stretch& first = rapid_to(r.job, {100.0, 100.0});
  EXPECT_LT((p.to_mm - first.segments.front().start).norm(), 0.05);
  EXPECT_NEAR(p.moved_mm, -(p.from_mm.x() - 100.0 + path_mm(first)), 0.1);
}

// The torch switched off before the job: it runs dry, never fires, never probes.
TEST_F(PausedMotion, TheTorchSwitchedOffRunsTheJobDry) {
  const PausedRun r = run("0.0,torch,0\n");
  const executor::ExecutionResult& x = r.out.result;
  ASSERT_TRUE(r.out.summary.done()) << r.out.summary.full_report();
  EXPECT_EQ(x.dry_pierces, 2);
  EXPECT_TRUE(x.probes.empty());
  for (const TraceSample& s : x.trace) ASSERT_FALSE(s.torch_fire) << "the torch fired at " << s.t_s << " s";
  EXPECT_LT(x.cycle_time_s, plain_.out.result.cycle_time_s);  // no pierces
}

// Switched off mid-cut: the torch goes out at once and the job holds; the resume goes on dry
// (the rest of that cut and the next); switched on again before the next cut, that one is cut.
TEST_F(PausedMotion, TheTorchSwitchedOffMidCutHoldsAndTheResumeGoesOnDry) {
  const double t = time_at(plain_.out.result.trace, {200.0, 100.0});
  for (const bool again : {false, true}) {
    SCOPED_TRACE(again ? "switched on again" : "left off");
    const PausedRun r = run(fmt::format("{:.3f},torch,0\n{:.3f},start,\n", t, t + 2.0) +
                            (again ? fmt::format("{:.3f},torch,1\n", t + 2.5) : std::string()));
    const executor::ExecutionResult& x = r.out.result;
    ASSERT_TRUE(r.out.summary.done()) << r.out.summary.full_report();
    ASSERT_EQ(x.holds.size(), 1u);
    EXPECT_TRUE(x.holds.front().by_torch_disable);
    // Out within two periods of the switch, and not lit again in that cut.
    for (const TraceSample& s : x.trace)
      if (s.t_s > t + 0.002 && s.torch_fire) ASSERT_GT(s.commanded_mm.x(), 350.0) << "fired on the first cut at " << s.t_s << " s";
    EXPECT_EQ(x.dry_pierces, again ? 0 : 1);
    EXPECT_EQ(x.probes.size(), again ? 2u : 1u);
  }
}

}  // namespace
}  // namespace machplan::motion
