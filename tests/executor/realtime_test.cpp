// The executor's real-time rules, measured: no heap allocation inside a tick (any mode, trace
// in memory and streamed), a stop requested from another thread, a position-command backend
// and an operator's jog session driven through the same loop.
#include <algorithm>
#include <array>
#include <cstdio>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <new>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/executor/executor.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/motion/run.h"
#include "engine/hardware/operator_events.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/forwarding_backend.h"
#include "tests/support/ideal_backend.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

std::string part(const char* name) { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/" + name; }

// Keeps the optimiser from eliding an allocation whose pointer it sees go unused (C++ lets it
// drop a new/delete pair, replaced operator new or not).
void keep_allocation(const void* p) { asm volatile("" : : "g"(p) : "memory"); }

// The counter itself sees allocations, in each form the tick could use, or every zero below
// would prove nothing. (malloc is counted under AddressSanitizer only; the four operator new
// forms, the nothrow one in stable_sort's buffer, are counted in every build.)
TEST(AllocationCounter, SeesEveryFormOfAllocation) {
  std::vector<int> v = {5, 3, 4, 1, 2};
  g_allocations = 0;
  g_counting = true;
  int* one = new int(1);
  int* many = new int[8];
  int* nothrow = new (std::nothrow) int(2);
  void* raw = std::malloc(16);
  for (const void* p : {static_cast<const void*>(one), static_cast<const void*>(many),
                        static_cast<const void*>(nothrow), static_cast<const void*>(raw)})
    keep_allocation(p);
  std::stable_sort(v.begin(), v.end());  // its buffer: the nothrow form
  g_counting = false;
  const long seen = g_allocations;
  delete one;
  delete[] many;
  delete nothrow;
  std::free(raw);
  EXPECT_GE(seen, 4);
  EXPECT_TRUE(std::is_sorted(v.begin(), v.end()));
}

struct Case {
  const char* part;
  Mode mode;
  bool stream;
  bool operator_inputs = false;  // holds, resumes and overrides during the run; the live state published
};

class TickAllocations : public ::testing::TestWithParam<Case> {};

TEST_P(TickAllocations, AreZero) {
  const Case c = GetParam();
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  o.session.executor.mode = c.mode;
  o.session.executor.record_trace = false;
  if (c.mode != Mode::planned) o.feed_override_mm_per_s = 4.0;
  const motion::RunOutcome prepared = motion::run_program(part(c.part), o);  // job, trajectories, machine
  ASSERT_FALSE(prepared.faulted());

  ExecutorOptions eo = o.session.executor;
  eo.record_trace = true;
  sim::SimOptions so;
  so.start_mm = prepared.job.start_mm;
  Latest<LiveState> live;
  RunParts parts;
  if (c.operator_inputs) {
    const auto tl = hardware::parse_operator_events("t_s,event,value\n"
                                                    "2.0,hold,\n3.0,start,\n"
                                                    "5.0,feed_override,50\n7.0,feed_override,150\n8.5,recover,-2\n"
                                                    "9.0,rapid_override,25\n9.2,start,\n"
                                                    "11.0,hold,\n11.5,start,\n14.0,feed_override,0\n15.0,feed_override,100\n",
                                                    "events.csv");
    so.operator_events = tl.states;
    parts.live = &live;
    // A lost arc recovered (back along the cut, re-pierce), on a warped sheet THC follows.
    so.faults.push_back({sim::FaultInjection::Kind::arc_loss, 7.5});
    so.sheet_warp_mm = std::make_pair(3.0, 1000.0);
  }
  cutting::MachineConfig machine = prepared.machine;
  machine.torch.plasma.recover_on_arc_loss = c.operator_inputs;
  sim::SimBackend be(machine, so);
  Executor ex(machine.setup(), eo);
  test::TempDir dir;
  std::unique_ptr<TraceStream> stream;
  if (c.stream) {
    stream = std::make_unique<TraceStream>((dir.path() / "trace.csv").string());
    parts.trace_stream = stream.get();
  }
  static const Trajectories kNone;
  Session s(ex, prepared.job, c.mode == Mode::planned ? prepared.trajectories : kNone, be, parts);
  long ticks = 0;
  g_allocations = 0;
  bool more = true;
  while (more && ticks < 10'000'000) {
    g_counting = true;
    more = s.tick();
    g_counting = false;
    ++ticks;
  }
  const long during = g_allocations;
  const ExecutionResult r = s.finish();
  EXPECT_EQ(during, 0) << ticks << " ticks";
  EXPECT_EQ(r.summary.status, Status::done) << r.report();
  EXPECT_GT(ticks, 10000);
  EXPECT_EQ(static_cast<long>(r.trace.size()), ticks);  // every tick recorded, none dropped
  EXPECT_FALSE(r.trace_truncated);
  if (c.stream) {
    EXPECT_EQ(static_cast<long>(r.trace_streamed), ticks);
    EXPECT_EQ(r.trace_stream_dropped, 0u);
  }
  if (c.operator_inputs) {
    EXPECT_GE(r.holds.size(), 3u);  // two by the button, one by the 0 % override
    EXPECT_TRUE(std::any_of(r.holds.begin(), r.holds.end(), [](const HoldReport& h) { return h.by_arc_loss; }));
    EXPECT_TRUE(std::any_of(r.cuts.begin(), r.cuts.end(), [](const CutError& e) { return e.thc.samples > 0; }));
    EXPECT_EQ(live.read().tick, static_cast<std::uint64_t>(ticks - 1));
  }
}

INSTANTIATE_TEST_SUITE_P(EveryMode, TickAllocations,
                         ::testing::Values(Case{"contour_lines_arcs.ngc", Mode::planned, false},
                                           Case{"contour_lines_arcs.ngc", Mode::planned, true},
                                           Case{"triangle_45.ngc", Mode::paper_open, false},
                                           Case{"triangle_45.ngc", Mode::paper_closed, true},
                                           Case{"contour_lines_arcs.ngc", Mode::planned, true, true}),
                         [](const auto& info) {
                           std::string name = to_string(info.param.mode);  // "paper-open": no '-' in a test name
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name + (info.param.stream ? "_streamed" : "") + (info.param.operator_inputs ? "_operated" : "");
                         });

TEST(TraceStream, WritesWhatTheRecorderKeeps) {
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  test::TempDir dir;
  o.session.trace_csv_path = (dir.path() / "streamed.csv").string();
  const motion::RunOutcome run = motion::run_program(part("triangle_45.ngc"), o);
  ASSERT_FALSE(run.faulted());
  const std::string kept = (dir.path() / "kept.csv").string();
  run.result.write_trace_csv(kept);
  std::ifstream a(o.session.trace_csv_path), b(kept);
  const std::string sa((std::istreambuf_iterator<char>(a)), {}), sb((std::istreambuf_iterator<char>(b)), {});
  EXPECT_GT(sa.size(), 100000u);
  EXPECT_EQ(sa, sb);
}

// Holds the loop at one exchange (a moment of machine time) until a stop has been requested,
// so that a test can ask from another thread at a known point of the run.
class HoldUntilStopped : public test::ForwardingBackend {
 public:
  HoldUntilStopped(hardware::Backend& inner, long hold_at_exchange, const StopSource& stop)
      : ForwardingBackend(inner), hold_at_(hold_at_exchange), stop_(stop) {}
  hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& i) noexcept override {
    if (++exchanges_ == hold_at_) {
      reached_.store(true);
      while (!stop_.stop_requested()) std::this_thread::yield();
    }
    return ForwardingBackend::exchange(o, i);
  }
  bool reached() const { return reached_.load(); }

 private:
  long hold_at_, exchanges_ = 0;
  const StopSource& stop_;
  std::atomic<bool> reached_{false};
};

// A stop requested from another thread while the torch cuts: the loop is held at 2 s of machine
// time (inside the cut, which starts at about 1.3 s) until the other thread has asked, so the
// stop lands at a known moment whatever the speed of the computer.
TEST(StopRequest, FromAnotherThreadStopsTheMachineAndReports) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const Eigen::Vector2d c(700, 700);
  auto cut = test::one_cut(test::make_stretch(test::circle_segments(c, 50), 80, true),
                           std::make_unique<test::ArcTrajectory>(c, 50, 0, 2 * M_PI, 80, 500));
  sim::SimOptions so;
  so.start_mm = cut.job.start_mm;
  sim::SimBackend sim(m, so);
  StopSource token;
  const double at_s = 2.0;
  HoldUntilStopped held(sim, std::lround(at_s / sim.period_s()), token);
  Executor ex(m.setup(), {});
  Termination stop(token.token());
  RunParts parts;
  parts.termination = &stop;
  std::thread other([&] {
    while (!held.reached()) std::this_thread::yield();
    token.request_stop();
  });
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, held, parts);
  other.join();
  ASSERT_TRUE(held.reached()) << r.report();
  ASSERT_EQ(r.faults.size(), 1u) << r.report();
  EXPECT_EQ(r.faults[0].kind, FaultKind::stop_requested);
  // Seen within a few periods of the request.
  EXPECT_GE(r.faults[0].time_s, at_s - 2 * sim.period_s());
  EXPECT_LT(r.faults[0].time_s, at_s + 5 * sim.period_s());
  EXPECT_TRUE(r.torch_off_at_end);
  EXPECT_TRUE(r.stopped_at_rest);
  EXPECT_FALSE(sim.torch_firing());
  EXPECT_FALSE(sim.drives_enabled());
  EXPECT_FALSE(r.cuts[0].complete);
  for (const TraceSample& t : r.trace)
    if (t.t_s > r.faults[0].time_s) { ASSERT_FALSE(t.torch_fire); }
}

TEST(PositionBackend, RunsAJobThroughTheSameLoop) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const Eigen::Vector2d a(100, 100), b(400, 250);
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  test::IdealPositionBackend be(m, a);
  Executor ex(m.setup(), {});
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, be);
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  EXPECT_EQ(r.backend, "ideal_position");
  ASSERT_EQ(r.cuts.size(), 1u);
  EXPECT_TRUE(r.cuts[0].complete);
  EXPECT_LT(r.cuts[0].max_mm, 1e-6);  // the ideal drive is where it is told
  Eigen::Vector2d end;
  be.true_position(end);
  EXPECT_LT((end - b).norm(), 1e-6);
}

TEST(PositionBackend, EstopStopsItToo) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const Eigen::Vector2d a(100, 100), b(400, 250);
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  struct Estopper final : test::ForwardingBackend {
    test::IdealPositionBackend& p;
    long n = 0;
    explicit Estopper(test::IdealPositionBackend& i) : ForwardingBackend(i), p(i) {}
    hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& in) noexcept override {
      if (++n == 2500) p.set_estop(true);
      return ForwardingBackend::exchange(o, in);
    }
  };
  test::IdealPositionBackend inner(m, a);
  Estopper be(inner);
  Executor ex(m.setup(), {});
  const ExecutionResult r = ex.run(cut.job, cut.trajectories, be);
  ASSERT_EQ(r.faults.size(), 1u);
  EXPECT_EQ(r.faults[0].kind, FaultKind::estop);
  EXPECT_TRUE(r.torch_off_at_end);
  EXPECT_FALSE(inner.drives_enabled());
}

// A position backend that plays positions planned ahead (as the HAL component does when a
// command comes late): what the executor plans for the periods ahead is where it then commands
// the axes, exactly, through a feed hold and its resume too; and from the period a stop begins
// it plans nothing (a stop is the stop's law, not the path).
struct AheadRecorder final : test::ForwardingBackend {
  test::IdealPositionBackend& p;
  long n = 0, hold_at = -1, resume_at = -1, stop_at = -1;
  std::vector<Eigen::Vector2d> cmd;
  std::vector<std::vector<std::array<double, 2>>> ahead;
  explicit AheadRecorder(test::IdealPositionBackend& i) : ForwardingBackend(i), p(i) {}
  int plays_ahead_periods() const override { return hardware::Outputs::kMaxAhead; }
  hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& in) noexcept override {
    hardware::OperatorInputs op;
    op.feed_hold = hold_at >= 0 && n >= hold_at && n < resume_at;
    op.cycle_start = n >= resume_at && n < resume_at + 5;
    op.stop = stop_at >= 0 && n >= stop_at;
    p.set_operator(op);
    ++n;
    cmd.emplace_back(o.position_command_mm[0], o.position_command_mm[1]);
    ahead.emplace_back(o.ahead_mm.begin(), o.ahead_mm.begin() + o.ahead_count);
    return ForwardingBackend::exchange(o, in);
  }
  // The largest distance between a period's plan and the commands that followed it, planned and
  // commanded within the periods [from, to), planned while the axes moved. (At rest the plan says rest: a move that starts
  // within the horizon, after a pierce or a hold, is the program's to start.)
  double worst(std::size_t from, std::size_t to) const {
    double w = 0.0;
    for (std::size_t k = std::max<std::size_t>(from, 1); k < to && k < cmd.size(); ++k)
      if (cmd[k] != cmd[k - 1])
      for (std::size_t j = 0; j < ahead[k].size() && k + j + 1 < std::min(to, cmd.size()); ++j)
        w = std::max(w, (Eigen::Vector2d(ahead[k][j][0], ahead[k][j][1]) - cmd[k + j + 1]).norm());
    return w;
  }
};

TEST(PositionBackend, PlansAheadWhereItWillCommandAndNothingOnceItStops) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  const Eigen::Vector2d a(100, 100), b(400, 250);
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  Executor ex(m.setup(), {});
  {
    test::IdealPositionBackend inner(m, a);
    AheadRecorder be(inner);
    be.hold_at = 2000;
    be.resume_at = 3000;
    const ExecutionResult r = ex.run(cut.job, cut.trajectories, be);
    ASSERT_EQ(r.summary.status, Status::done) << r.report();
    ASSERT_EQ(be.ahead[1500].size(), static_cast<std::size_t>(hardware::Outputs::kMaxAhead));
    // Nothing could foresee the operator's hold: the plans made before the executor saw it are
    // checked up to the press. The others, through the stop along the path and the resume, are
    // the time scale's own steps, so exact.
    const double w = std::max(be.worst(0, 2000), be.worst(2002, be.cmd.size()));
    std::printf("planned ahead against commanded, through a hold and a resume: %.2g mm at most\n", w);
    EXPECT_LT(w, 1e-9);
  }
  {
    test::IdealPositionBackend inner(m, a);
    AheadRecorder be(inner);
    be.stop_at = 2000;
    const ExecutionResult r = ex.run(cut.job, cut.trajectories, be);
    ASSERT_FALSE(r.summary.done());
    EXPECT_FALSE(be.ahead[1999].empty());
    for (std::size_t k = 2003; k < be.ahead.size(); ++k) ASSERT_TRUE(be.ahead[k].empty()) << "period " << k;
  }
}

TEST(JogSession, FollowsTheOperatorAndEndsOnCycleStart) {
  const auto m = cutting::load_machine(cutting::find_machine("xy_table"));
  sim::SimOptions so;
  so.start_mm = {150, 150};
  hardware::OperatorInputs right, centred, done;
  right.jog = {1.0, 0.5};
  done.cycle_start = true;
  so.operator_events = {{0.2, right}, {1.2, centred}, {2.0, done}};
  sim::SimBackend sim(m, so);
  ExecutorOptions eo;
  eo.mode = Mode::jog;
  eo.jog.speed_mm_per_s = 40;
  Executor ex(m.setup(), eo);
  motion::Job none;
  none.source = "jog";
  none.start_mm = so.start_mm;
  const ExecutionResult r = ex.run(none, {}, sim);
  ASSERT_EQ(r.summary.status, Status::done) << r.report();
  Eigen::Vector2d at;
  sim.true_position(at);
  // 1 s at 40 and 20 mm/s (less the ramps at 500 mm/s^2 with the jerk limit): about 38 and 19 mm.
  EXPECT_NEAR(at.x() - 150, 40 * 1.0, 4.0);
  EXPECT_NEAR(at.y() - 150, 20 * 1.0, 3.0);
  EXPECT_NEAR(r.cycle_time_s, 2.0, 0.5);
  double vmax = 0;
  for (std::size_t k = 1; k < r.trace.size(); ++k)
    vmax = std::max(vmax, (r.trace[k].commanded_mm - r.trace[k - 1].commanded_mm).norm() / 0.001);
  EXPECT_LE(vmax, std::hypot(40.0, 20.0) + 1e-6);
}

TEST(JogSession, RefusesAJob) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({{0, 0}, {10, 0}}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 0), 80, 500));
  sim::SimBackend sim(m, {});
  ExecutorOptions eo;
  eo.mode = Mode::jog;
  Executor ex(m.setup(), eo);
  EXPECT_THROW(ex.run(cut.job, {}, sim), InputError);
}

TEST(BackendCheck, AMachineFileThatDisagreesWithTheBackendIsRefusedBeforeMotion) {
  const auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  cutting::MachineConfig other = m;
  other.axes[1].plant.dac_bits = 16;
  sim::SimBackend sim(other, {});
  const Eigen::Vector2d a(0, 0), b(10, 0);
  auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                           std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  Executor ex(m.setup(), {});
  try {
    ex.run(cut.job, cut.trajectories, sim);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("machine 'thermal_gantry': backend 'sim' disagrees with the machine file: axis Y "
                                         "dac_bits is 16 on the backend, 12 in the machine file"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(sim.time_s(), 0.0);
}

}  // namespace
}  // namespace machplan::executor

namespace machplan::executor {
namespace {

// An encoder whose real scale is 0.4 % off what the machine file (and the backend) declare:
// decoded with the declared scale the cut lands off; with the calibrated scale it lands true.
TEST(CalibratedEncoderScale, DecodesTheCountersWithTheMeasuredScale) {
  const auto nominal = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  cutting::MachineConfig truth = nominal;
  for (auto& ax : truth.axes) ax.plant.encoder_mm_per_rev *= 1.004;
  const Eigen::Vector2d a(100, 100), b(400, 250);
  struct Declared final : test::ForwardingBackend {  // the truth, declaring the nominal signals
    const cutting::MachineConfig& m;
    Declared(hardware::Backend& inner, const cutting::MachineConfig& nominal) : ForwardingBackend(inner), m(nominal) {}
    hardware::AxisSignals axis_signals(int i) const override {
      const auto& p = m.axes[i].plant;
      return {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), p.command_latency_ticks,
              p.reading_latency_ticks};
    }
  };
  const auto end_error = [&](bool calibrated) {
    auto cut = test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), 80, true),
                             std::make_unique<test::LineTrajectory>(a, b, 80, 500));
    sim::SimOptions so;
    so.start_mm = a;
    sim::SimBackend sim(truth, so);
    Declared be(sim, nominal);
    MachineSetup setup = nominal.setup();
    if (calibrated)
      for (int i = 0; i < 2; ++i) setup.calibrated_mm_per_count[i] = truth.axes[i].plant.mm_per_count();
    const ExecutionResult r = Executor(setup, {}).run(cut.job, cut.trajectories, be);
    EXPECT_EQ(r.summary.status, Status::done) << r.report();
    Eigen::Vector2d at;
    sim.true_position(at);
    return (at - b).norm();
  };
  const double off = end_error(false), on = end_error(true);
  EXPECT_GT(off, 0.4 * 0.004 * (b - a).norm());  // most of the 0.4 % of the 335 mm travelled
  EXPECT_LT(on, 0.05);
  MachineSetup bad = nominal.setup();
  bad.calibrated_mm_per_count[0] = 2 * bad.signals[0].mm_per_count;
  EXPECT_THROW(bad.validate(), InputError);
}

}  // namespace
}  // namespace machplan::executor
