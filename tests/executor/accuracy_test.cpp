// Planned mode at 80 mm/s on the thermal gantry with every plant effect on (0.7 drive gain
// uncalibrated, Coulomb and viscous friction, backlash, speed noise, DAC and encoder
// quantisation, one tick of latency each way): the contour error while the torch burns stays
// within 0.1 mm, measured from the encoders and from the simulated truth.
#include <cstdio>

#include <gtest/gtest.h>

#include "models/cutting/machine_config.h"
#include "tests/support/simulate.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

cutting::MachineConfig checked_gantry() {
  auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  // The test means nothing unless the effects are really on.
  for (const auto& a : m.axes) {
    EXPECT_EQ(a.plant.gain_factor, 0.7);
    EXPECT_GT(a.plant.coulomb_friction_mm_per_s, 0.0);
    EXPECT_GT(a.plant.viscous_friction_ratio, 0.0);
    EXPECT_GT(a.plant.backlash_mm, 0.0);
    EXPECT_GT(a.plant.command_latency_ticks + a.plant.reading_latency_ticks, 0);
    EXPECT_EQ(a.plant.dac_bits, 12);
    EXPECT_EQ(a.plant.decoding, 4);
  }
  return m;
}

ExecutionResult run_line(const cutting::MachineConfig& m, Eigen::Vector2d a, Eigen::Vector2d b, std::uint64_t seed) {
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(a, b, 80, m.limits.acceleration_mm_per_s2));
  sim::SimOptions so;
  so.seed = seed;
  return test::simulate(m, cut.job, cut.trajectories, {}, so);
}

ExecutionResult run_circle(const cutting::MachineConfig& m, double R, bool ccw, std::uint64_t seed) {
  const Eigen::Vector2d c(1000, 1000);
  auto segs = test::circle_segments(c, R);
  double sweep = 2 * M_PI;
  if (!ccw) {  // the same circle clockwise: reversed spans
    const Eigen::Vector2d a = c + Eigen::Vector2d(R, 0), b = c - Eigen::Vector2d(R, 0);
    segs = {make_segment(a, b, -1.0), make_segment(b, a, -1.0)};
    sweep = -sweep;
  }
  auto cut = test::one_cut(test::make_stretch(segs, 80, true),
                           std::make_unique<test::ArcTrajectory>(c, R, 0, sweep, 80, m.limits.acceleration_mm_per_s2));
  sim::SimOptions so;
  so.seed = seed;
  return test::simulate(m, cut.job, cut.trajectories, {}, so);
}

void expect_within(const ExecutionResult& r, const char* what) {
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  ASSERT_EQ(r.cuts.size(), 1u);
  const CutError& c = r.cuts[0];
  EXPECT_TRUE(c.complete);
  EXPECT_GT(c.samples, 1000u);
  std::printf("%-28s max %.4f mm rms %.4f mm (true: max %.4f rms %.4f)\n", what, c.max_mm, c.rms_mm, c.max_true_mm,
              c.rms_true_mm);
  EXPECT_LE(c.max_mm, 0.1) << what;
  EXPECT_LE(c.max_true_mm, 0.1) << what;
}

TEST(PlannedAccuracy, StraightLinesAt80) {
  const auto m = checked_gantry();
  for (std::uint64_t seed : {1, 2, 3}) {
    expect_within(run_line(m, {100, 100}, {400, 250}, seed), "line 26.6 deg, 335 mm");
    expect_within(run_line(m, {500, 100}, {300, 300}, seed), "line 135 deg, 283 mm");
    expect_within(run_line(m, {100, 600}, {400, 600}, seed), "line along X, 300 mm");
  }
}

TEST(PlannedAccuracy, CircleR50At80) {
  const auto m = checked_gantry();
  for (std::uint64_t seed : {1, 2, 3}) {
    expect_within(run_circle(m, 50, true, seed), "circle R50 ccw");
    expect_within(run_circle(m, 50, false, seed), "circle R50 cw");
  }
}

// The learned feed-forward is what copes with the 0.7 drive: with it frozen at the nominal
// gain, the same PID misses the budget on the circle.
TEST(PlannedAccuracy, WithoutTheAdaptiveFeedForwardTheCircleFails) {
  auto m = checked_gantry();
  for (auto& a : m.axes) a.servo.ff_adaptation_per_s2 = 0;
  const ExecutionResult r = run_circle(m, 50, true, 1);
  ASSERT_EQ(r.summary.status, Status::done);
  std::printf("circle R50, fixed FF: max %.4f mm\n", r.cuts[0].max_true_mm);
  EXPECT_GT(r.cuts[0].max_true_mm, 0.15);
}

}  // namespace
}  // namespace machplan::executor
