// Initial height sensing on the simulated gantry, whole jobs: the bundled nested sheet on a
// warped sheet with probing on, the skip rule, the cycle against the estimate that counts the
// probes, and the probe's faults injected.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "models/cutting/machine_config.h"
#include "models/sim/sheet_map.h"
#include "models/sim/sim_backend.h"
#include "solvers/motion/run.h"
#include "tests/support/datasets.h"

namespace machplan::motion {
namespace {

using executor::FaultKind;
using executor::ProbeReport;
using test::gantry;
using test::part;

constexpr auto kWarp = std::make_pair(3.0, 1000.0);  // +-3 mm over 1000 mm

RunOutcome run_with(const cutting::MachineConfig& m, std::optional<sim::FaultInjection> fault = std::nullopt,
                    const std::string& program = "nested_sheet.ngc") {
  RunOptions o;
  o.session.machine_config = m;
  o.session.backend.sim.sheet_warp_mm = kWarp;
  if (fault) o.session.backend.sim.faults.push_back(*fault);
  return run_program(part(program), o);
}

double chebyshev(const ProbeReport& a, const ProbeReport& b) { return (a.position_mm - b.position_mm).cwiseAbs().maxCoeff(); }

// Every pierce of the nested sheet at its pierce height within 0.1 mm of the true surface, on a
// sheet warped +-3 mm; the skip rule obeyed pierce by pierce; the cycle within 2 % of the
// estimate that counts the probes.
void check_nested_sheet(double skip_mm) {
  cutting::MachineConfig m = gantry();
  m.torch_height.probe.skip_distance_mm = skip_mm;
  const RunOutcome r = run_with(m);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  const auto& probes = r.result.probes;
  std::size_t pierces = 0;
  for (const auto& s : r.job.steps) pierces += s.kind == Step::Kind::torch_on;
  ASSERT_EQ(probes.size(), pierces) << "one probe (or skip) per pierce";
  double worst = 0.0, worst_skipped = 0.0, worst_last = 0.0, lo = 1e9, hi = -1e9;
  std::size_t skipped = 0;
  const ProbeReport* last_probed = nullptr;
  for (const ProbeReport& p : probes) {
    ASSERT_FALSE(std::isnan(p.pierce_height_error_mm)) << "the simulator knows the truth";
    const bool rule = last_probed && skip_mm > 0 && chebyshev(p, *last_probed) <= skip_mm;
    EXPECT_EQ(p.skipped, rule) << "line " << p.source_line;
    if (p.skipped) {
      worst_skipped = std::max(worst_skipped, std::abs(p.pierce_height_error_mm));
      // QtPlasmaC's rule keeps the last probe's height: its error against the true surface.
      const double true_surface = p.surface_mm - p.pierce_height_error_mm;
      worst_last = std::max(worst_last, std::abs(last_probed->surface_mm - true_surface));
    } else {
      worst = std::max(worst, std::abs(p.pierce_height_error_mm));
      last_probed = &p, lo = std::min(lo, p.surface_mm), hi = std::max(hi, p.surface_mm);
    }
    skipped += p.skipped;
  }
  const double estimate = r.planned_motion_s + r.process_time_s;
  std::printf("skip %g mm: %zu pierces, %zu probes skipped; pierce height within %.3f mm (probed) and %.3f mm (skipped) "
              "of the true surface's (the last probe's height: %.3f mm); surfaces %+.2f .. %+.2f mm; cycle %.3f s, estimate "
              "%.3f s (%+.2f %%)\n",
              skip_mm, pierces, skipped, worst, worst_skipped, worst_last, lo, hi, r.result.cycle_time_s, estimate,
              100.0 * (r.result.cycle_time_s / estimate - 1.0));
  EXPECT_LT(worst, 0.1);
  if (skip_mm <= 5) EXPECT_LT(worst_skipped, 0.1) << "a slope of 3 mm * 2 pi / 1000 mm over 5 mm at most";
  // Farther, the map's plane cannot follow the warp's curvature exactly, but it is better than
  // QtPlasmaC's last height.
  if (skipped > 0) EXPECT_LT(worst_skipped, std::min(0.25, 0.75 * worst_last));
  EXPECT_GT(hi - lo, 3.0) << "the warp was there to be found";
  EXPECT_NEAR(r.result.cycle_time_s / estimate, 1.0, 0.02);
  if (skip_mm > 25) EXPECT_GT(skipped, 0u) << "the nested sheet has pierces within 25 mm of each other";
}

TEST(Probing, EveryPierceOfTheNestedSheetIsAtItsHeightOverAWarpedSheet) { check_nested_sheet(5.0); }

TEST(Probing, PiercesSparedByTheSkipRuleTakeTheSurfaceMapsEstimate) { check_nested_sheet(30.0); }

// One injected fault on a job of cuts; returns the outcome.
RunOutcome faulted(sim::FaultInjection::Kind kind, double at_s, cutting::MachineConfig m = gantry()) {
  sim::FaultInjection f;
  f.kind = kind;
  f.at_s = at_s;
  return run_with(m, f);
}

void expect_stop(const RunOutcome& r, FaultKind kind) {
  ASSERT_EQ(r.summary.status, Status::faulted) << r.summary.full_report();
  ASSERT_EQ(r.result.faults.size(), 1u);
  EXPECT_EQ(r.result.faults.front().kind, kind) << r.result.faults.front().message;
  EXPECT_TRUE(r.result.torch_off_at_end);
  EXPECT_TRUE(r.result.stopped_at_rest);
}

// The first pierce's probe: when it begins and ends, from a clean run.
struct FirstProbe {
  double start_s, end_s;
};
FirstProbe first_probe() {
  const RunOutcome r = run_with(gantry());
  const ProbeReport& p = r.result.probes.at(1);  // the second: after the first cut, between cuts
  return {p.t_s - p.duration_s, p.t_s};
}

TEST(Probing, NoSheetUnderTheTorchIsAProbeMissAndTheTorchIsNeverLit) {
  const FirstProbe p = first_probe();
  const RunOutcome r = faulted(sim::FaultInjection::Kind::probe_miss, p.start_s - 0.5);
  expect_stop(r, FaultKind::probe_miss);
  EXPECT_NE(r.result.faults.front().message.find("no contact by 5 mm under the expected surface"), std::string::npos)
      << r.result.faults.front().message;
  EXPECT_EQ(r.result.probes.size(), 1u) << "the first pierce's probe only";
  // The torch was never lit after the fault's injection: no trace sample fires after it.
  for (const auto& s : r.result.trace)
    if (s.t_s > p.start_s) ASSERT_FALSE(s.torch_fire) << s.t_s;
}

TEST(Probing, AFloatSwitchStuckClosedStopsTheNextProbeBeforeTheTorchGoesDown) {
  const FirstProbe p = first_probe();
  const RunOutcome r = faulted(sim::FaultInjection::Kind::switch_stuck, p.start_s - 0.5);
  expect_stop(r, FaultKind::probe_switch_stuck);
  EXPECT_NE(r.result.faults.front().message.find("float switch was closed before the probe"), std::string::npos);
  for (const auto& s : r.result.trace)
    if (s.t_s > p.start_s) ASSERT_FALSE(s.torch_fire) << s.t_s;
}

TEST(Probing, TheFloatSwitchClosingMidCutIsABreakaway) {
  const FirstProbe p = first_probe();
  const RunOutcome r = faulted(sim::FaultInjection::Kind::breakaway, p.start_s - 2.0);  // in the first cut
  expect_stop(r, FaultKind::torch_breakaway);
  EXPECT_EQ(r.result.faults.front().axis, 2) << "the float switch, not the breakaway switch";
  EXPECT_NEAR(r.result.faults.front().time_s, p.start_s - 2.0, 0.01) << "within the debounce";
  EXPECT_NE(r.result.faults.front().message.find("float switch closed while the torch fired"), std::string::npos);
}

TEST(Probing, WithTheOhmicContactMissingTheFloatSwitchTakesOverAndTheJobCompletes) {
  const RunOutcome r = faulted(sim::FaultInjection::Kind::ohmic_miss, 0.0);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  double worst = 0.0;
  for (const ProbeReport& p : r.result.probes) {
    EXPECT_STREQ(p.sensor, "float_switch");
    worst = std::max(worst, std::abs(p.pierce_height_error_mm));
  }
  EXPECT_LT(worst, 0.1);
  EXPECT_TRUE(r.result.backend_notes.empty());
}

TEST(Probing, ADirtyPlateMissesSomeOhmicContactsAndTheFloatSwitchFindsThoseSurfaces) {
  cutting::MachineConfig m = gantry();
  m.sheet_ohmic_miss_probability = 0.3;
  const RunOutcome r = run_with(m);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  std::size_t by_float = 0;
  double worst = 0.0;
  for (const ProbeReport& p : r.result.probes) {
    by_float += std::string(p.sensor) == "float_switch";
    worst = std::max(worst, std::abs(p.pierce_height_error_mm));
  }
  EXPECT_GT(by_float, 5u);
  EXPECT_LT(by_float, r.result.probes.size() - 5);
  EXPECT_LT(worst, 0.1);
}

// A sheet given as a measured height map (--sheet-map): tilted 2 mm over the table and with a
// 1.5 mm bump; every probe finds the map's surface and every pierce fires at its height over it.
TEST(Probing, OnASheetGivenAsAHeightMapEveryPierceIsAtItsHeight) {
  std::string csv = "x_mm,y_mm,z_mm\n";
  const auto z = [](double x, double y) { return 0.0016 * x - 0.0008 * y + 1.5 * std::exp(-(std::pow(x - 300, 2) + std::pow(y - 250, 2)) / 2e4); };
  for (int i = 0; i <= 30; ++i)
    for (int j = 0; j <= 25; ++j) csv += std::to_string(i * 50) + "," + std::to_string(j * 50) + "," + std::to_string(z(i * 50, j * 50)) + "\n";
  auto map = std::make_shared<const sim::SheetMap>(sim::parse_sheet_map(csv, "sheet.csv"));
  RunOptions o;
  o.session.machine_config = gantry();
  o.session.backend.sim.sheet_map = map;
  const RunOutcome r = run_program(part("bracket_l.ngc"), o);
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  ASSERT_FALSE(r.result.probes.empty());
  double worst = 0.0, worst_surface = 0.0;
  for (const ProbeReport& p : r.result.probes) {
    worst = std::max(worst, std::abs(p.pierce_height_error_mm));
    if (!p.skipped) worst_surface = std::max(worst_surface, std::abs(p.surface_mm - map->z_mm(p.position_mm.x(), p.position_mm.y())));
  }
  std::printf("height map: %zu probes, surface within %.3f mm of the map, pierces within %.3f mm\n", r.result.probes.size(),
              worst_surface, worst);
  EXPECT_LT(worst_surface, 0.06);
  EXPECT_LT(worst, 0.1);
}

}  // namespace
}  // namespace machplan::motion
