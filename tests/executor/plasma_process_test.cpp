// The plasma process as a plasma table runs it: torch height control from the arc voltage on a
// warped sheet, its anti-dive at corners and over kerfs cut earlier, and cut recovery after a
// lost arc.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/hardware/operator_events.h"
#include "tests/support/cut_coverage.h"
#include "tests/support/datasets.h"
#include "models/cutting/machine_config.h"
#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using executor::CutError;
using executor::TraceSample;

using test::part;

using test::gantry;

RunOutcome run_on(const std::string& path, const cutting::MachineConfig& m, const std::string& events = "",
                  std::optional<std::pair<double, double>> warp = std::nullopt) {
  RunOptions o;
  o.session.machine_config = m;
  o.session.backend.sim.sheet_warp_mm = warp;
  if (!events.empty()) o.session.backend.sim.operator_events = hardware::parse_operator_events(events, "events.csv").states;
  return run_program(path, o);
}

struct ThcWorst {
  double max_mm = 0.0, velocity_change_mm = 0.0, void_change_mm = 0.0, velocity_locked_s = 0.0;
  int cuts = 0;
};
ThcWorst worst_thc(const std::vector<CutError>& cuts) {
  ThcWorst w;
  for (const CutError& c : cuts) {
    if (c.thc.samples == 0) continue;
    ++w.cuts;
    w.max_mm = std::max(w.max_mm, c.thc.max_mm);
    w.velocity_change_mm = std::max(w.velocity_change_mm, c.thc.velocity_lock_change_mm);
    w.void_change_mm = std::max(w.void_change_mm, c.thc.void_lock_change_mm);
    w.velocity_locked_s += c.thc.velocity_locked_s;
  }
  return w;
}

TEST(Thc, HoldsTheCutHeightWithinAThirdOfAMillimetreOnASheetWarpedThreeMillimetres) {
  const auto warp = std::make_pair(3.0, 1000.0);
  const RunOutcome with = run_on(part("nested_sheet.ngc"), gantry(), "", warp);
  ASSERT_TRUE(with.summary.done()) << with.summary.full_report();
  const ThcWorst w = worst_thc(with.result.cuts);
  ASSERT_GT(w.cuts, 5);
  std::printf("THC on, +-3 mm warp: torch height within %.3f mm of the cut height; height change under velocity "
              "anti-dive at most %.3f mm over %.2f s of velocity lock\n", w.max_mm, w.velocity_change_mm, w.velocity_locked_s);
  EXPECT_LT(w.max_mm, 0.3);
  // No dive at corners and small holes: under the velocity lock the torch follows the surface
  // the map estimates (the warp's own change, a few tenths over a corner), not the voltage.
  EXPECT_LT(w.velocity_change_mm, 0.3);
  EXPECT_GT(w.velocity_locked_s, 0.1);    // ... where the velocity lock did hold the height

  // The operator's THC switch off: the torch rides the warp at its 1.5 mm cut height over the
  // surface its probe found, and where the sheet rises more than that it meets the plate. With
  // the gantry's float switch the torch floats up and rides on the plate (a cut that scrapes):
  // the run completes, but the height is lost. A rigid torch that does not probe (its heights
  // are over the nominal surface) gives at once: a collision (the breakaway switch), the run
  // ends faulted with the torch off. (Before the simulator had a breakaway switch, the torch went on through the
  // plate and the run completed.)
  const std::string thc_off = "t_s,event,value\n0,thc,0\n";
  const RunOutcome floating = run_on(part("nested_sheet.ngc"), gantry(), thc_off, warp);
  ASSERT_TRUE(floating.summary.done()) << floating.summary.full_report();
  double lowest_gap = 1e9;
  for (const auto& t : floating.result.trace)
    if (t.torch_fire && t.arc_ok && !std::isnan(t.torch_gap_mm)) lowest_gap = std::min(lowest_gap, t.torch_gap_mm);
  EXPECT_LT(lowest_gap, 0.0) << "the torch rode on the plate";
  EXPECT_GT(lowest_gap, -gantry().torch_height.probe.float_travel_mm) << "but never closed the float switch";
  std::printf("THC off, +-3 mm warp, float switch: the torch rode %.3f mm into its float\n", -lowest_gap);

  cutting::MachineConfig rigid = gantry();
  rigid.torch_height.probe = {};
  const RunOutcome without = run_on(part("nested_sheet.ngc"), rigid, thc_off, warp);
  ASSERT_EQ(without.summary.status, Status::faulted) << without.summary.full_report();
  ASSERT_EQ(without.result.faults.size(), 1u);
  EXPECT_EQ(without.result.faults.front().kind, executor::FaultKind::torch_breakaway);
  EXPECT_EQ(without.result.faults.front().axis, -1) << "the breakaway switch";
  EXPECT_TRUE(without.result.probes.empty());
  // Between its pierce and cut heights over the nominal surface: no probe, no THC.
  EXPECT_GE(without.result.faults.front().value, gantry().torch_height.cut_height_mm - 0.05);
  EXPECT_LE(without.result.faults.front().value, gantry().torch_height.pierce_height_mm + 0.05);
  EXPECT_TRUE(without.result.torch_off_at_end);
  EXPECT_TRUE(without.result.stopped_at_rest);
  std::printf("THC off, +-3 mm warp, a rigid torch without probing: the torch met the plate at %.3f s\n", without.result.faults.front().time_s);
}

// A steeper warp, +-3 mm over 400 mm, on the bracket: THC alone loses height where it may not
// act (after the pierce until it arms, at corners under the velocity lock); the surface map of
// the probes and of the heights THC held carries the torch over those stretches.
TEST(Thc, TheSurfaceMapHoldsTheBracketWithinThreeTenthsOnASteepWarp) {
  for (const double wavelength : {1000.0, 600.0, 400.0}) {
    const RunOutcome r = run_on(part("bracket_l.ngc"), gantry(), "", std::make_pair(3.0, wavelength));
    ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
    const ThcWorst w = worst_thc(r.result.cuts);
    ASSERT_EQ(w.cuts, 5);
    std::printf("bracket, +-3 mm over %.0f mm: torch height within %.3f mm of the cut height\n", wavelength, w.max_mm);
    EXPECT_LT(w.max_mm, 0.3) << wavelength;
  }
}

// Two long cuts at right angles, the second crossing the first's kerf on a flat sheet.
std::string crossing_program(const test::TempDir& dir) {
  return dir.write("crossing.ngc", "G21 G90\n"
                                   "G0 X20 Y150\nM3 S1\nG1 X280 Y150 F2000\nM5\n"
                                   "G0 X150 Y20\nM3 S1\nG1 X150 Y280 F2000\nM5\nM2\n");
}

TEST(Thc, DoesNotDiveWhereACutCrossesAnEarlierKerf) {
  test::TempDir dir;
  const std::string path = crossing_program(dir);
  const RunOutcome r = run_on(path, gantry());
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  ASSERT_EQ(r.result.cuts.size(), 2u);
  const CutError& second = r.result.cuts[1];
  ASSERT_GT(second.thc.samples, 1000u);
  std::printf("kerf crossing: height change while void-locked %.3f mm over %.3f s, worst height error %.3f mm\n",
              second.thc.void_lock_change_mm, second.thc.void_locked_s, second.thc.max_mm);
  EXPECT_GT(second.thc.void_lock_change_mm + second.thc.max_mm, 0.0);  // measured
  EXPECT_LT(second.thc.void_lock_change_mm, 0.2);
  EXPECT_GT(second.thc.void_locked_s, 0.0);  // the void lock held the height over the kerf
  EXPECT_LT(second.thc.max_mm, 0.3);

  // Without the void anti-dive (a threshold no rise reaches) the torch dives over the kerf.
  cutting::MachineConfig m = gantry();
  m.thc.void_anti_dive_v_per_s = 1e6;
  const RunOutcome dives = run_on(path, m);
  ASSERT_TRUE(dives.summary.done()) << dives.summary.full_report();
  std::printf("kerf crossing without void anti-dive: worst height error %.3f mm\n", dives.result.cuts[1].thc.max_mm);
  EXPECT_GT(dives.result.cuts[1].thc.max_mm, 0.3);
}

// The longest stretch of the cuts the arc left uncut, from the simulator's truth.
double longest_uncut_mm(const Job& job, const std::vector<TraceSample>& trace, double reach) {
  double worst = 0.0;
  for (const Stretch& s : job.stretches)
    if (s.cutting) worst = std::max(worst, test::cut_coverage(s, trace, reach).longest_gap_mm);
  return worst;
}

TEST(CutRecovery, TenArcLossesAreRecoveredAndTheCutsLeaveNoGapLongerThanTheKerf) {
  cutting::MachineConfig m = gantry();
  m.torch.plasma.recover_on_arc_loss = true;
  RunOptions o;
  o.session.machine_config = m;
  o.session.executor.record_trace = true;
  const PlannedRun plan = plan_program(part("nested_sheet.ngc"), o, m);
  double cut_time = 0.0;  // the job's machine time, roughly
  for (const auto& tr : plan.trajectories)
    if (tr) cut_time += tr->duration_s();
  // Seeded random instants at least 6 s apart; each recovery holds the job about 4 s, so the
  // later instants move on with it (a loss that came during a hold would meet the re-pierced
  // arc where the last one was: a repeated loss, which ends the job by design).
  std::mt19937_64 rng(22);
  std::vector<double> at;
  while (at.size() < 10) {
    const double t = std::uniform_real_distribution<double>(2.0, 0.75 * cut_time)(rng);
    if (std::all_of(at.begin(), at.end(), [t](double u) { return std::abs(t - u) >= 6.0; })) at.push_back(t);
  }
  std::sort(at.begin(), at.end());
  for (std::size_t i = 0; i < at.size(); ++i) {
    sim::FaultInjection f;
    f.kind = sim::FaultInjection::Kind::arc_loss;
    f.at_s = at[i] + 4.5 * static_cast<double>(i);
    o.session.backend.sim.faults.push_back(f);
  }
  session::MachineSession s(o.session);
  auto run = s.start(plan.job, plan.trajectories, {});
  // The executor takes the machine back to where the arc went out; the operator, at each
  // hold, 3 mm further back along the path, then cycle start (pressed for 20 periods).
  hardware::OperatorInputs op;
  int holds_seen = 0;
  long held_ticks = 0, pressed_ticks = 0;
  while (run->tick()) {
    if (op.cycle_start && ++pressed_ticks == 20) {
      op.cycle_start = false;
      s.operator_inputs().set(op);
    }
    const executor::LiveState live = s.live().read();
    if (live.run != executor::LiveState::Run::held) {
      held_ticks = 0;
      continue;
    }
    if (++held_ticks == 1) {
      ++holds_seen;
      op.paused_motion_mm -= 3.0;
      s.operator_inputs().set(op);
    } else if (held_ticks == 1500) {
      op.cycle_start = true;
      pressed_ticks = 0;
      s.operator_inputs().set(op);
    }
    if (held_ticks > 5000) FAIL() << "the hold was never released";
  }
  const executor::ExecutionResult r = run->finish();
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  int recoveries = 0;
  for (const executor::HoldReport& h : r.holds) {
    if (!h.by_arc_loss) continue;
    ++recoveries;
    EXPECT_TRUE(std::isfinite(h.resumed_at_s));
    // Back over the braking and 3 mm more: past the cut's start into the rapid before it where
    // the cut began closer than that (and then the job goes on from there, the pierce its own).
    EXPECT_LT(h.recovered_mm, -h.distance_to_stop_mm) << "at " << h.t_s << " s";
    bool on_rapid = false;
    for (const executor::PausedMotionReport& p : r.paused_motions)
      if (p.t_s >= h.t_s && p.end_s <= h.resumed_at_s) on_rapid = plan.job.stretches[plan.job.steps[p.to_step].stretch].rapid;
    EXPECT_TRUE(h.repierce_s > 0.0 || on_rapid) << "at " << h.t_s << " s";
  }
  EXPECT_EQ(recoveries, 10) << r.report();
  EXPECT_EQ(holds_seen, 10);
  const double kerf = 1.5;
  const double gap = longest_uncut_mm(plan.job, r.trace, kerf / 2);
  std::printf("10 arc losses recovered; the longest uncut stretch of the cuts: %.3f mm\n", gap);
  EXPECT_LT(gap, kerf);
}

TEST(CutRecovery, AnArcLostAgainWithinAFewMillimetresEndsTheJob) {
  cutting::MachineConfig m = gantry();
  m.torch.plasma.recover_on_arc_loss = true;
  RunOptions o;
  o.session.machine_config = m;
  const PlannedRun plan = plan_program(part("triangle_45.ngc"), o, m);
  // Mid-cut, from a run without losses.
  double mid_cut_s = 0.0;
  {
    session::MachineSession plain(o.session);
    const executor::ExecutionResult r = plain.run(plan.job, plan.trajectories);
    std::vector<double> burning;
    for (const TraceSample& t : r.trace)
      if (t.arc_ok && t.torch_fire) burning.push_back(t.t_s);
    ASSERT_FALSE(burning.empty());
    mid_cut_s = burning[burning.size() / 2];
  }
  // Two losses: the second waits for the arc the re-pierce lights, right where the first was.
  for (double at : {mid_cut_s, mid_cut_s + 0.001}) {
    sim::FaultInjection f;
    f.kind = sim::FaultInjection::Kind::arc_loss;
    f.at_s = at;
    o.session.backend.sim.faults.push_back(f);
  }
  o.session.backend.sim.operator_events =
      hardware::parse_operator_events(fmt::format("t_s,event,value\n{},start,\n", mid_cut_s + 2.0), "events.csv").states;
  session::MachineSession s(o.session);
  const executor::ExecutionResult r = s.run(plan.job, plan.trajectories);
  ASSERT_EQ(r.summary.status, Status::faulted) << r.report();
  EXPECT_EQ(r.faults.front().kind, executor::FaultKind::arc_lost);
  EXPECT_TRUE(r.torch_off_at_end);
  ASSERT_FALSE(r.holds.empty());
  EXPECT_TRUE(r.holds.front().by_arc_loss);
}

}  // namespace
}  // namespace machplan::motion
