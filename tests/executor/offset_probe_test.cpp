// Offset probing: a probe beside the torch (QtPlasmaC's offset probe) finds the sheet before the
// pierces. The planner's part (solvers/motion/offset_probe.h: the moves to the probing position
// and back, which pierces probe), the torch sequencer's (deploy, probe, stow) and whole jobs on
// the simulated gantry over a warped sheet.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/executor/torch_sequencer.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/motion/offset_probe.h"
#include "solvers/motion/run.h"
#include "tests/support/datasets.h"
#include "tests/support/torch_plant.h"

namespace machplan::motion {
namespace {

using executor::ProbeReport;
using executor::TorchSequencer;

const Eigen::Vector2d kOffset(-60.0, -45.0);  // the probe, from the torch's centre

cutting::MachineConfig offset_gantry(double skip_mm) {
  cutting::MachineConfig m = test::gantry();
  executor::ProbeSetup& p = m.torch_height.probe;
  p.ohmic = false;
  p.float_switch = true;
  p.offset_x_mm = kOffset.x();
  p.offset_y_mm = kOffset.y();
  p.offset_delay_s = 0.3;
  p.skip_distance_mm = skip_mm;
  return m;
}

// Where the torch stands at each torch_on of `job`.
std::vector<Eigen::Vector2d> pierce_points(const Job& job) {
  std::vector<Eigen::Vector2d> out;
  Eigen::Vector2d at = job.start_mm;
  for (const Step& s : job.steps) {
    if (s.kind == Step::Kind::move) at = job.stretches[s.stretch].segments.back().end;
    if (s.kind == Step::Kind::torch_on) out.push_back(at);
  }
  return out;
}

// A job of two pierces 100 mm apart, each cut a 20 mm line.
Job two_cuts(const Eigen::Vector2d& start) {
  Job j;
  j.source = "two cuts";
  j.start_mm = start;
  Eigen::Vector2d at = start;
  auto move = [&](const Eigen::Vector2d& to, bool cutting, int line) {
    Stretch s;
    s.cutting = cutting;
    s.rapid = !cutting;
    s.segments.push_back(make_segment(at, to, 0.0));
    s.feed_mm_per_s.push_back(cutting ? 20.0 : 200.0);
    s.source_lines.push_back(line);
    j.stretches.push_back(std::move(s));
    j.steps.push_back({Step::Kind::move, line, j.stretches.size() - 1});
    at = to;
  };
  int line = 1;
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(200, 200), Eigen::Vector2d(300, 200)}) {
    move(p, false, line++);
    j.steps.push_back({Step::Kind::torch_on, line++});
    move(p + Eigen::Vector2d(20, 0), true, line++);
    j.steps.push_back({Step::Kind::torch_off, line++});
  }
  return j;
}

TEST(OffsetProbe, ThePlannerSendsTheProbeOverEachPierceAndTheTorchBack) {
  const executor::ProbeSetup probe = offset_gantry(0.0).torch_height.probe;
  Job j = two_cuts({0, 0});
  const std::vector<Eigen::Vector2d> pierces = pierce_points(j);
  ASSERT_EQ(insert_offset_probes(j, probe, 250.0), 2u);
  EXPECT_EQ(pierce_points(j), pierces) << "the pierces stay where they were";
  // Each torch_on: the probe step two steps before it, the torch then at the pierce point less
  // the offset, and a rapid from there back to the pierce.
  Eigen::Vector2d at = j.start_mm;
  int probes = 0;
  for (std::size_t i = 0; i < j.steps.size(); ++i) {
    const Step& s = j.steps[i];
    if (s.kind == Step::Kind::move) {
      const Stretch& k = j.stretches[s.stretch];
      EXPECT_LT((k.segments.front().start - at).norm(), 1e-9) << "step " << i << " starts where the last ended";
      at = k.segments.back().end;
    }
    if (s.kind != Step::Kind::probe) continue;
    const Eigen::Vector2d pierce = pierces[static_cast<std::size_t>(probes++)];
    EXPECT_LT((at + kOffset - pierce).norm(), 1e-9) << "the probe stands over the pierce";
    ASSERT_LT(i + 2, j.steps.size());
    ASSERT_EQ(j.steps[i + 1].kind, Step::Kind::move);
    EXPECT_TRUE(j.stretches[j.steps[i + 1].stretch].rapid);
    EXPECT_EQ(j.steps[i + 2].kind, Step::Kind::torch_on);
  }
  EXPECT_EQ(probes, 2);
  // The first rapid now ends where the torch probes: no detour over the pierce point first.
  EXPECT_LT((j.stretches[j.steps[0].stretch].segments.back().end - (pierces[0] - kOffset)).norm(), 1e-9);

  // A skip distance past 100 mm: the second pierce keeps the first probe's surface.
  executor::ProbeSetup skipping = probe;
  skipping.skip_distance_mm = 150.0;
  Job k = two_cuts({0, 0});
  EXPECT_EQ(insert_offset_probes(k, skipping, 250.0), 1u);
  // No offset probe: nothing changes.
  Job n = two_cuts({0, 0});
  EXPECT_EQ(insert_offset_probes(n, test::gantry().torch_height.probe, 250.0), 0u);
  EXPECT_EQ(n.steps.size(), two_cuts({0, 0}).steps.size());
}

TEST(OffsetProbe, TheSequencerDeploysProbesStowsAndPiercesOverTheSurfaceFoundBesideIt) {
  executor::TorchSetup t = test::probing_torch(false, true);
  t.probe.offset_x_mm = kOffset.x();
  t.probe.offset_y_mm = kOffset.y();
  t.probe.offset_delay_s = 0.3;
  TorchSequencer seq;
  seq.configure(t, 0.001);
  hardware::Outputs out;
  test::TorchPlant p;
  p.plate = -1.2;
  out.torch_height_target_mm = p.height;  // retracted, as a torch off left it
  seq.set_position({500, 400});
  seq.start_probe(out);
  EXPECT_TRUE(out.offset_probe) << "deployed first";
  EXPECT_FALSE(seq.lighting()) << "a probe step lights nothing";
  const double start_height = p.height;
  // The deployment: the torch waits where it is for the probe to come down.
  hardware::Inputs in;
  for (int i = 0; i < 250; ++i) {
    p.step(out, in, 0.001);
    ASSERT_EQ(seq.tick(in, out), TorchSequencer::Tick::busy);
  }
  EXPECT_NEAR(p.height, start_height, 1e-9) << "no descent before the probe is down";
  ASSERT_EQ(test::run_torch(seq, p, out).first, TorchSequencer::Tick::done);
  EXPECT_FALSE(out.offset_probe) << "stowed after the probe";
  EXPECT_FALSE(out.torch_fire);
  EXPECT_NEAR(p.height - *p.plate, t.probe.probe_height_mm, 0.06) << "waits at the probe height over the surface found";
  TorchSequencer::Probe r;
  ASSERT_TRUE(seq.take_probe(r));
  EXPECT_EQ(r.sensor, TorchSequencer::Probe::Sensor::offset_probe);
  EXPECT_LT((r.at_mm - Eigen::Vector2d(440, 355)).norm(), 1e-9) << "where the probe stood";
  EXPECT_NEAR(r.surface_mm, -1.2, 0.02);
  // The torch on that follows pierces over that surface with no probe of its own.
  seq.set_position({500, 400});
  seq.start_on(false, out);
  EXPECT_TRUE(seq.lighting());
  ASSERT_EQ(test::run_torch(seq, p, out).first, TorchSequencer::Tick::done);
  EXPECT_FALSE(seq.take_probe(r)) << "no second record for the same pierce";
  EXPECT_NEAR(p.height_at_fire - *p.plate, t.pierce_height_mm, 0.06);
  // A torch on no probe step prepared (a re-pierce) takes the surface known there.
  seq.start_off(out);
  ASSERT_EQ(test::run_torch(seq, p, out).first, TorchSequencer::Tick::done);
  p.lowest = p.height;
  seq.start_on(false, out);
  ASSERT_EQ(test::run_torch(seq, p, out).first, TorchSequencer::Tick::done);
  ASSERT_TRUE(seq.take_probe(r));
  EXPECT_TRUE(r.skipped);
  EXPECT_GT(p.lowest, *p.plate + t.cut_height_mm - 0.06) << "the torch itself never probes";
}

TEST(OffsetProbe, AStuckProbeIsFoundBeforeTheTorchGoesDown) {
  executor::TorchSetup t = test::probing_torch(false, true);
  t.probe.offset_x_mm = 50.0;
  TorchSequencer seq;
  seq.configure(t, 0.001);
  hardware::Outputs out;
  test::TorchPlant p;
  p.float_stuck = true;
  out.torch_height_target_mm = p.height;
  const double start_height = p.height;
  seq.set_position({0, 0});
  seq.start_probe(out);
  ASSERT_EQ(test::run_torch(seq, p, out).first, TorchSequencer::Tick::failed);
  EXPECT_EQ(seq.failure(), TorchSequencer::Failure::switch_stuck);
  EXPECT_FALSE(out.offset_probe) << "stowed on the fault";
  EXPECT_NEAR(p.height, start_height, 1e-9);
}

// The bundled nested sheet on a sheet warped +-3 mm over 1000 mm, probed with the offset probe:
// every pierce at its height within 0.1 mm of the true surface, the probe over the pierce point,
// and the cycle within 2 % of the estimate that counts the probes and the moves to them.
void check_nested_sheet(double skip_mm) {
  RunOptions o;
  o.session.machine_config = offset_gantry(skip_mm);
  o.session.backend.sim.sheet_warp_mm = std::make_pair(3.0, 1000.0);
  const RunOutcome r = run_program(test::part("nested_sheet.ngc"), o);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  const std::vector<Eigen::Vector2d> pierces = pierce_points(r.job);
  ASSERT_EQ(r.result.probes.size(), pierces.size());
  std::size_t probed = 0;
  double worst = 0.0, worst_skipped = 0.0, worst_place = 0.0;
  for (std::size_t i = 0; i < pierces.size(); ++i) {
    const ProbeReport& p = r.result.probes[i];
    ASSERT_FALSE(std::isnan(p.pierce_height_error_mm)) << "pierce " << i;
    if (p.skipped) {
      worst_skipped = std::max(worst_skipped, std::abs(p.pierce_height_error_mm));
      continue;
    }
    ++probed;
    EXPECT_STREQ(p.sensor, "offset_probe");
    worst = std::max(worst, std::abs(p.pierce_height_error_mm));
    worst_place = std::max(worst_place, (p.position_mm - pierces[i]).norm());
  }
  EXPECT_EQ(probed, r.offset_probes);
  const double estimate = r.planned_motion_s + r.process_time_s;
  std::printf("offset probe (%g, %g) mm, skip %g mm: %zu pierces, %zu probed; pierce height within %.3f mm (probed) and "
              "%.3f mm (skipped) of the true surface's; probe within %.4f mm of the pierce point; cycle %.3f s, estimate "
              "%.3f s (%+.2f %%)\n",
              kOffset.x(), kOffset.y(), skip_mm, pierces.size(), probed, worst, worst_skipped, worst_place,
              r.result.cycle_time_s, estimate, 100.0 * (r.result.cycle_time_s / estimate - 1.0));
  EXPECT_LT(worst, 0.1);
  EXPECT_LT(worst_skipped, 0.25);
  EXPECT_LT(worst_place, 0.05) << "the probe measured the surface where the torch pierced";
  EXPECT_NEAR(r.result.cycle_time_s, estimate, 0.02 * estimate);
}

TEST(OffsetProbe, EveryPierceOfTheNestedSheetIsAtItsHeightOverAWarpedSheet) { check_nested_sheet(0.0); }

TEST(OffsetProbe, WithTheSkipRuleOnlyThePiercesFarFromTheLastProbeAreProbed) { check_nested_sheet(30.0); }

TEST(OffsetProbe, AProbingPositionOutsideTheTravelIsRefusedBeforeAnythingRuns) {
  cutting::MachineConfig m = offset_gantry(0.0);
  m.torch_height.probe.offset_x_mm = 900.0;  // the torch would go 900 mm left of a pierce at x < 900
  RunOptions o;
  o.session.machine_config = m;
  const PlannedRun plan = plan_program(test::part("nested_sheet.ngc"), o, m);
  EXPECT_EQ(plan.summary.status, Status::infeasible);
  EXPECT_NE(plan.summary.message.find("travel"), std::string::npos) << plan.summary.message;
}

}  // namespace
}  // namespace machplan::motion
