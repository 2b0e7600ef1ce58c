// The runtime an operator expects: feed hold and resume along the path, live feed and rapid
// overrides, the operator's stop, run from line, and a spindle machine.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/hardware/operator_events.h"
#include "tests/support/datasets.h"
#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using executor::HoldReport;
using executor::TraceSample;

using test::part;
std::string program(const std::string& name) { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/programs/" + name; }

RunOutcome run_with_events(const std::string& path, const std::string& events, const std::string& machine = "thermal_gantry",
                           bool trace = true) {
  RunOptions o;
  o.session.machine = machine;
  o.session.executor.record_trace = trace;
  if (!events.empty()) o.session.backend.sim.operator_events = hardware::parse_operator_events(events, "events.csv").states;
  return run_program(path, o);
}

// Points of the cut: measured positions while the torch burns (arc OK), every `every`-th.
std::vector<Eigen::Vector2d> cut_points(const std::vector<TraceSample>& trace, int every) {
  std::vector<Eigen::Vector2d> out;
  int n = 0;
  for (const TraceSample& s : trace)
    if (s.torch_fire && s.arc_ok && n++ % every == 0) out.push_back(s.measured_mm);
  return out;
}

// The largest distance from a point of `a` to the nearest point of `b` (a grid of `cell` mm).
double farthest_from(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b, double cell) {
  std::map<std::pair<long, long>, std::vector<Eigen::Vector2d>> grid;
  const auto key = [cell](const Eigen::Vector2d& p) {
    return std::make_pair(static_cast<long>(std::floor(p.x() / cell)), static_cast<long>(std::floor(p.y() / cell)));
  };
  for (const Eigen::Vector2d& p : b) grid[key(p)].push_back(p);
  double worst = 0.0;
  for (const Eigen::Vector2d& p : a) {
    const auto [kx, ky] = key(p);
    double best = 2 * cell;  // beyond the neighbouring cells: at least a cell away
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy) {
        const auto it = grid.find({kx + dx, ky + dy});
        if (it == grid.end()) continue;
        for (const Eigen::Vector2d& q : it->second) best = std::min(best, (p - q).norm());
      }
    worst = std::max(worst, best);
  }
  return worst;
}

TEST(FeedHold, TwentyHoldsOnTheNestedSheetStopAlongThePathAndTheCutIsWhole) {
  const RunOutcome plain = run_with_events(part("nested_sheet.ngc"), "");
  ASSERT_TRUE(plain.summary.done()) << plain.summary.full_report();
  // 20 holds at seeded random instants, each released 0.6 s later.
  std::mt19937_64 rng(21);
  std::vector<double> at;
  for (int i = 0; i < 20; ++i) at.push_back(std::uniform_real_distribution<double>(1.0, plain.result.cycle_time_s - 60)(rng));
  std::sort(at.begin(), at.end());
  std::string events = "t_s,event,value\n";
  double shift = 0.0;
  for (double t : at) {
    events += fmt::format("{:.3f},hold,\n{:.3f},start,\n", t + shift, t + shift + 0.6);
    shift += 2.5;  // a stop, a re-pierce: the later instants move on with the job
  }
  const RunOutcome held = run_with_events(part("nested_sheet.ngc"), events);
  ASSERT_TRUE(held.summary.done()) << held.summary.full_report();
  ASSERT_EQ(held.result.holds.size(), 20u) << [&] {
    std::string t = events + "holds at:";
    for (const HoldReport& h : held.result.holds) t += fmt::format(" {:.3f}", h.t_s);
    return t;
  }();
  const double period = held.machine.servo_period_s;
  int in_cuts = 0, in_rapids = 0;
  for (const HoldReport& h : held.result.holds) {
    SCOPED_TRACE(fmt::format("hold at {:.3f} s, line {}: v {:.4f} a {:.3f} A {:.3f} J {:.1f}", h.t_s, h.source_line,
                             h.speed_mm_per_s, h.acceleration_mm_per_s2, h.stop_acceleration_mm_per_s2, h.stop_jerk_mm_per_s3));
    ASSERT_TRUE(h.stopped);
    EXPECT_LE(h.distance_to_stop_mm, h.jerk_limited_stop_mm() + h.speed_mm_per_s * period + 1e-6);
    EXPECT_LE(h.off_path_mm, held.planner.path_tolerance_mm + 1e-9);  // the setpoint never leaves the path
    EXPECT_FALSE(std::isnan(h.resumed_at_s));
    if (h.torch_off) {  // the hold put the torch out in a cut: before rest, and the resume pierced again
      ++in_cuts;
      EXPECT_TRUE(h.in_cut);
      EXPECT_TRUE(h.torch_off_before_rest);
      EXPECT_GT(h.repierce_s, 0.0);
    }
    in_rapids += h.in_rapid;
  }
  EXPECT_GE(in_cuts, 5);
  EXPECT_GE(in_rapids, 3);
  // The cut is the same cut: every point of each within the kerf (1.5 mm) of the other.
  const auto a = cut_points(plain.result.trace, 5), b = cut_points(held.result.trace, 5);
  EXPECT_LE(farthest_from(a, b, 1.0), 0.75);
  EXPECT_LE(farthest_from(b, a, 1.0), 0.75);
}

// A 500 mm straight cut at 3000 mm/min (50 mm/s) on the gantry.
constexpr const char* kLongCut =
    "G21 G90\nG0 X100 Y200\nM3\nG4 P0.5\nG1 X600 Y200 F3000\nM5\nG0 X50 Y50\nM2\n";

TEST(FeedOverride, ThePathSpeedFollowsItsStepsWithinTheLimits) {
  test::TempDir dir;
  const std::string prog = dir.write("long_cut.ngc", kLongCut);
  const RunOutcome r =
      run_with_events(prog, "t_s,event,value\n5.0,feed_override,50\n7.0,feed_override,150\n9.0,feed_override,100\n");
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  const auto& tr = r.result.trace;
  const double dt = r.machine.servo_period_s, A = r.machine.limits.acceleration_mm_per_s2, J = r.machine.limits.jerk_mm_per_s3;
  const double vmax = r.machine.limits.velocity_mm_per_s;
  // Commanded speed, acceleration and jerk per axis, by differences of the commanded points.
  std::vector<double> t, speed;
  double worst_a = 0.0, worst_j = 0.0;
  for (std::size_t i = 3; i < tr.size(); ++i) {
    const Eigen::Vector2d v = (tr[i].commanded_mm - tr[i - 1].commanded_mm) / dt;
    const Eigen::Vector2d v1 = (tr[i - 1].commanded_mm - tr[i - 2].commanded_mm) / dt;
    const Eigen::Vector2d v2 = (tr[i - 2].commanded_mm - tr[i - 3].commanded_mm) / dt;
    const Eigen::Vector2d a = (v - v1) / dt, a1 = (v1 - v2) / dt;
    t.push_back(tr[i].t_s);
    speed.push_back(v.norm());
    if (tr[i].torch_fire) {
      worst_a = std::max(worst_a, a.cwiseAbs().maxCoeff());
      worst_j = std::max(worst_j, ((a - a1) / dt).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LE(worst_a, A * 1.01);
  EXPECT_LE(worst_j, J * 1.05);
  // After each step the speed reaches its new value (150 %: capped below the axes' speed)
  // within the time the limits need (an S-curve: dv / A + A / J) and 50 ms.
  const auto reached = [&](double from_s, double target) {
    for (std::size_t i = 0; i < t.size(); ++i)
      if (t[i] >= from_s && std::abs(speed[i] - target) <= 0.01 * target) return t[i] - from_s;
    return 1e9;
  };
  const double F = 50.0;
  // (The cut runs from about 4.3 s: rapid, pierce.)
  const double steps[3][3] = {{5.0, F, 0.5 * F}, {7.0, 0.5 * F, std::min(1.5 * F, 0.95 * vmax)}, {9.0, std::min(1.5 * F, 0.95 * vmax), F}};
  for (const auto& [at, from, to] : steps) {
    const double need = std::abs(to - from) / A + A / J;
    EXPECT_LE(reached(at, to), need + 0.05) << "step at " << at << " s to " << to << " mm/s";
  }
}

TEST(RapidOverride, TwentyFivePercentCapsTheRapidsAtAQuarter) {
  test::TempDir dir;
  const std::string prog = dir.write("rapids.ngc", "G21 G90\nG0 X900 Y700\nG0 X100 Y100\nM2\n");
  const RunOutcome full = run_with_events(prog, "");
  const RunOutcome slow = run_with_events(prog, "t_s,event,value\n0,rapid_override,25\n");
  ASSERT_TRUE(full.summary.done() && slow.summary.done());
  const auto top = [](const RunOutcome& r) {
    double v = 0.0;
    for (std::size_t i = 1; i < r.result.trace.size(); ++i)
      v = std::max(v, (r.result.trace[i].commanded_mm - r.result.trace[i - 1].commanded_mm).norm() / r.machine.servo_period_s);
    return v;
  };
  EXPECT_GT(top(full), 70.0);
  EXPECT_LE(top(slow), 0.25 * top(full) + 1e-6);
  EXPECT_GT(slow.result.cycle_time_s, 3.0 * full.result.cycle_time_s);
}

// One straight cut along X on the thermal gantry at `feed` mm/min.
std::string straight_cut(const test::TempDir& dir, int feed) {
  return dir.write(fmt::format("straight_{}.ngc", feed),
                   fmt::format("G21 G90 G17 G40 G94\nG0 X100 Y100\nM3 S1\nG1 X400 Y100 F{}\nM5\nG0 X0 Y0\nM2\n", feed));
}

// What the panel shows 0.5 s into the cut of `path` run with the feed override at `feed_pct`
// from the start, and the run's cycle time.
struct Shown {
  executor::LiveState live;
  double cycle_s = 0.0;
};
Shown shown_in_the_cut(const std::string& path, double feed_pct) {
  RunOptions o;
  o.session.machine = "thermal_gantry";
  o.session.executor.record_trace = false;
  o.session.backend.sim.operator_events =
      hardware::parse_operator_events(fmt::format("t_s,event,value\n0.0,feed_override,{}\n", feed_pct), "events.csv").states;
  session::MachineSession s(session_options_for(o));
  const PlannedRun plan = plan_program(path, o, s.machine());
  session::MachineSession::RunHooks hooks;
  hooks.expected_s = plan.expected_s();
  auto run = s.start(plan.job, plan.trajectories, hooks);
  Shown r;
  long in_cut = 0;
  while (run->tick()) {
    const executor::LiveState l = s.live().read();
    if (l.arc_ok && l.path_speed_mm_per_s > 1.0 && ++in_cut == 500) r.live = l;
  }
  EXPECT_GE(in_cut, 500);
  r.cycle_s = run->finish().cycle_time_s;
  return r;
}

TEST(FeedOverride, AboveTheMachinesTopSpeedTheTimeLeftAndTheOverrideShownAreWhatTheMachineDoes) {
  test::TempDir dir;
  // At 80 mm/s along X the cut runs at the axis' top speed: 150 % changes nothing, and the
  // panel must say so (the time left as at 100 %, the override taken 100 %).
  const std::string top = straight_cut(dir, 4800);
  const Shown top100 = shown_in_the_cut(top, 100), top150 = shown_in_the_cut(top, 150);
  // (Within two periods: the blends at the cut's ends leave the rate a sliver of room.)
  EXPECT_NEAR(top150.cycle_s, top100.cycle_s, 0.002);
  EXPECT_EQ(top150.live.feed_override_pct, 150.0);
  EXPECT_NEAR(top150.live.feed_effective_pct, 100.0, 1e-9);
  EXPECT_NEAR(top150.live.time_left_s, top100.live.time_left_s, 0.002);
  // At 30 mm/s there is room: the cut runs at 150 %, and the time left is as true as at 100 %
  // (only the cut speeds up; the rapids and the torch take as long as at 100 %).
  const std::string slow = straight_cut(dir, 1800);
  const Shown slow100 = shown_in_the_cut(slow, 100), slow150 = shown_in_the_cut(slow, 150);
  EXPECT_LT(slow150.cycle_s, slow100.cycle_s - 2.0);
  EXPECT_NEAR(slow150.live.feed_effective_pct, 150.0, 2.0);  // the ramps at the cut's ends stay at the plan's rate
  const auto miss = [](const Shown& s) { return s.live.time_left_s - (s.cycle_s - s.live.t_s); };
  std::printf("30 mm/s: time left shown minus the time the run took from there: %.3f s at 100 %%, %.3f s at 150 %%\n",
              miss(slow100), miss(slow150));
  EXPECT_NEAR(miss(slow150), miss(slow100), 0.1 * (slow100.cycle_s - slow150.cycle_s));
}

TEST(FeedOverride, ZeroPercentHoldsAFeedMoveUntilItRises) {
  test::TempDir dir;
  const std::string prog = dir.write("long_cut.ngc", kLongCut);
  const RunOutcome r = run_with_events(prog, "t_s,event,value\n4.0,feed_override,0\n6.0,feed_override,100\n");
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  ASSERT_EQ(r.result.holds.size(), 1u);
  EXPECT_TRUE(r.result.holds[0].by_override);
  EXPECT_TRUE(r.result.holds[0].in_cut);
  EXPECT_NEAR(r.result.holds[0].resumed_at_s, 6.0, 0.01);
}

TEST(OperatorStop, EndsTheJobTorchOffAsCancelled) {
  const RunOutcome r = run_with_events(part("triangle_45.ngc"), "t_s,event,value\n6.0,stop,\n");
  EXPECT_EQ(r.summary.status, Status::cancelled) << r.summary.full_report();
  EXPECT_EQ(r.result.summary.status, Status::cancelled);  // the executor's own word for it
  ASSERT_FALSE(r.result.faults.empty());
  EXPECT_EQ(r.result.faults[0].kind, executor::FaultKind::operator_stop);
  EXPECT_TRUE(r.result.torch_off_at_end);
  EXPECT_TRUE(r.result.stopped_at_rest);
}

// The job's moves from `from` on, as geometry, feeds and lines.
std::vector<std::string> moves_of(const Job& job, std::size_t from_step) {
  std::vector<std::string> out;
  for (std::size_t s = from_step; s < job.steps.size(); ++s) {
    const Step& st = job.steps[s];
    if (st.kind != Step::Kind::move) {
      out.push_back(fmt::format("step {} line {}", static_cast<int>(st.kind), st.source_line));
      continue;
    }
    const Stretch& k = job.stretches[st.stretch];
    for (std::size_t j = 0; j < k.segments.size(); ++j)
      out.push_back(fmt::format("{} {} ({:.9f},{:.9f})->({:.9f},{:.9f}) sweep {:.9f} f {:.6f} line {}", k.cutting, k.rapid,
                                k.segments[j].start.x(), k.segments[j].start.y(), k.segments[j].end.x(), k.segments[j].end.y(),
                                k.segments[j].sweep, k.feed_mm_per_s[j], k.source_lines[j]));
  }
  return out;
}

TEST(RunFromLine, TheMovesAfterTheStartAreTheFullRunsTail) {
  RunOptions o;
  const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const PlannedRun full = plan_program(part("nested_sheet.ngc"), o, m);
  for (int line : {12, 40, 77, 150, 300}) {
    SCOPED_TRACE(fmt::format("--from-line {}", line));
    o.from_line = line;
    const PlannedRun tail = plan_program(part("nested_sheet.ngc"), o, m);
    ASSERT_TRUE(tail.from_line.has_value());
    // The full job's steps from the start step on, against the tail's after its rapid and relight.
    const std::vector<std::string> full_moves = moves_of(full.job, tail.from_line->step);
    std::size_t skip = 1 + (tail.from_line->relight ? 1 : 0);
    std::vector<std::string> tail_moves = moves_of(tail.job, skip);
    // A start inside a move: the full job's move is entered at the line's segment.
    if (tail.from_line->segment > 0) {
      const std::vector<std::string> cut = moves_of(full.job, tail.from_line->step);
      ASSERT_GE(cut.size(), tail.from_line->segment);
    }
    std::vector<std::string> expected(full_moves.begin() + static_cast<std::ptrdiff_t>(tail.from_line->segment), full_moves.end());
    EXPECT_EQ(tail_moves, expected);
    // It starts with a rapid to where the line begins, from the job's start.
    const Stretch& first = tail.job.stretches[tail.job.steps[0].stretch];
    EXPECT_TRUE(first.rapid);
    EXPECT_LT((first.segments.back().end - tail.from_line->at_mm).norm(), 1e-9);
  }
  // And runs to its end.
  o.from_line = 150;
  const RunOutcome r = run_program(part("nested_sheet.ngc"), o);
  EXPECT_TRUE(r.summary.done()) << r.summary.full_report();
}

// The panel's move to a job's start is the rapid a run from a line starts with, alone.
TEST(RunFromLine, ItsRapidAloneIsTheMoveToAJobsStart) {
  const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  RunOptions o;
  o.from_line = 40;
  const PlannedRun tail = plan_program(part("nested_sheet.ngc"), o, m);
  ASSERT_TRUE(tail.from_line.has_value());
  const Job alone = rapid_job(tail.programmed.start_mm, tail.from_line->at_mm, m.limits.rapid_mm_per_s, "to the start");
  EXPECT_EQ(alone.source, "to the start");
  EXPECT_EQ(alone.start_mm, tail.programmed.start_mm);
  ASSERT_EQ(alone.steps.size(), 1u);
  const Stretch& r = alone.stretches[alone.steps[0].stretch];
  EXPECT_TRUE(r.rapid);
  EXPECT_FALSE(r.cutting);
  ASSERT_EQ(r.segments.size(), 1u);
  EXPECT_EQ(r.segments[0].start, tail.programmed.start_mm);
  EXPECT_EQ(r.segments[0].end, tail.from_line->at_mm);
  EXPECT_EQ(r.feed_mm_per_s[0], m.limits.rapid_mm_per_s);
  // Planned and run as any job, it ends where the line begins.
  o.from_line = 0;
  const RunOutcome run = run_job(alone, o);
  ASSERT_TRUE(run.summary.done()) << run.summary.full_report();
  EXPECT_LT((run.job.stretches.back().segments.back().end - tail.from_line->at_mm).norm(), 1e-9);
}

TEST(RunFromLine, ALineAfterTheLastStepIsRefused) {
  RunOptions o;
  o.from_line = 100000;
  try {
    run_program(part("triangle_45.ngc"), o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "from_line");
    EXPECT_NE(std::string(e.what()).find("comes after the program's last step"), std::string::npos) << e.what();
  }
}

TEST(Spindle, TheMillingProgramRunsOnTheXyTableAndItsSpindleTurnsThroughAHold) {
  const RunOutcome r = run_with_events(program("mill_slot_plate.ngc"), "t_s,event,value\n10.0,hold,\n11.0,start,\n", "xy_table");
  ASSERT_TRUE(r.summary.done()) << r.summary.full_report();
  int starts = 0;
  for (const Step& st : r.job.steps) starts += st.kind == Step::Kind::torch_on;
  EXPECT_EQ(starts, 1);  // M3 once, M5 once
  ASSERT_EQ(r.result.holds.size(), 1u);
  EXPECT_FALSE(r.result.holds[0].in_cut);  // nothing was turned off
  EXPECT_EQ(r.result.holds[0].repierce_s, 0.0);
  bool turning_while_held = false;
  for (const TraceSample& s : r.result.trace)
    if (s.t_s > 10.5 && s.t_s < 10.9) turning_while_held = s.torch_fire;
  EXPECT_TRUE(turning_while_held);
  EXPECT_NE(r.summary.full_report().find("spindle on"), std::string::npos);
}

// An oxy-fuel torch held mid-cut: the cutting oxygen goes off before the axes rest, the preheat
// flame burns on, so the resume re-pierces with the cutting oxygen's pierce delay alone, not a
// second preheat.
TEST(FeedHold, AnOxyFuelTorchKeepsItsPreheatFlameThroughAHold) {
  test::TempDir dir;
  std::ifstream in(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string plasma = "kind: plasma";
  ASSERT_NE(text.find(plasma), std::string::npos);
  text.replace(text.find(plasma), plasma.size(), "kind: oxy_fuel");
  const std::string machine = dir.write("oxy_gantry.yaml", text);
  const std::string prog = dir.write("long_cut.ngc", kLongCut);
  const RunOutcome plain = run_with_events(prog, "", machine);
  ASSERT_TRUE(plain.summary.done()) << plain.summary.full_report();
  const double preheat = plain.machine.torch.oxy_fuel.preheat_s, pierce = plain.machine.torch.oxy_fuel.pierce_delay_s;
  ASSERT_GT(preheat, 3 * pierce);  // so that a second preheat would show
  // Held halfway along the 500 mm cut (the torch cutting at x = 350 mm).
  double t_hold = -1.0;
  for (const TraceSample& t : plain.result.trace)
    if (t.torch_fire && t.measured_mm.x() > 350.0) {
      t_hold = t.t_s;
      break;
    }
  ASSERT_GT(t_hold, preheat);
  const RunOutcome held =
      run_with_events(prog, fmt::format("t_s,event,value\n{:.3f},hold,\n{:.3f},start,\n", t_hold, t_hold + 1.0), machine);
  ASSERT_TRUE(held.summary.done()) << held.summary.full_report();
  ASSERT_EQ(held.result.holds.size(), 1u);
  const HoldReport& h = held.result.holds[0];
  EXPECT_TRUE(h.in_cut);
  EXPECT_TRUE(h.torch_off);
  EXPECT_TRUE(h.torch_off_before_rest);
  EXPECT_GE(h.repierce_s, pierce - 1e-9);
  EXPECT_LT(h.repierce_s, pierce + 0.5 * preheat) << "the resume preheated again";
  // The whole job took the hold, the wait and the re-pierce longer, no second preheat.
  EXPECT_LT(held.result.cycle_time_s, plain.result.cycle_time_s + 1.0 + pierce + 0.5 * preheat);
}

TEST(OperatorEventsCli, HoldsAreReportedInJsonAndThePaperModesRefuseThem) {
  const test::Cli cli;
  const std::string events = cli.write("events.csv", "t_s,event,value\n5.0,hold,\n6.0,start,\n");
  const test::CliResult r = cli.run({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--operator-events", events, "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["holds"].size(), 1u);
  for (const char* f : {"t_s", "position_mm", "distance_to_stop_mm", "off_path_mm", "jerk_limited_stop_mm", "resumed_at_s"})
    EXPECT_TRUE(j["holds"][0].contains(f)) << f;
  const test::CliResult paper = cli.run({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--mode", "paper-open",
                                         "--feed", "4", "--operator-events", events});
  EXPECT_EQ(paper.code, 2);
  EXPECT_NE(paper.err.find("--operator-events: a feed hold at 5 s: the paper modes take no feed hold"), std::string::npos)
      << paper.err;
  const std::string stop = cli.write("stop.csv", "t_s,event,value\n5.0,stop,\n");
  EXPECT_EQ(cli.run({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--operator-events", stop}).code, 3);
}

}  // namespace
}  // namespace machplan::motion
