// Every controller of the factory in the executor's loop on the simulated XY table (friction,
// noise, quantisation, one period of latency each way): Koren's two test contours, a line at
// 26.6 degrees at 1.2 m/min and a 20 mm radius circle at 0.96 m/min. Each must stay stable
// (complete, bounded error) and the comparisons the controllers exist for must hold.
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "engine/control/controller_factory.h"
#include "models/cutting/controller_plant.h"
#include "models/sim/simulate.h"
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
ContourError run(const std::string& kind, const Gains& gains, Shape shape, std::uint64_t seed = 1) {
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
    traj = std::make_unique<test::ArcTrajectory>(kCentre, kRadius, 0, 2 * M_PI, kCircleFeed, acc);
  }
  st.feed_mm_per_s.assign(st.segments.size(), shape == Shape::line ? kLineFeed : kCircleFeed);
  st.source_lines.assign(st.segments.size(), 1);
  job.start_mm = st.segments.front().start;
  job.stretches.push_back(st);
  job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  executor::Trajectories trajs;
  trajs.push_back(std::move(traj));

  auto c = make_controller(kind, gains, cutting::controller_plant(m));
  executor::RunParts parts;
  parts.controller = c.get();
  sim::SimOptions so;
  so.seed = seed;
  const executor::ExecutionResult r = sim::simulate(m, job, trajs, {}, so, {}, parts);
  ContourError e;
  e.completed = r.status == executor::ExecutionResult::Status::completed;
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

ContourError report(const std::string& kind, const Gains& g, Shape s, const char* label = "") {
  const ContourError e = run(kind, g, s);
  std::printf("%-7s %-22s %-6s max %.5f mm  rms %.5f mm\n", kind.c_str(), label, s == Shape::line ? "line" : "circle",
              e.max_mm, e.rms_mm);
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

}  // namespace
}  // namespace machplan::control
