// The executor's sequencing, validation and results on the simulated gantry.
#include <atomic>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "cli/json/executor.h"
#include "tests/support/datasets.h"
#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/executor/executor.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "tests/support/forwarding_backend.h"
#include "tests/support/simulate.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

using motion::Step;

using test::gantry;

test::OneCut line_cut(Eigen::Vector2d a, Eigen::Vector2d b, double feed = 40) {
  return test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), feed, true),
                       std::make_unique<test::LineTrajectory>(a, b, feed, 500));
}

// Index of the first trace sample satisfying `pred`, or -1.
template <class P>
long first(const std::vector<TraceSample>& t, P pred) {
  for (std::size_t i = 0; i < t.size(); ++i)
    if (pred(t[i])) return static_cast<long>(i);
  return -1;
}

TEST(Executor, TorchSequenceRunsInOrder) {
  const auto m = gantry();
  auto cut = line_cut({100, 100}, {150, 100});
  sim::SimOptions so;
  so.start_mm = cut.job.start_mm;
  sim::SimBackend sim(m, so);
  Executor ex(m.setup(), {});
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, sim);
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  const auto& t = r.trace;
  const long fire = first(t, [](auto& s) { return s.torch_fire; });
  const long arc = first(t, [](auto& s) { return s.arc_ok; });
  const long move = first(t, [](auto& s) { return s.step == 1; });
  const long off = first(t, [](auto& s) { return s.step == 2; });
  ASSERT_GT(fire, 0);
  // Firing waits for the probe: down from retract (15 mm) to the probe height at the axis'
  // speed, on at the probe speed to the plate, and up to pierce height.
  const auto& th = m.torch_height;
  const double probe_s = (th.retract_height_mm - th.probe.probe_height_mm) / th.speed_mm_per_s +
                         th.probe.probe_height_mm / th.probe.probe_speed_mm_per_s + th.pierce_height_mm / th.speed_mm_per_s;
  EXPECT_GE(t[fire].t_s, probe_s - 0.01);
  ASSERT_EQ(r.probes.size(), 1u);
  EXPECT_STREQ(r.probes[0].sensor, "ohmic");
  EXPECT_NEAR(r.probes[0].surface_mm, 0.0, 0.02) << "a flat sheet at the nominal surface";
  EXPECT_NEAR(r.probes[0].pierce_height_error_mm, 0.0, 0.06);
  // Arc OK comes after the arc start delay; the move starts after the pierce delay and the
  // descent to cut height.
  EXPECT_NEAR(t[arc].t_s - t[fire].t_s, m.torch.plasma.arc_start_delay_s, 0.003);
  EXPECT_GE(t[move].t_s - t[arc].t_s, m.torch.plasma.pierce_delay_s);
  for (long i = 0; i < move; ++i) EXPECT_EQ(t[i].dac_x, 0) << "no motion before the pierce is done, tick " << i;
  ASSERT_GT(off, move);
  // The torch burns through the whole move and goes out at torch_off.
  for (long i = move; i < off; ++i) ASSERT_TRUE(t[i].torch_fire && t[i].arc_ok) << i;
  EXPECT_FALSE(t[off].torch_fire);
  EXPECT_FALSE(t.back().torch_fire);
  EXPECT_FALSE(t.back().drives_enabled);
  EXPECT_FALSE(sim.torch_firing());
  EXPECT_NEAR(sim.torch_height_mm(), m.torch_height.retract_height_mm, 0.05);
  EXPECT_NEAR(r.torch_on_s, (off - arc) * 0.001, 0.003);
  EXPECT_NEAR((sim.plant(0).load_position_mm()), 150.0, 0.05);
}

TEST(Executor, ProgrammedDwellIsThePierceDelay) {
  const auto m = gantry();
  auto cut = line_cut({100, 100}, {120, 100});
  // torch_on, dwell 1.7 s (G4), move, torch_off.
  cut.job.steps.insert(cut.job.steps.begin() + 1, Step{Step::Kind::dwell, 6, 0, 1.7});
  cut.trajectories.insert(cut.trajectories.begin() + 1, nullptr);
  const ExecutionResult r = test::simulate(m, cut.job, cut.trajectories, {});
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  const long arc = first(r.trace, [](auto& s) { return s.arc_ok; });
  const long move = first(r.trace, [](auto& s) { return s.step == 2; });
  const double pierce = r.trace[move].t_s - r.trace[arc].t_s;
  EXPECT_GE(pierce, 1.7);
  EXPECT_LT(pierce, 1.7 + m.torch.plasma.pierce_delay_s);  // the default was not added on top
}

TEST(Executor, OxyFuelPreheatsAndNeedsNoArcSignal) {
  auto m = gantry();
  m.torch.kind = TorchSetup::Kind::oxy_fuel;
  m.torch.oxy_fuel.preheat_s = 3.0;
  auto cut = line_cut({100, 100}, {120, 100});
  const ExecutionResult r = test::simulate(m, cut.job, cut.trajectories, {});
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  const long fire = first(r.trace, [](auto& s) { return s.torch_fire; });
  EXPECT_GE(r.trace[fire].t_s, 3.0);
}

TEST(Executor, ArcThatNeverStartsIsAFaultWithTorchOff) {
  auto m = gantry();
  m.torch.plasma.arc_start_failure_probability = 1.0;
  auto cut = line_cut({100, 100}, {120, 100});
  const ExecutionResult r = test::simulate(m, cut.job, cut.trajectories, {});
  ASSERT_EQ(r.summary.status, Status::faulted);
  ASSERT_EQ(r.faults.size(), 1u);
  EXPECT_EQ(r.faults[0].kind, FaultReport::Kind::arc_start_failed);
  EXPECT_EQ(r.faults[0].step, 0);
  EXPECT_EQ(r.faults[0].source_line, 5);
  EXPECT_NE(r.faults[0].message.find("test.ngc:5: no arc OK within 2 s"), std::string::npos) << r.faults[0].message;
  EXPECT_FALSE(r.trace.back().torch_fire);
  EXPECT_TRUE(r.torch_off_at_end);
  for (const auto& s : r.trace) EXPECT_EQ(s.dac_x, 0);
}

TEST(Executor, TorchIsTurnedOffBeforeARapidEvenWithoutATorchOffStep) {
  const auto m = gantry();
  test::OneCut c = line_cut({100, 100}, {130, 100});
  c.job.steps.pop_back();  // no torch_off
  c.trajectories.pop_back();
  c.job.stretches.push_back(test::make_stretch(test::polyline_segments({{130, 100}, {130, 160}}, false), 80, false, true, 20));
  c.job.steps.push_back({Step::Kind::move, 20, 1, 0.0});
  c.trajectories.push_back(std::make_unique<test::LineTrajectory>(Eigen::Vector2d(130, 100), Eigen::Vector2d(130, 160), 80, 500));
  const ExecutionResult r = test::simulate(m, c.job, c.trajectories, {});
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  for (const auto& s : r.trace)
    if (s.step == 2) { ASSERT_FALSE(s.torch_fire); }
  EXPECT_NEAR(r.rapid_distance_mm, 60.0, 1e-9);
  EXPECT_NEAR(r.cut_distance_mm, 30.0, 1e-9) << "the cut, not the rapid after it";
}

TEST(Executor, RefusesJobsThatDoNotFitTheirTrajectories) {
  const auto m = gantry();
  Executor ex(m.setup(), {});
  sim::SimBackend sim(m, {});
  {
    auto c = line_cut({100, 100}, {150, 100});
    c.trajectories[1] = std::make_unique<test::LineTrajectory>(Eigen::Vector2d(100, 100), Eigen::Vector2d(150, 101), 40, 500);
    EXPECT_NE(test::error_of([&] { ex.run(c.job, c.trajectories, sim); }).find("test.ngc:10: trajectory of step 1 runs"),
              std::string::npos);
  }
  {
    auto c = line_cut({100, 100}, {150, 100});
    c.trajectories[1].reset();
    EXPECT_NE(test::error_of([&] { ex.run(c.job, c.trajectories, sim); }).find("test.ngc:10: move step 1 has no trajectory"),
              std::string::npos);
  }
  {
    auto c = line_cut({100, 100}, {150, 100});
    c.job.steps.erase(c.job.steps.begin());
    c.trajectories.erase(c.trajectories.begin());
    EXPECT_NE(test::error_of([&] { ex.run(c.job, c.trajectories, sim); })
                  .find("test.ngc:10: cutting move with the torch off (no torch_on step before it)"),
              std::string::npos);
  }
  {
    auto c = line_cut({100, 100}, {150, 100});
    c.job.start_mm = {0, 0};
    EXPECT_NE(test::error_of([&] { ex.run(c.job, c.trajectories, sim); }).find("stretch 0 starts at (100.0000, 100.0000)"),
              std::string::npos);
  }
  {
    auto table = cutting::load_machine(cutting::find_machine("xy_table"));
    table.torch.kind = executor::TorchSetup::Kind::none;  // neither torch nor spindle
    table.spindle.reset();
    Executor tx(table.setup(), {});
    sim::SimBackend ts(table, {});
    auto c = line_cut({100, 100}, {150, 100});
    EXPECT_NE(test::error_of([&] { tx.run(c.job, c.trajectories, ts); }).find("test.ngc:5: torch or spindle on, but machine 'xy_table' has neither"),
              std::string::npos);
  }
  EXPECT_EQ(sim.time_s(), 0.0);  // nothing was run
}

TEST(Executor, SameSeedSameRun) {
  const auto m = gantry();
  auto a = line_cut({100, 100}, {180, 140}, 80);
  auto b = line_cut({100, 100}, {180, 140}, 80);
  ExecutorOptions o;
  sim::SimOptions so;
  so.seed = 11;
  const ExecutionResult ra = test::simulate(m, a.job, a.trajectories, o, so);
  const ExecutionResult rb = test::simulate(m, b.job, b.trajectories, o, so);
  ASSERT_EQ(ra.trace.size(), rb.trace.size());
  EXPECT_EQ(ra.cuts[0].max_true_mm, rb.cuts[0].max_true_mm);
  EXPECT_EQ(ra.trace.back().true_mm, rb.trace.back().true_mm);
  so.seed = 12;
  const ExecutionResult rc = test::simulate(m, a.job, a.trajectories, o, so);
  EXPECT_NE(ra.cuts[0].max_true_mm, rc.cuts[0].max_true_mm);
}

TEST(Executor, ProgressRisesToOneOverTheRun) {
  // A plain move on the XY table (no torch), its expected time the trajectory's own.
  const auto m = cutting::load_machine(cutting::find_machine("xy_table"));
  const Eigen::Vector2d a(100, 100), b(150, 130);
  motion::Job job;
  job.source = "progress.ngc";
  job.start_mm = a;
  job.stretches.push_back(test::make_stretch(test::polyline_segments({a, b}, false), 20, false));
  job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  Trajectories trs(1);
  trs[0] = std::make_unique<test::LineTrajectory>(a, b, 20, 500);
  sim::SimOptions so;
  so.start_mm = a;
  sim::SimBackend sim(m, so);
  Executor ex(m.setup(), {});
  Progress share;
  RunParts parts;
  parts.progress = &share;
  parts.expected_s = trs[0]->duration_s();
  Session s(ex, job, trs, sim, parts);
  double last = 0.0;
  int ticks = 0, halfway_at = -1;
  while (s.tick()) {
    const double v = share.share();
    ASSERT_GE(v, last) << ticks;  // never back
    ASSERT_LT(v, 1.0) << ticks;   // 1 only once the run is over
    if (halfway_at < 0 && v >= 0.5) halfway_at = ticks;
    last = v;
    ++ticks;
  }
  const ExecutionResult r = s.finish();
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  EXPECT_EQ(share.share(), 1.0);
  EXPECT_GT(last, 0.9);
  // Half way through the move's time is half way through the run (the stop settles after it).
  EXPECT_NEAR(halfway_at * 0.001, 0.5 * trs[0]->duration_s(), 0.01);
}

// A machine that knows only what it measures, as one through HAL: the simulator with its truth
// hidden.
struct WithoutTruth final : test::ForwardingBackend {
  using ForwardingBackend::ForwardingBackend;
  const char* name() const override { return "machine"; }
  bool true_position(Eigen::Vector2d&) const noexcept override { return false; }
};

TEST(Executor, WithoutTruthTheReportsSayTheTrueErrorIsUnavailable) {
  const auto m = gantry();
  auto c = line_cut({100, 100}, {150, 130});
  sim::SimOptions so;
  so.start_mm = c.job.start_mm;
  sim::SimBackend sim(m, so);
  WithoutTruth machine(sim);
  Executor ex(m.setup(), {});
  const ExecutionResult r = ex.run(c.job, c.trajectories, machine);
  ASSERT_TRUE(r.summary.done()) << r.report();
  EXPECT_FALSE(r.truth_available);
  ASSERT_EQ(r.cuts.size(), 1u);
  EXPECT_GT(r.cuts[0].max_mm, 0.0);  // measured
  EXPECT_TRUE(std::isnan(r.max_true_contour_error_mm()));
  EXPECT_NE(r.report().find("true contour error unavailable: the machine backend"), std::string::npos) << r.report();
  EXPECT_EQ(r.report().find("nan"), std::string::npos) << r.report();
  const auto j = cli::to_json(r);
  EXPECT_EQ(j["truth_available"], false);
  EXPECT_TRUE(j["cuts"][0]["max_true_contour_error_mm"].is_null());
  EXPECT_TRUE(j["cuts"][0]["rms_true_contour_error_mm"].is_null());

  // The simulator itself knows the truth.
  sim::SimBackend sim2(m, so);
  const ExecutionResult s = ex.run(c.job, c.trajectories, sim2);
  EXPECT_TRUE(s.truth_available);
  EXPECT_FALSE(std::isnan(s.max_true_contour_error_mm()));
  EXPECT_EQ(s.report().find("unavailable"), std::string::npos) << s.report();
  EXPECT_EQ(cli::to_json(s)["truth_available"], true);
}

TEST(Executor, ReportJsonAndCsv) {
  const auto m = gantry();
  auto c = line_cut({100, 100}, {150, 130});  // both axes move: a contour error to report
  const ExecutionResult r = test::simulate(m, c.job, c.trajectories, {});
  EXPECT_NE(r.report().find("completed"), std::string::npos);
  EXPECT_NE(r.report().find("contour error max"), std::string::npos);
  const auto j = cli::to_json(r);
  EXPECT_EQ(j["status"], "done");
  EXPECT_EQ(j["mode"], "planned");
  EXPECT_EQ(j["cuts"].size(), 1u);
  EXPECT_GT(j["cuts"][0]["max_contour_error_mm"].get<double>(), 0.0);
  EXPECT_FALSE(j.contains("trace"));
  EXPECT_EQ(cli::to_json(r, true)["trace"].size(), r.trace.size());
  test::TempDir dir;
  const std::string path = (dir.path() / "trace.csv").string();
  r.write_trace_csv(path);
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm,meas_y_mm,true_x_mm,true_y_mm,dac_x,dac_y,enabled,torch_fire,arc_ok,torch_height_mm,torch_gap_mm,arc_v");
  std::size_t lines = 0;
  for (std::string l; std::getline(in, l);) ++lines;
  EXPECT_EQ(lines, r.trace.size());
  // A trace that cannot be written is an output error with the system's reason, not bad input.
  try {
    r.write_trace_csv("/nonexistent/dir/t.csv");
    ADD_FAILURE() << "written";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/dir/t.csv: cannot write: No such file or directory");
  }
  EXPECT_EQ(parse_mode("paper-closed").value, Mode::paper_closed);
  EXPECT_EQ(parse_mode("paper-closed").note, "");
  EXPECT_EQ(test::error_of([] { parse_mode("fast"); }),
            "mode: unknown mode 'fast' (known: planned, paper-open, paper-closed, jog)");
}

// One spelling per mode, the README's; the old spellings are still read, with a note for the
// caller to show, and to_string() gives back the canonical one.
TEST(Executor, ModesHaveOneSpellingAndTheOldOnesAreAcceptedWithANote) {
  for (const Mode m : {Mode::planned, Mode::paper_open, Mode::paper_closed, Mode::jog}) {
    const Parsed<Mode> p = parse_mode(to_string(m));
    EXPECT_EQ(p.value, m);
    EXPECT_EQ(p.note, "");
  }
  const Parsed<Mode> old = parse_mode("paper_open");
  EXPECT_EQ(old.value, Mode::paper_open);
  EXPECT_EQ(old.note, "'paper_open' is the old spelling of 'paper-open'");
}

TEST(Executor, XyTableRunsAFastMoveToItsEnd) {
  const auto m = cutting::load_machine(cutting::find_machine("xy_table"));
  motion::Job job;
  job.source = "table.ngc";
  job.start_mm = {50, 50};
  job.stretches.push_back(test::make_stretch(test::polyline_segments({{50, 50}, {350, 300}}, false), 1000, false, true));
  job.steps.push_back({Step::Kind::move, 1, 0, 0.0});
  Trajectories tr;
  tr.push_back(std::make_unique<test::LineTrajectory>(Eigen::Vector2d(50, 50), Eigen::Vector2d(350, 300), 1000,
                                                      m.limits.acceleration_mm_per_s2));
  sim::SimOptions so;
  so.start_mm = job.start_mm;
  sim::SimBackend sim(m, so);
  const ExecutionResult r = Executor(m.setup(), {}).run(job, tr, sim);
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  Eigen::Vector2d at;
  sim.true_position(at);
  EXPECT_LT((at - Eigen::Vector2d(350, 300)).norm(), 0.02);
  EXPECT_NEAR(r.rapid_distance_mm, std::hypot(300.0, 250.0), 1e-9);
}

TEST(ExecutorOptions, ValidateNamesTheField) {
  ExecutorOptions o;
  o.blu_mm = 0;
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "blu_mm");
    EXPECT_NE(std::string(e.what()).find("blu_mm: 0 is out of range: must be in [0.01, 1000] mm"), std::string::npos)
        << e.what();
  }
  // A member's field comes out under the owner's name, as the CLI's tables name it.
  o = {};
  o.supervisor.stop_settle_s = 0;
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "supervisor.stop_settle_s");
  }
}

}  // namespace
}  // namespace machplan::executor
