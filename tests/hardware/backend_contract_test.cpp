// The backend contract (engine/hardware/backend.h), one suite run against every backend.
//
// A new backend is one more entry in kBackends below: a name and a function that builds it on
// the thermal gantry's machine file, with the hooks the suite needs to provoke what the
// contract is about (missed exchanges, an open E-stop chain, a lost link). A backend that
// cannot be told to do something in a test (a real controller) provides the hook through its
// simulator or test mode.
#include <algorithm>
#include <array>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"

#include "engine/hardware/backend.h"
#include "engine/hardware/hal_backend.h"
#include "models/backends/backend_factory.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "tests/support/ideal_backend.h"
// MACHPLAN_HAL_BACKEND (tests/CMakeLists.txt) is 1 in a build with the HAL backend: the suite
// then runs on the HAL-simulated machine too.
#if MACHPLAN_HAL_BACKEND
#include "tests/support/hal_sim.h"
#endif

namespace machplan::hardware {
namespace {

struct Harness {
  std::unique_ptr<Backend> backend;
  std::function<void(int)> miss_exchanges;  // n periods pass with no exchange
  std::function<void()> open_estop;
  std::function<void()> lose_link;
};

struct Entry {
  const char* name;
  std::function<Harness(const cutting::MachineConfig&)> make;
};

const cutting::MachineConfig& gantry() {
  static const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  return m;
}

Harness sim_harness(const cutting::MachineConfig& m) {
  backends::BackendOptions o;
  o.name = "sim";
  o.sim.start_mm = {500, 500};
  auto b = backends::make_backend(m, o);
  auto* s = dynamic_cast<sim::SimBackend*>(b.get());
  Harness h;
  h.miss_exchanges = [s](int n) { s->miss_exchanges(n); };
  // The simulator's faults fire at the start of the next period.
  h.open_estop = [s] { s->inject({sim::FaultInjection::Kind::estop, s->time_s(), 0, 0}); };
  h.lose_link = [s] { s->inject({sim::FaultInjection::Kind::lost_backend, s->time_s(), 0, 0}); };
  h.backend = std::move(b);
  return h;
}

template <class B>
Harness ideal_harness(const cutting::MachineConfig& m) {
  auto b = std::make_unique<B>(m, Eigen::Vector2d(500, 500));
  B* p = b.get();
  Harness h;
  h.miss_exchanges = [p](int n) { p->miss_exchanges(n); };
  h.open_estop = [p] { p->set_estop(true); };
  h.lose_link = [p] { p->lose(); };
  h.backend = std::move(b);
  return h;
}

#if MACHPLAN_HAL_BACKEND
// The HAL-simulated thermal gantry (scripts/hal-sim, position mode), brought up once for all
// the tests (ctest's hal_sim_down stops it): before each, the threads run, the E-stop chain is
// closed and the resting axes are homed at 500, 500. Missed exchanges are counted in the
// component's own periods; the link is lost by stopping HAL's threads.
Harness hal_harness(const cutting::MachineConfig& m) {
  test::ensure_hal_sim();
  auto pins = std::make_shared<test::HalPins>();
  pins->start_threads();
  pins->set_signal("estop-open", 0);
  test::hal_sim("home 500 500");
  backends::BackendOptions o;
  o.name = "hal";
  o.hal.start_mm = {500, 500};
  auto b = backends::make_backend(m, o);
  auto* hal = dynamic_cast<HalBackend*>(b.get());
  Harness h;
  h.miss_exchanges = [hal, pins](int n) {
    const double until = static_cast<double>(hal->last_period()) + n;
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (pins->number("machplan.period-count") < until && std::chrono::steady_clock::now() < limit)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
  };
  h.open_estop = [pins] { pins->set_signal("estop-open", 1); };
  h.lose_link = [pins] { pins->stop_threads(); };
  h.backend = std::move(b);
  return h;
}
#endif

// ---- every backend: one line each ----
const Entry kBackends[] = {
    {"sim", sim_harness},
    {"ideal_dac", ideal_harness<test::IdealDacBackend>},
    {"ideal_position", ideal_harness<test::IdealPositionBackend>},
#if MACHPLAN_HAL_BACKEND
    {"hal", hal_harness},
#endif
};

class BackendContract : public ::testing::TestWithParam<Entry> {
 protected:
  void SetUp() override { h_ = GetParam().make(gantry()); }
  Backend& be() { return *h_.backend; }
  // Enabled outputs that move both axes at about 20 mm/s.
  Outputs moving() {
    Outputs o;
    o.drives_enabled = true;
    o.torch_height_target_mm = 15.0;
    for (int i = 0; i < kAxes; ++i) {
      const AxisSignals s = be().axis_signals(i);
      o.dac_code[i] = static_cast<std::int32_t>(20.0 / s.dac_full_scale_mm_per_s * (1 << (s.dac_bits - 1)));
      o.position_command_mm[i] = 500.0;
    }
    return o;
  }
  // Position as the executor would see it: decoded movement of the counters, or the feedback.
  double travel(const Inputs& a, const Inputs& b, int axis) {
    if (be().command_kind() == CommandKind::position) return b.position_feedback_mm[axis] - a.position_feedback_mm[axis];
    return a.counter[axis] != b.counter[axis] ? 1.0 : 0.0;  // moved at all
  }
  Harness h_;
};

TEST_P(BackendContract, DeclaresWhatItOffers) {
  EXPECT_GT(be().period_s(), 0.0);
  EXPECT_LE(be().period_s(), 0.1);
  EXPECT_GE(be().watchdog_periods(), 1);
  EXPECT_NE(std::string(be().name()), "");
  for (int i = 0; i < kAxes; ++i) {
    const AxisSignals s = be().axis_signals(i);
    EXPECT_GE(s.command_latency_ticks, 0);
    EXPECT_GE(s.reading_latency_ticks, 0);
    if (be().command_kind() == CommandKind::speed_dac) {
      EXPECT_GT(s.mm_per_count, 0.0);
      EXPECT_GT(s.dac_full_scale_mm_per_s, 0.0);
      EXPECT_GE(s.counter_bits, 8);
      EXPECT_GE(s.dac_bits, 8);
    }
  }
}

TEST_P(BackendContract, InitialInputsAreTheStandingMachineAndMakeNoExchange) {
  const Inputs a = be().initial_inputs();
  const Inputs b = be().initial_inputs();
  EXPECT_EQ(a.counter, b.counter);
  EXPECT_EQ(a.position_feedback_mm, b.position_feedback_mm);
  EXPECT_FALSE(a.estop);
  EXPECT_FALSE(a.watchdog_tripped);
  EXPECT_FALSE(a.arc_ok);
  for (double j : a.op.jog) EXPECT_EQ(j, 0.0);
  if (be().command_kind() == CommandKind::position) {
    EXPECT_DOUBLE_EQ(a.position_feedback_mm[0], 500.0);
    EXPECT_DOUBLE_EQ(a.position_feedback_mm[1], 500.0);
  }
}

TEST_P(BackendContract, DisabledDrivesDoNotMoveAndEnabledOnesDo) {
  Inputs start = be().initial_inputs(), in;
  Outputs off = moving();
  off.drives_enabled = false;
  if (be().command_kind() == CommandKind::position) off.position_command_mm = {510.0, 490.0};
  for (int k = 0; k < 50; ++k) ASSERT_EQ(be().exchange(off, in), Health::ok);
  EXPECT_EQ(travel(start, in, 0), 0.0);
  EXPECT_EQ(travel(start, in, 1), 0.0);
  Outputs on = moving();
  if (be().command_kind() == CommandKind::position) on.position_command_mm = {500.5, 499.5};
  for (int k = 0; k < 200; ++k) ASSERT_EQ(be().exchange(on, in), Health::ok);
  EXPECT_NE(travel(start, in, 0), 0.0);
  EXPECT_NE(travel(start, in, 1), 0.0);
}

// The timing rule: the outputs of an exchange take effect at the start of its period, after the
// drive's declared command latency, and the inputs it returns are as old as the declared
// reading latency. So a move commanded at exchange 0 shows in the feedback that exchange
// (command + reading latency) returns at the soonest, and soon after that: no backend may
// show it early (outputs applied before their period, feedback fresher than declared) nor
// hold it back.
TEST_P(BackendContract, ACommandShowsInTheFeedbackAfterTheDeclaredLatenciesAndNoSooner) {
  Inputs in;
  Outputs still = moving();
  still.dac_code = {0, 0};
  for (int k = 0; k < 50; ++k) ASSERT_EQ(be().exchange(still, in), Health::ok);
  const Inputs rest = in;
  for (int k = 0; k < 20; ++k) ASSERT_EQ(be().exchange(still, in), Health::ok);
  ASSERT_EQ(travel(rest, in, 0), 0.0) << "the machine must stand still at rest for this test";
  Outputs go = moving();
  if (be().command_kind() == CommandKind::position) go.position_command_mm = {500.2, 499.8};
  std::array<int, kAxes> first{-1, -1};
  for (int k = 0; k < 200 && (first[0] < 0 || first[1] < 0); ++k) {
    ASSERT_EQ(be().exchange(go, in), Health::ok);
    for (int i = 0; i < kAxes; ++i)
      if (first[i] < 0 && travel(rest, in, i) != 0.0) first[i] = k;
  }
  for (int i = 0; i < kAxes; ++i) {
    const AxisSignals s = be().axis_signals(i);
    const int latency = s.command_latency_ticks + s.reading_latency_ticks;
    EXPECT_GE(first[i], latency) << "axis " << i << ": the move showed before the declared latencies";
    // A counter shows the move once the axis has crossed a count: at 20 mm/s through the
    // drive's lag, a few periods.
    EXPECT_LE(first[i], latency + 20) << "axis " << i;
  }
}

TEST_P(BackendContract, WatchdogStopsTheMachineWhenExchangesStop) {
  Inputs in;
  const Outputs on = moving();
  for (int k = 0; k < 20; ++k) ASSERT_EQ(be().exchange(on, in), Health::ok);
  EXPECT_FALSE(in.watchdog_tripped);
  // A pause shorter than the watchdog is allowed.
  h_.miss_exchanges(be().watchdog_periods() - 1);
  ASSERT_EQ(be().exchange(on, in), Health::ok);
  EXPECT_FALSE(in.watchdog_tripped);
  // A longer one trips it, and it stays tripped: the drives no longer follow commands.
  h_.miss_exchanges(be().watchdog_periods() + 5);
  ASSERT_EQ(be().exchange(on, in), Health::ok);
  EXPECT_TRUE(in.watchdog_tripped);
  Inputs before = in;
  Outputs again = on;
  if (be().command_kind() == CommandKind::position) again.position_command_mm = {520.0, 480.0};
  for (int k = 0; k < 100; ++k) be().exchange(again, in);
  EXPECT_TRUE(in.watchdog_tripped);
  EXPECT_FALSE(in.arc_ok);
  // Coasting to rest after the trip may still move the axes a little; commands do not.
  Inputs later = in;
  for (int k = 0; k < 100; ++k) be().exchange(again, in);
  EXPECT_EQ(travel(later, in, 0), 0.0);
  EXPECT_EQ(travel(later, in, 1), 0.0);
  (void)before;
}

TEST_P(BackendContract, EstopIsReportedAndCutsDrivesAndTorch) {
  Inputs in;
  Outputs on = moving();
  on.torch_fire = true;
  for (int k = 0; k < 20; ++k) be().exchange(on, in);
  h_.open_estop();
  for (int k = 0; k < 5; ++k) be().exchange(on, in);
  EXPECT_TRUE(in.estop);
  EXPECT_FALSE(in.arc_ok);
  for (int k = 0; k < 200; ++k) be().exchange(on, in);  // let any motion die out
  const Inputs rest = in;
  for (int k = 0; k < 100; ++k) be().exchange(on, in);
  EXPECT_EQ(travel(rest, in, 0), 0.0);
  EXPECT_EQ(travel(rest, in, 1), 0.0);
}

TEST_P(BackendContract, LostIsFinal) {
  Inputs in;
  const Outputs on = moving();
  for (int k = 0; k < 10; ++k) ASSERT_EQ(be().exchange(on, in), Health::ok);
  h_.lose_link();
  Health h = Health::ok;
  for (int k = 0; k < 3 && h == Health::ok; ++k) h = be().exchange(on, in);
  ASSERT_EQ(h, Health::lost);
  for (int k = 0; k < 20; ++k) EXPECT_EQ(be().exchange(on, in), Health::lost);
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, BackendContract, ::testing::ValuesIn(kBackends),
                         [](const auto& info) { return std::string(info.param.name); });

// Paced to the wall clock, the simulator lives in the program's process: a stall of the process
// stalls the simulated machine too, so nothing moved and nothing trips; the stall is told.
TEST(SimPaced, AStallOfTheProcessIsToldNotTrippedOn) {
  sim::SimOptions o;
  o.realtime = true;
  o.watchdog_periods = 20;
  sim::SimBackend sim(gantry(), o);
  Outputs out;
  out.drives_enabled = true;
  Inputs in = sim.initial_inputs();
  for (int i = 0; i < 5; ++i) ASSERT_EQ(sim.exchange(out, in), Health::ok);
  std::this_thread::sleep_for(std::chrono::milliseconds(60));  // 60 periods, past the watchdog's 20
  ASSERT_EQ(sim.exchange(out, in), Health::ok);
  EXPECT_FALSE(in.watchdog_tripped);
  const std::vector<std::string> notes = sim.notes();
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("stalled 1 time(s) past the watchdog's 20 periods"), std::string::npos) << notes[0];
  // An injected watchdog still trips it.
  sim::FaultInjection f;
  f.kind = sim::FaultInjection::Kind::watchdog;
  f.at_s = 0.0;
  sim.inject(f);
  for (int i = 0; i < 3; ++i) sim.exchange(out, in);
  EXPECT_TRUE(in.watchdog_tripped);
}

TEST(BackendFactory, UnknownNameListsTheKnownOnes) {
  backends::BackendOptions o;
  o.name = "linuxcnc-typo";
  const std::string known = MACHPLAN_HAL_BACKEND ? "sim, hal" : "sim";
  try {
    backends::make_backend(gantry(), o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("name: unknown backend 'linuxcnc-typo' (known: " + known + ")"), std::string::npos)
        << e.what();
  }
}

// A build without LinuxCNC's HAL has no "hal" backend, and says so to whoever asks for it; a
// build with it takes "hal" as a valid name (opening it needs HAL running: tests/hal).
TEST(BackendFactory, HalIsThereExactlyWhenBuiltWithIt) {
  const std::vector<std::string> names = backends::backend_names();
  const bool listed = std::find(names.begin(), names.end(), "hal") != names.end();
  EXPECT_EQ(listed, MACHPLAN_HAL_BACKEND == 1);
  backends::BackendOptions o;
  o.name = "hal";
  if (MACHPLAN_HAL_BACKEND) {
    EXPECT_NO_THROW(o.validate());
  } else {
    try {
      backends::make_backend(gantry(), o);
      FAIL() << "a build without HAL made a hal backend";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("name: this machplan was built without LinuxCNC's HAL"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace machplan::hardware
