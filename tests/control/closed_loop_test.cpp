// Every controller of the factory in the executor's loop on the simulated XY table (friction,
// noise, quantisation, one period of latency each way): Koren's two test contours, a line at
// 26.6 degrees at 1.2 m/min and a 20 mm radius circle at 0.96 m/min. Each must stay stable
// (complete, bounded error) and the comparisons the controllers exist for must hold.
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "engine/control/controller_factory.h"
#include "models/cutting/controller_plant.h"
#include "tests/support/simulate.h"
#include "tests/support/test_trajectory.h"

namespace machplan::control {
namespace {

struct ContourError {
  double max_mm = 0, rms_mm = 0;
  bool completed = false;
};

const cutting::MachineConfig& table() {
  static const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("xy_table"));
  return m;
}

enum class Shape { line, circle };
const Eigen::Vector2d kLineFrom(100, 100), kCentre(200, 175);
constexpr double kLineDeg = 26.6, kLineLen = 80, kLineFeed = 20;  // 1.2 m/min
constexpr double kRadius = 20, kCircleFeed = 16;                   // 0.96 m/min

// Runs one move (no torch: the table carries a tool) and measures the true position's
// distance from the programmed line or circle over the move's ticks.
ContourError run(const std::string& kind, const Gains& gains, Shape shape, double circle_feed = kCircleFeed) {
  const cutting::MachineConfig& m = table();
  const double acc = m.limits.acceleration_mm_per_s2;
  motion::Job job;
  job.source = "closed_loop_test";
  std::unique_ptr<motion::Trajectory> traj;
  motion::Stretch st;
  const double th = kLineDeg * M_PI / 180;
  const Eigen::Vector2d dir(std::cos(th), std::sin(th)), to = kLineFrom + kLineLen * dir;
  const Eigen::Vector2d start = kCentre + Eigen::Vector2d(kRadius, 0);
  if (shape == Shape::line) {
    st.segments = {make_segment(kLineFrom, to, 0.0)};
    traj = std::make_unique<test::LineTrajectory>(kLineFrom, to, kLineFeed, acc);
  } else {
    const Eigen::Vector2d opposite = kCentre - Eigen::Vector2d(kRadius, 0);
    st.segments = {make_segment(start, opposite, 1.0), make_segment(opposite, start, 1.0)};
    traj = std::make_unique<test::ArcTrajectory>(kCentre, kRadius, 0, 2 * M_PI, circle_feed, acc);
  }
  st.feed_mm_per_s.assign(st.segments.size(), shape == Shape::line ? kLineFeed : circle_feed);
  st.source_lines.assign(st.segments.size(), 1);
  job.start_mm = st.segments.front().start;
  job.stretches.push_back(st);
  job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  executor::Trajectories trajs;
  trajs.push_back(std::move(traj));

  auto c = make_controller(kind, gains, cutting::controller_plant(m));
  session::MachineSession::RunHooks hooks;
  hooks.controller = c.get();
  sim::SimOptions so;
  so.seed = 1;
  const executor::ExecutionResult r = test::simulate(m, job, trajs, {}, so, hooks);
  ContourError e;
  e.completed = r.summary.done();
  double sum2 = 0;
  std::size_t n = 0;
  for (const executor::TraceSample& s : r.trace) {
    if (s.step != 0) continue;
    const Eigen::Vector2d p = s.true_mm;
    const double d = shape == Shape::line ? std::abs((p - kLineFrom).x() * dir.y() - (p - kLineFrom).y() * dir.x())
                                          : std::abs((p - kCentre).norm() - kRadius);
    e.max_mm = std::max(e.max_mm, d);
    sum2 += d * d;
    ++n;
  }
  e.rms_mm = n ? std::sqrt(sum2 / n) : 0;
  EXPECT_GT(n, 1000u) << kind;
  return e;
}

ContourError report(const std::string& kind, const Gains& g, Shape s, const char* label = "",
                    double circle_feed = kCircleFeed) {
  const ContourError e = run(kind, g, s, circle_feed);
  std::printf("%-7s %-28s %-6s max %.5f mm  rms %.5f mm\n", kind.c_str(), label,
              s == Shape::line ? "line" : (circle_feed == kCircleFeed ? "circle" : "fast circle"), e.max_mm, e.rms_mm);
  EXPECT_TRUE(e.completed) << kind << " " << label;
  return e;
}

// Stability: with its defaults every kind completes both contours with a bounded error (the
// P baseline lags 20 mm/s / 150 /s = 0.13 mm along the path; nothing may be ten times worse
// across it).
TEST(ClosedLoop, EveryKindIsStableOnTheLineAndTheCircle) {
  for (const std::string& kind : controller_kinds())
    for (Shape s : {Shape::line, Shape::circle}) {
      const ContourError e = report(kind, {}, s, "defaults");
      EXPECT_LT(e.max_mm, 0.1) << kind;
      EXPECT_GT(e.max_mm, 0.0) << kind;  // the measurement measures something
    }
}

// The contour loop stiffens the machine across the path only. With the defaults (Wp = Kp)
// it takes about a third off the axial P's contour error, on the circle (where Coulomb friction
// at each quadrant is the error) and on the line; a contour integral removes most of what is
// left, Koren's 5 : 1 in RMS (measured: circle P max 16.6 rms 7.9 um, CCC 11.2 / 4.1, CCC + Wi
// 13.1 / 1.7; line P 7.1 / 5.5, CCC + Wi 4.8 / 1.0).
TEST(ClosedLoop, CrossCoupledBeatsTheAxialPOnBothContours) {
  const ContourError p_circle = report("p", {}, Shape::circle), p_line = report("p", {}, Shape::line);
  const ContourError c_circle = report("ccc", {}, Shape::circle), c_line = report("ccc", {}, Shape::line);
  const ContourError ci_circle = report("ccc", {{"ccc_ki_per_s2", 10000.0}}, Shape::circle, "Wi 10000");
  EXPECT_LT(c_circle.max_mm, 0.8 * p_circle.max_mm);
  EXPECT_LT(c_circle.rms_mm, 0.7 * p_circle.rms_mm);
  EXPECT_LT(c_line.max_mm, 0.8 * p_line.max_mm);
  EXPECT_LT(c_line.rms_mm, 0.7 * p_line.rms_mm);
  const ContourError ci_line = report("ccc", {{"ccc_ki_per_s2", 10000.0}}, Shape::line, "Wi 10000");
  EXPECT_LT(ci_circle.rms_mm, p_circle.rms_mm / 4);
  EXPECT_LT(ci_line.rms_mm, p_line.rms_mm / 4);
}

// Coulomb friction feed-forward (an option of p, pid and the axial loops of ccc) pre-empts the
// quadrant glitches the feedback can only answer (measured: P max 16.6 rms 7.9 um; with
// Fc = 2 mm/s, the table's friction, 9.7 / 1.6; CCC with it 7.2 / 1.4).
TEST(ClosedLoop, FrictionFeedForwardPreEmptsTheQuadrantGlitches) {
  const ContourError p = report("p", {}, Shape::circle);
  const ContourError pf = report("p", {{"friction_ff_mm_per_s", 2.0}}, Shape::circle, "Fc 2");
  const ContourError cf = report("ccc", {{"friction_ff_mm_per_s", 2.0}}, Shape::circle, "Fc 2");
  EXPECT_LT(pf.max_mm, 0.75 * p.max_mm);
  EXPECT_LT(pf.rms_mm, p.rms_mm / 3);
  EXPECT_LT(cf.max_mm, pf.max_mm);
}

// Koren's servo comparison, qualitatively: at a high feed on the circle (6 m/min) the PID
// without programmed acceleration fails (its integrator overshoots every quadrant), the ZPETC
// tracks better than the P loop it is built on; on the line under friction the ZPETC is no
// better than P and far worse than the PID, whose integrator holds the friction.
TEST(ClosedLoop, ZpetcTracksFastCirclesButNotFrictionOnLines) {
  constexpr double kFast = 100;  // mm/s
  const ContourError p = report("p", {}, Shape::circle, "", kFast);
  const ContourError pid = report("pid", {}, Shape::circle, "", kFast);
  const ContourError z = report("zpetc", {}, Shape::circle, "", kFast);
  EXPECT_LT(z.max_mm, 0.8 * p.max_mm);
  EXPECT_LT(z.rms_mm, 0.8 * p.rms_mm);
  EXPECT_GT(pid.max_mm, 3 * p.max_mm);
  const ContourError z_line = report("zpetc", {}, Shape::line), pid_line = report("pid", {}, Shape::line);
  const ContourError p_line = report("p", {}, Shape::line);
  EXPECT_GT(z_line.rms_mm, 3 * pid_line.rms_mm);
  EXPECT_GT(z_line.rms_mm, 0.9 * p_line.rms_mm);
}

// The fuzzy controller against the PID on Koren's circle: the PID's integrator overshoots
// after each quadrant's friction, the fuzzy controller has no integrator to wind up.
// With the integral of its output (ki_per_s) it also holds the friction, and beats the PID
// on both figures as Koren's did (his: RMS 3.5 x, maximum 18 : 10; measured here: PID max 29.3
// rms 5.6 um, fuzzy + I 15.1 / 1.9).
TEST(ClosedLoop, FuzzyBeatsThePidOnTheCircle) {
  const ContourError pid = report("pid", {}, Shape::circle), flc = report("flc", {}, Shape::circle);
  EXPECT_LT(flc.max_mm, 0.7 * pid.max_mm);
  const ContourError flc_i = report("flc", {{"ki_per_s", 100.0}}, Shape::circle, "ki 100");
  EXPECT_LT(flc_i.max_mm, 0.7 * pid.max_mm);
  EXPECT_LT(flc_i.rms_mm, pid.rms_mm / 2.5);
}

}  // namespace
}  // namespace machplan::control
