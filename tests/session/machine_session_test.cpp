// The machine session: one rig for every caller (run, tuning, guard, calibration, panel).
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/datasets.h"
#include "engine/hardware/operator_channel.h"
#include "models/backends/backend_factory.h"
#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"
#include "tests/support/stretches.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_trajectory.h"

namespace machplan::session {
namespace {

using executor::ExecutionResult;

using test::part;

// A move of the table from a to b, no torch.
struct Move {
  motion::Job job;
  executor::Trajectories trajectories;
};
Move move(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  Move m;
  m.job.source = "move";
  m.job.start_mm = a;
  m.job.stretches.push_back(test::make_stretch(test::polyline_segments({a, b}, false), 20, false));
  m.job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  m.trajectories.resize(1);
  m.trajectories[0] = std::make_unique<test::LineTrajectory>(a, b, 20, 500);
  return m;
}

TEST(MachineSession, LoadsTheMachineOnceAndOpensTheBackendOnFirstUse) {
  MachineSessionOptions o;
  o.machine = "xy_table";
  MachineSession s(o);
  EXPECT_EQ(s.machine().name, "xy_table");
  EXPECT_EQ(s.setup().name, "xy_table");
  EXPECT_EQ(s.controller_name(), "pid_ff");
  EXPECT_FALSE(s.calibration().has_value());
  EXPECT_FALSE(s.backend_open());
  const Move a = move({100, 100}, {150, 120});
  const ExecutionResult r = s.run(a.job, a.trajectories);
  EXPECT_EQ(r.summary.status, Status::done) << r.report();
  EXPECT_TRUE(s.backend_open());
  EXPECT_EQ(r.backend, "sim");
}

TEST(MachineSession, JobsRunOneAfterTheOtherOnTheSameMachine) {
  MachineSessionOptions o;
  o.machine = "xy_table";
  o.executor.record_trace = false;
  MachineSession s(o);
  const Move a = move({100, 100}, {150, 120}), b = move({150, 120}, {120, 160});
  ASSERT_EQ(s.run(a.job, a.trajectories).summary.status, Status::done);
  Eigen::Vector2d at;
  ASSERT_TRUE(s.backend().true_position(at));
  EXPECT_NEAR((at - Eigen::Vector2d(150, 120)).norm(), 0.0, 0.05) << "the simulated table stays where the first job left it";
  ASSERT_EQ(s.run(b.job, b.trajectories).summary.status, Status::done);
  ASSERT_TRUE(s.backend().true_position(at));
  EXPECT_NEAR((at - Eigen::Vector2d(120, 160)).norm(), 0.0, 0.05);
}

TEST(MachineSession, BadChoicesNameTheirField) {
  test::TempDir dir;
  const std::string store = (dir.path() / "store.db").string();
  const auto field_of = [](const MachineSessionOptions& o) {
    try {
      MachineSession s(o);
    } catch (const InputError& e) {
      EXPECT_TRUE(e.is_field()) << e.what();
      return std::string(e.what());
    }
    return std::string("<no InputError>");
  };
  MachineSessionOptions o;
  o.machine = "xy_table";
  o.store_path = store;
  o.gains["kp_per_s"] = 10;
  EXPECT_EQ(field_of(o), "gains: gains need a controller kind");
  o.gains.clear();
  o.controller = "pd";
  EXPECT_NE(field_of(o).find("controller: unknown controller 'pd' (known: p, pid, pid_ff, zpetc, ccc, flc)"),
            std::string::npos);
  o.controller = "tuned";
  EXPECT_NE(field_of(o).find("controller: no active tuning for 'xy_table' in " + store), std::string::npos);
  EXPECT_EQ(field_of(o).find("--"), std::string::npos) << "messages below cli/ name fields, never flags";
  o.controller.clear();
  o.active_calibration = true;
  EXPECT_NE(field_of(o).find("active_calibration: no active calibration for 'xy_table'"), std::string::npos);
}

// The rules between options are the options' own: a library caller meets them as the command
// line and the panel do, under the field's name and never a flag's.
TEST(MachineSession, RulesBetweenOptionsAreInValidate) {
  const auto refusal = [](const MachineSessionOptions& o) {
    try {
      o.validate();
    } catch (const InputError& e) {
      EXPECT_TRUE(e.is_field()) << e.what();
      EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << "a flag named below cli/: " << e.what();
      return std::string(e.what());
    }
    return std::string("<accepted>");
  };
  const MachineSessionOptions planned;
  EXPECT_EQ(refusal(planned), "<accepted>");
  MachineSessionOptions o = planned;
  o.executor.blu_mm = 5;
  EXPECT_EQ(refusal(o), "executor.blu_mm: 5 mm: a vector length applies to the paper modes only (mode paper-open or "
                        "paper-closed), not to mode planned");
  o.executor.mode = executor::Mode::paper_closed;
  EXPECT_EQ(refusal(o), "<accepted>");
  o = planned;
  o.executor.calibration_factor = 1.2;
  EXPECT_EQ(refusal(o).rfind("executor.calibration_factor: 1.2: a factor applies to the paper modes only", 0), 0u);
  o.executor.mode = executor::Mode::paper_open;
  EXPECT_EQ(refusal(o), "<accepted>");

  // The paper modes take the operator's stop and THC switch, nothing that changes the speed.
  hardware::OperatorEvent stop, hold;
  stop.at_s = 2.0;
  stop.inputs.stop = true;
  stop.inputs.thc_enabled = false;
  hold.at_s = 3.5;
  hold.inputs.feed_hold = true;
  o = planned;
  o.backend.sim.operator_events = {stop, hold};
  EXPECT_EQ(refusal(o), "<accepted>");
  o.executor.mode = executor::Mode::paper_open;
  EXPECT_EQ(refusal(o), "backend.sim.operator_events: a feed hold at 3.5 s: " + std::string(kPaperModesLack));
  o.backend.sim.operator_events = {stop};
  EXPECT_EQ(refusal(o), "<accepted>");

  // What only the simulator does, on every other backend.
  for (const std::string& name : backends::backend_names()) {
    if (name == "sim") continue;
    o = planned;
    o.backend.name = name;
    EXPECT_EQ(refusal(o), "<accepted>");
    o.backend.sim.faults.push_back({sim::FaultInjection::Kind::estop, 1.5});
    EXPECT_EQ(refusal(o), "backend.sim.faults: estop at 1.5 s: faults are injected on the simulator only (backend sim), not "
                          "on backend " + name);
    o.backend.sim.faults.clear();
    o.backend.sim.operator_events = {stop};
    EXPECT_NE(refusal(o).find("backend.sim.operator_events: events from 2 s to 2 s: a timeline of operator events plays on "
                              "the simulator only"),
              std::string::npos);
    o.backend.sim.operator_events.clear();
    o.backend.sim.sheet_warp_mm = std::make_pair(2.0, 300.0);
    EXPECT_NE(refusal(o).find("backend.sim.sheet_warp_mm: 2 mm over 300 mm: the sheet's warp is simulated on the simulator only"),
              std::string::npos);
  }

  // A run's options check their session's rules too (plan_program, plan_job), its calibration's
  // feed being the run's feed override.
  motion::RunOptions r;
  r.session.executor.blu_mm = 5;
  try {
    r.validate();
    ADD_FAILURE() << "a run's options took a paper mode's setting in planned mode";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "executor.blu_mm");
  }
  r = {};
  r.session.executor.mode = executor::Mode::paper_open;
  r.session.active_calibration = true;
  try {
    r.validate();
    ADD_FAILURE() << "a calibration in a paper mode without a feed";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "paper_feed_mm_per_s");
  }
  r.feed_override_mm_per_s = 4.0;
  EXPECT_NO_THROW(r.validate()) << "the feed override is the calibration's feed";
}

TEST(MachineSession, ThePaperModesLackHoldsOverridesAndRecoveryOnly) {
  hardware::OperatorInputs in;
  EXPECT_EQ(paper_mode_lacks(in), "");
  in.stop = in.estop = true;
  in.thc_enabled = false;
  EXPECT_EQ(paper_mode_lacks(in), "") << "stop, the E-stop and THC are the paper modes' too";
  hardware::OperatorInputs a;
  a.cycle_start = true;
  EXPECT_EQ(paper_mode_lacks(a), "a cycle start");
  a = {};
  a.feed_override_pct = 50;
  EXPECT_EQ(paper_mode_lacks(a), "a feed override of 50 %");
  a = {};
  a.rapid_override_pct = 25;
  EXPECT_EQ(paper_mode_lacks(a), "a rapid override of 25 %");
  a = {};
  a.paused_motion_mm = -5;
  EXPECT_EQ(paper_mode_lacks(a), "a paused motion of -5 mm");
}

TEST(MachineSession, OperatorInputsReachTheExecutorThroughTheBackend) {
  MachineSessionOptions o;
  o.machine = "xy_table";
  o.executor.mode = executor::Mode::jog;
  o.executor.jog.speed_mm_per_s = 20;
  o.executor.record_trace = false;
  MachineSession s(o);
  motion::Job job;
  job.source = "operator";
  job.start_mm = {200, 175};
  const auto session = s.start(job, {}, {});
  hardware::OperatorInputs in;
  in.jog = {1.0, 0.0};
  s.operator_inputs().set(in);
  for (int i = 0; i < 1000; ++i) ASSERT_TRUE(session->tick());
  Eigen::Vector2d at;
  ASSERT_TRUE(s.backend().true_position(at));
  EXPECT_GT(at.x(), 210.0) << "a second at 20 mm/s to the right";
  EXPECT_NEAR(at.y(), 175.0, 0.05);
  in = {};
  in.cycle_start = true;  // ends the manual part
  s.operator_inputs().set(in);
  int ticks = 0;
  while (session->tick() && ticks < 20000) ++ticks;
  EXPECT_LT(ticks, 20000);
  EXPECT_EQ(session->finish().summary.status, Status::done);
}

TEST(OperatorChannel, TheNewestStateWinsAndButtonsMerge) {
  hardware::OperatorChannel ch;
  EXPECT_EQ(ch.latest().jog[0], 0.0);
  hardware::OperatorInputs a, b;
  a.jog = {0.5, 0.0};
  b.jog = {-0.25, 0.75};
  b.feed_hold = true;
  ch.set(a);
  ch.set(b);
  EXPECT_EQ(ch.latest().jog[0], -0.25);
  EXPECT_EQ(ch.latest().jog[1], 0.75);  // read twice: still the newest
  hardware::OperatorInputs pendant;
  pendant.jog = {0.1, 0.1};
  pendant.cycle_start = true;
  hardware::OperatorMerger merger;
  const hardware::OperatorInputs m = merger.merge(pendant, ch.latest());
  EXPECT_EQ(m.jog[0], -0.25) << "the channel's stick wins while it is deflected";
  EXPECT_TRUE(m.feed_hold);
  EXPECT_TRUE(m.cycle_start);
  const hardware::OperatorInputs idle = merger.merge(pendant, hardware::OperatorInputs{});
  EXPECT_EQ(idle.jog[0], 0.1) << "a centred channel leaves the pendant's stick";
}

TEST(OperatorMerger, TheLevelThatChangedLastWinsAndRecoveryRequestsAdd) {
  hardware::OperatorMerger merger;
  hardware::OperatorInputs pin, panel;
  EXPECT_EQ(merger.merge(pin, panel).feed_override_pct, 100.0);
  panel.feed_override_pct = 50;
  EXPECT_EQ(merger.merge(pin, panel).feed_override_pct, 50.0) << "the panel's knob moved";
  EXPECT_EQ(merger.merge(pin, panel).feed_override_pct, 50.0) << "and stays";
  pin.feed_override_pct = 120;
  EXPECT_EQ(merger.merge(pin, panel).feed_override_pct, 120.0) << "then the pin moved";
  panel.thc_enabled = false;
  EXPECT_FALSE(merger.merge(pin, panel).thc_enabled);
  pin.paused_motion_mm = -5;
  panel.paused_motion_mm = 2;
  EXPECT_EQ(merger.merge(pin, panel).paused_motion_mm, -3.0);
}

TEST(RunOnASession, TheDeadlineInMachineTimeStopsTheRunTorchOff) {
  motion::RunOptions o;
  o.session.executor.record_trace = false;
  Termination t;
  t.set_deadline(5.0, "machine time");
  const motion::RunOutcome r = motion::run_program(part("triangle_45.ngc"), o, {&t, nullptr, nullptr});
  EXPECT_EQ(r.summary.status, Status::deadline) << r.summary.full_report();
  EXPECT_TRUE(r.result.torch_off_at_end);
  EXPECT_NE(r.summary.message.find("the deadline of 5 s of machine time was reached"), std::string::npos) << r.summary.message;
  EXPECT_NE(r.summary.full_report().find("cycle ratio           -"), std::string::npos) << "no ratio for a run that did not complete";
  EXPECT_EQ(r.summary.exit_code(), 3);
}

TEST(RunOnASession, AnInjectedFaultThatNeverTookEffectIsReported) {
  motion::RunOptions o;
  o.session.executor.record_trace = false;
  sim::FaultInjection late;
  late.kind = sim::FaultInjection::Kind::arc_start_failure;
  late.at_s = 500;
  o.session.backend.sim.faults.push_back(late);
  const motion::RunOutcome r = motion::run_program(part("triangle_45.ngc"), o);
  EXPECT_TRUE(r.summary.done());
  ASSERT_EQ(r.result.backend_notes.size(), 1u);
  EXPECT_NE(r.result.backend_notes[0].find("arc-start-failure@500 s never fired"), std::string::npos) << r.result.backend_notes[0];
  EXPECT_NE(r.summary.full_report().find("warning: the injected fault arc-start-failure@500 s never fired"), std::string::npos);

  // Fired after the last pierce: it took effect on nothing.
  o.session.backend.sim.faults[0].at_s = r.result.cycle_time_s - 0.5;
  const motion::RunOutcome after = motion::run_program(part("triangle_45.ngc"), o);
  ASSERT_EQ(after.result.backend_notes.size(), 1u);
  EXPECT_NE(after.result.backend_notes[0].find("never took effect: no arc was started after it"), std::string::npos)
      << after.result.backend_notes[0];
}

}  // namespace
}  // namespace machplan::session
