// Every fault kind, injected at seeded random times during a cut, ends with the torch off, the
// machine at rest, the fault reported with its kind, and no motion commanded after the stop.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/executor/executor.h"
#include "models/axis/plant.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "tests/support/forwarding_backend.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

using FI = sim::FaultInjection;
using FK = FaultReport::Kind;

struct Case {
  FI::Kind inject;
  FK expect;
};

class FaultInjection : public ::testing::TestWithParam<Case> {};

// A cut along a circle of R 50 at 80 mm/s (about 4 s of motion), after the pierce.
test::OneCut circle_cut() {
  const Eigen::Vector2d c(700, 700);
  return test::one_cut(test::make_stretch(test::circle_segments(c, 50), 80, true),
                       std::make_unique<test::ArcTrajectory>(c, 50, 0, 2 * M_PI, 80, 500));
}

TEST_P(FaultInjection, EndsTorchOffAtRestReportedWithNoMotionAfter) {
  const Case cs = GetParam();
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const MachineSetup setup = m.setup();
  std::mt19937_64 rng(1234 + static_cast<int>(cs.inject));
  for (int trial = 0; trial < 4; ++trial) {
    SCOPED_TRACE(::testing::Message() << "trial " << trial);
    auto cut = circle_cut();
    sim::SimOptions so;
    so.seed = 100 + trial;
    so.start_mm = cut.job.start_mm;
    sim::SimBackend sim(m, so);
    // The cut's motion runs from about 1.3 s to 5.3 s of simulated time; inject inside it.
    FI f;
    f.kind = cs.inject;
    f.at_s = 1.5 + 3.5 * axis::uniform01(rng);
    f.axis = static_cast<int>(rng() % 2);
    f.counts = 20 + static_cast<std::int32_t>(rng() % 200);  // jumps of 20..219 counts
    if (f.counts > 235) f.counts = 235;
    sim.inject(f);
    Executor ex(setup, {});
    const ExecutionResult r = ex.run(cut.job, cut.trajectories, sim);

    ASSERT_EQ(r.summary.status, Status::faulted) << r.report();
    ASSERT_EQ(r.faults.size(), 1u);
    const FaultReport& fr = r.faults[0];
    EXPECT_EQ(fr.kind, cs.expect) << fr.message;
    EXPECT_GE(fr.time_s, f.at_s - 1e-9);
    EXPECT_EQ(fr.step, 1);
    // The line of the half circle the tool was on (lines 10 and 11): clear away from the
    // joints; near them the cursor of the segment the tool is on decides.
    ASSERT_TRUE(fr.source_line == 10 || fr.source_line == 11) << fr.source_line;
    const double above = fr.last_known_mm.y() - 700;
    if (std::abs(above) > 5.0) EXPECT_EQ(fr.source_line, above > 0 ? 10 : 11) << fr.last_known_mm.transpose();
    EXPECT_FALSE(fr.message.empty());
    // The last known position: with the encoders still trusted it follows the machine to rest;
    // after a bad reading it is the last good one, on the circle being cut.
    const bool feedback_lost = cs.expect == FK::encoder_glitch || cs.expect == FK::counter_wrap_misread ||
                               cs.expect == FK::lost_backend;
    if (feedback_lost) {
      EXPECT_NEAR((fr.last_known_mm - Eigen::Vector2d(700, 700)).norm(), 50.0, 0.5);
    } else {
      Eigen::Vector2d rest;
      sim.true_position(rest);
      EXPECT_LT((fr.last_known_mm - rest).norm(), 0.1);
    }

    // Torch off from the fault on; off at the end.
    EXPECT_TRUE(r.torch_off_at_end);
    for (const TraceSample& s : r.trace)
      if (s.t_s > fr.time_s) { ASSERT_FALSE(s.torch_fire) << "t " << s.t_s; }

    // The stop: the commanded speed never grows after the fault and keeps its direction, and
    // after the ramp (at most the largest command vector / stop deceleration) every command is
    // zero.
    const double ramp_s = std::sqrt(2.0) * setup.signals[0].dac_full_scale_mm_per_s / setup.max_acceleration_mm_per_s2;
    double last_mag = std::numeric_limits<double>::infinity();
    for (const TraceSample& s : r.trace) {
      if (s.t_s <= fr.time_s) continue;
      const double mag = std::hypot(s.dac_x, s.dac_y);
      EXPECT_LE(mag, last_mag + 1.5) << "t " << s.t_s;  // +1.5: DAC rounding of each axis
      last_mag = mag;
      if (s.t_s > fr.time_s + ramp_s + 0.002) { ASSERT_EQ(mag, 0.0) << "motion commanded after the stop, t " << s.t_s; }
    }

    if (cs.inject == FI::Kind::lost_backend) {
      // Nothing can be commanded; the hardware watchdog stops the machine.
      EXPECT_FALSE(r.stopped_at_rest);
      sim.coast(1.0);
    } else {
      EXPECT_TRUE(r.stopped_at_rest);
      EXPECT_FALSE(r.trace.back().drives_enabled);
    }
    EXPECT_FALSE(sim.torch_firing());
    EXPECT_FALSE(sim.arc_burning());
    for (int a = 0; a < 2; ++a) EXPECT_EQ(sim.plant(a).velocity_mm_per_s(), 0.0) << "axis " << a;
    // And it stays at rest.
    Eigen::Vector2d p0, p1;
    sim.true_position(p0);
    sim.coast(0.5);
    sim.true_position(p1);
    EXPECT_EQ(p0, p1);
  }
}

INSTANTIATE_TEST_SUITE_P(EachKind, FaultInjection,
                         ::testing::Values(Case{FI::Kind::stuck_axis, FK::following_error},
                                           Case{FI::Kind::encoder_glitch, FK::encoder_glitch},
                                           Case{FI::Kind::counter_wrap_misread, FK::counter_wrap_misread},
                                           Case{FI::Kind::estop, FK::estop},
                                           Case{FI::Kind::lost_backend, FK::lost_backend},
                                           Case{FI::Kind::arc_loss, FK::arc_lost}),
                         [](const auto& info) { return std::string(to_string(info.param.expect)); });

TEST(StopRequest, FromAnotherPlaceEndsLikeAFault) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  auto cut = circle_cut();
  sim::SimOptions so;
  so.start_mm = cut.job.start_mm;
  // A backend wrapper that asks the executor to stop after 2.5 s of simulated time.
  struct Stopper final : test::ForwardingBackend {
    sim::SimBackend& sim;
    Termination* stop = nullptr;
    explicit Stopper(sim::SimBackend& s) : ForwardingBackend(s), sim(s) {}
    hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& i) noexcept override {
      if (sim.time_s() >= 2.5) stop->request_stop();
      return ForwardingBackend::exchange(o, i);
    }
  };
  sim::SimBackend sim(m, so);
  Stopper st(sim);
  Executor ex(m.setup(), {});
  Termination stop;
  st.stop = &stop;
  RunParts parts;
  parts.termination = &stop;
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, st, parts);
  ASSERT_EQ(r.faults.size(), 1u);
  EXPECT_EQ(r.faults[0].kind, FK::stop_requested);
  // A stop asked for is how the run was meant to end, not a fault of the machine.
  EXPECT_EQ(r.summary.status, Status::cancelled);
  EXPECT_EQ(r.summary.message, r.faults[0].message);
  EXPECT_NE(r.report().find(": cancelled\n"), std::string::npos) << r.report();
  EXPECT_EQ(r.report().find("FAULTED"), std::string::npos) << r.report();
  EXPECT_NEAR(r.faults[0].time_s, 2.5, 0.003);
  EXPECT_FALSE(sim.torch_firing());
  EXPECT_EQ(sim.plant(0).velocity_mm_per_s(), 0.0);
  EXPECT_EQ(sim.plant(1).velocity_mm_per_s(), 0.0);
  EXPECT_FALSE(r.cuts[0].complete);
}

TEST(StopRequest, ADeadlineInMachineTimeEndsTheRunAsDeadline) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  auto cut = circle_cut();
  sim::SimOptions so;
  so.start_mm = cut.job.start_mm;
  sim::SimBackend sim(m, so);
  Executor ex(m.setup(), {});
  Termination t;
  t.set_deadline(1.0, "machine time");
  RunParts parts;
  parts.termination = &t;
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, sim, parts);
  ASSERT_EQ(r.faults.size(), 1u);
  EXPECT_EQ(r.faults[0].kind, FK::stop_requested);
  EXPECT_EQ(r.summary.status, Status::deadline) << r.report();
  EXPECT_FALSE(sim.torch_firing());
}

}  // namespace
}  // namespace machplan::executor
