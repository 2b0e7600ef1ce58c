// The probing and operator signals between HAL and the Backend interface, on the HAL-simulated
// thermal gantry (scripts/hal-sim): each test opens a HalBackend session of its own, exchanges
// periods with it, and sets the component's input pins either with halcmd's setp (the operator
// pins, which the simulation leaves unlinked) or through the simulation's plate model, by
// commanding the torch height down onto the plate (float-switch, ohmic-sense-in, breakaway;
// datasets/hal/sim_common.hal). Every test starts HAL and stops it again (HalSim).
#include <chrono>
#include <cstdint>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "engine/hardware/backend.h"
#include "engine/hardware/hal_backend.h"
#include "models/backends/backend_factory.h"
#include "models/cutting/machine_config.h"
#include "tests/support/hal_sim.h"

namespace machplan {
namespace {

using hardware::Health;
using hardware::Inputs;
using hardware::Outputs;

// The plate model's thresholds (datasets/hal/thermal_gantry.hal): the float switch's travel and
// the float's overtravel before the breakaway.
constexpr double kFloatTravel = 1.5, kOvertravel = 2.0;
// The height axis moves 50 mm/s: 0.05 mm a period. A switch's first closed sample carries the
// height its comparison was made at, so the height there lies within one period's travel of
// the threshold (and a little more for rounding).
constexpr double kStep = 0.06;

const cutting::MachineConfig& gantry() {
  static const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
  return m;
}

// One HalBackend session on the running simulation, the axes standing at `start`.
class Session {
 public:
  explicit Session(Eigen::Vector2d start) {
    backends::BackendOptions o;
    o.name = "hal";
    o.hal.start_mm = start;
    backend_ = backends::make_backend(gantry(), o);
    in_ = backend_->initial_inputs();
    out.drives_enabled = true;
    out.position_command_mm = {start.x(), start.y()};
    out.torch_height_target_mm = 10.0;
  }
  // n periods with `out`; the inputs of the last.
  const Inputs& run(int n) {
    for (int i = 0; i < n; ++i) step();
    return in_;
  }
  // Periods with `out` until `done` holds for the inputs, at most `limit`; false when it never did.
  bool run_until(const std::function<bool(const Inputs&)>& done, int limit = 3000) {
    for (int i = 0; i < limit; ++i)
      if (done(step())) return true;
    return false;
  }
  // Periods until the sample returned was taken after now (after a pin was set): the program
  // may run behind the servo thread and return older samples first.
  const Inputs& catch_up(const test::HalPins& pins) {
    const auto now = static_cast<std::uint32_t>(pins.number("machplan.period-count"));
    auto* hal = dynamic_cast<hardware::HalBackend*>(backend_.get());
    EXPECT_NE(hal, nullptr);
    for (int i = 0; i < 2000 && hal && static_cast<std::int32_t>(hal->last_period() - now) <= 0; ++i) step();
    EXPECT_GT(static_cast<std::int32_t>(hal->last_period() - now), 0) << "the exchange fell 2000 periods behind";
    return in_;
  }
  // Periods until the output pin `pin` reads `value` (the commands go out ahead, but a late one
  // is dropped), then until a sample taken after that; false when it never did.
  bool until_pin(const test::HalPins& pins, const std::string& pin, bool value) {
    for (int i = 0; i < 2000; ++i) {
      if (pins.bit(pin) == value) {
        catch_up(pins);
        return true;
      }
      step();
    }
    return false;
  }
  const Inputs& in() const { return in_; }
  Outputs out;

 private:
  const Inputs& step() {
    const Health h = backend_->exchange(out, in_);
    EXPECT_EQ(h, Health::ok);
    return in_;
  }
  std::unique_ptr<hardware::Backend> backend_;
  Inputs in_;
};

TEST(HalSignals, OperatorPinsReachTheOperatorInputs) {
  test::HalSim sim;
  test::HalPins pins;
  Session s({0, 0});
  const Inputs& idle = s.catch_up(pins);
  // The pins' defaults are the operator's neutral ones.
  EXPECT_FALSE(idle.op.stop);
  EXPECT_EQ(idle.op.rapid_override_pct, 100.0);
  EXPECT_EQ(idle.op.paused_motion_mm, 0.0);
  EXPECT_TRUE(idle.op.thc_enabled);
  EXPECT_FALSE(idle.op.estop);
  EXPECT_FALSE(idle.estop);

  pins.set_pin("machplan.stop", 1);
  EXPECT_TRUE(s.catch_up(pins).op.stop);
  pins.set_pin("machplan.stop", 0);
  EXPECT_FALSE(s.catch_up(pins).op.stop);

  pins.set_pin("machplan.rapid-override", 40);
  EXPECT_EQ(s.catch_up(pins).op.rapid_override_pct, 40.0);
  // Out of range: clamped to 1 .. 100; not a number: 100.
  pins.set_pin("machplan.rapid-override", 0.2);
  EXPECT_EQ(s.catch_up(pins).op.rapid_override_pct, 1.0);
  pins.set_pin("machplan.rapid-override", 250);
  EXPECT_EQ(s.catch_up(pins).op.rapid_override_pct, 100.0);
  pins.set_pin("machplan.rapid-override", 55);
  EXPECT_EQ(s.catch_up(pins).op.rapid_override_pct, 55.0);
  pins.set_pin("machplan.rapid-override", std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(s.catch_up(pins).op.rapid_override_pct, 100.0);

  // The buttons, as the component samples them.
  pins.set_pin("machplan.feed-hold", 1);
  EXPECT_TRUE(s.catch_up(pins).op.feed_hold);
  pins.set_pin("machplan.feed-hold", 0);
  EXPECT_FALSE(s.catch_up(pins).op.feed_hold);
  pins.set_pin("machplan.cycle-start", 1);
  EXPECT_TRUE(s.catch_up(pins).op.cycle_start);
  pins.set_pin("machplan.cycle-start", 0);
  EXPECT_FALSE(s.catch_up(pins).op.cycle_start);
  // The feed override: 0 .. 200 %, clamped; not a number: 100 %.
  pins.set_pin("machplan.feed-override", 35);
  EXPECT_EQ(s.catch_up(pins).op.feed_override_pct, 35.0);
  pins.set_pin("machplan.feed-override", 250);
  EXPECT_EQ(s.catch_up(pins).op.feed_override_pct, 200.0);
  pins.set_pin("machplan.feed-override", std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(s.catch_up(pins).op.feed_override_pct, 100.0);
  pins.set_pin("machplan.feed-override", 100);
  // The joystick, per axis.
  pins.set_pin("machplan.jog.0", 0.25);
  pins.set_pin("machplan.jog.1", -0.5);
  const Inputs& jogged = s.catch_up(pins);
  EXPECT_EQ(jogged.op.jog[0], 0.25);
  EXPECT_EQ(jogged.op.jog[1], -0.5);
  pins.set_pin("machplan.jog.0", 0);
  pins.set_pin("machplan.jog.1", 0);
  // The arc voltage (unlinked in the simulation): volts; 0 or less reads as not measured.
  pins.set_pin("machplan.arc-voltage", 121.5);
  EXPECT_EQ(s.catch_up(pins).arc_voltage_v, 121.5);
  pins.set_pin("machplan.arc-voltage", -3);
  EXPECT_EQ(s.catch_up(pins).arc_voltage_v, 0.0);

  EXPECT_TRUE(idle.op.torch_enabled);
  pins.set_pin("machplan.torch-enable", 0);
  EXPECT_FALSE(s.catch_up(pins).op.torch_enabled);
  pins.set_pin("machplan.torch-enable", 1);
  EXPECT_TRUE(s.catch_up(pins).op.torch_enabled);

  pins.set_pin("machplan.thc-enable", 0);
  EXPECT_FALSE(s.catch_up(pins).op.thc_enabled);
  pins.set_pin("machplan.thc-enable", 1);
  EXPECT_TRUE(s.catch_up(pins).op.thc_enabled);

  // Cut recovery is a counter: the distance asked since the session opened.
  pins.set_pin("machplan.cut-recovery-distance", 7.5);
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_mm, 7.5);
  pins.set_pin("machplan.cut-recovery-distance", 2.0);  // 5.5 mm backwards
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_mm, 2.0);
  pins.set_pin("machplan.cut-recovery-distance", std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_mm, 2.0);  // no request: the last good value stands

  // The paused-motion speed is a level, -1 .. 1: clamped; not a number: no motion.
  EXPECT_EQ(idle.op.paused_motion_speed, 0.0);
  pins.set_pin("machplan.paused-motion-speed", -0.5);
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_speed, -0.5);
  pins.set_pin("machplan.paused-motion-speed", 3.0);
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_speed, 1.0);
  pins.set_pin("machplan.paused-motion-speed", std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_speed, 0.0);
  pins.set_pin("machplan.paused-motion-speed", 0.0);

  // The operator's E-stop: reported as the operator's, not as the chain's, and it drops the
  // drives in the component at once; latched for the rest of the session.
  ASSERT_TRUE(s.until_pin(pins, "machplan.enable", true));
  pins.set_pin("machplan.operator-estop", 1);
  const Inputs& stopped = s.catch_up(pins);
  EXPECT_TRUE(stopped.op.estop);
  EXPECT_FALSE(stopped.estop);
  EXPECT_FALSE(pins.bit("machplan.enable"));
  pins.set_pin("machplan.operator-estop", 0);
  EXPECT_TRUE(s.catch_up(pins).op.estop);
  EXPECT_FALSE(pins.bit("machplan.enable"));
}

// watchdog-reset: a session that stops exchanging trips the component's watchdog (drives off,
// watchdog-ok FALSE, latched); a rising edge of watchdog-reset clears it.
TEST(HalSignals, WatchdogResetClearsATrip) {
  test::HalSim sim;
  test::HalPins pins;
  Session s({0, 0});
  ASSERT_TRUE(s.until_pin(pins, "machplan.enable", true));
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // no exchange: more than the 200-period watchdog
  ASSERT_TRUE(pins.wait_bit("machplan.watchdog-ok", false, std::chrono::milliseconds(1000)));
  EXPECT_FALSE(pins.bit("machplan.enable"));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(pins.bit("machplan.watchdog-ok")) << "latched";
  pins.set_pin("machplan.watchdog-reset", 1);
  EXPECT_TRUE(pins.wait_bit("machplan.watchdog-ok", true, std::chrono::milliseconds(1000)));
  pins.set_pin("machplan.watchdog-reset", 0);
}

TEST(HalSignals, CutRecoveryCountsFromWhereThePinStoodWhenTheSessionOpened) {
  test::HalSim sim;
  test::HalPins pins;
  pins.set_pin("machplan.cut-recovery-distance", 12.0);  // left by an earlier job
  pins.set_pin("machplan.operator-estop", 1);
  pins.set_pin("machplan.operator-estop", 0);  // released before the session: no E-stop in it
  Session s({0, 0});
  const Inputs& first = s.catch_up(pins);
  EXPECT_EQ(first.op.paused_motion_mm, 0.0);
  EXPECT_FALSE(first.op.estop);
  EXPECT_TRUE(s.until_pin(pins, "machplan.enable", true));  // the drives come on: no E-stop latched
  pins.set_pin("machplan.cut-recovery-distance", 15.0);
  EXPECT_EQ(s.catch_up(pins).op.paused_motion_mm, 3.0);
}

// Down onto the flat plate at the sheet's nominal surface (0): the ohmic contact at 0 with
// ohmic-enable on, the float switch at -float travel, the breakaway at -(float travel +
// overtravel); each opens again on the way up.
TEST(HalSignals, ThePlateModelClosesOhmicFloatAndBreakawayAtTheirHeights) {
  test::HalSim sim;
  test::HalPins pins;
  Session s({0, 0});
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
  EXPECT_FALSE(s.in().ohmic_sense);
  EXPECT_FALSE(s.in().float_switch);
  EXPECT_FALSE(s.in().torch_breakaway);

  // Ohmic sensing follows Outputs::ohmic_enable.
  EXPECT_FALSE(pins.bit("machplan.ohmic-enable"));
  s.out.ohmic_enable = true;
  EXPECT_TRUE(s.until_pin(pins, "machplan.ohmic-enable", true));

  s.out.torch_height_target_mm = -1.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.ohmic_sense; }));
  std::printf("ohmic contact at %.4f mm\n", s.in().torch_height_mm);
  EXPECT_LE(s.in().torch_height_mm, 0.0);
  EXPECT_GT(s.in().torch_height_mm, -kStep);
  EXPECT_FALSE(s.in().float_switch);
  // At -1 mm the torch rests on the plate, the float not yet at its switch.
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm + 1.0) < 1e-6; }));
  EXPECT_TRUE(s.in().ohmic_sense);
  EXPECT_FALSE(s.in().float_switch);
  EXPECT_FALSE(s.in().torch_breakaway);

  // Ohmic sensing off: no contact however the torch stands.
  s.out.ohmic_enable = false;
  EXPECT_TRUE(s.until_pin(pins, "machplan.ohmic-enable", false));
  EXPECT_FALSE(s.in().ohmic_sense);

  s.out.torch_height_target_mm = -3.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.float_switch; }));
  std::printf("float switch at %.4f mm\n", s.in().torch_height_mm);
  EXPECT_LE(s.in().torch_height_mm, -kFloatTravel);
  EXPECT_GT(s.in().torch_height_mm, -kFloatTravel - kStep);
  EXPECT_FALSE(s.in().torch_breakaway);
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm + 3.0) < 1e-6; }));
  EXPECT_TRUE(s.in().float_switch);
  EXPECT_FALSE(s.in().torch_breakaway);  // within the float's overtravel

  s.out.torch_height_target_mm = -5.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.torch_breakaway; }));
  std::printf("breakaway at %.4f mm\n", s.in().torch_height_mm);
  EXPECT_LE(s.in().torch_height_mm, -kFloatTravel - kOvertravel);
  EXPECT_GT(s.in().torch_height_mm, -kFloatTravel - kOvertravel - kStep);
  EXPECT_TRUE(s.in().float_switch);

  // Back up: every switch opens again, in turn.
  s.out.torch_height_target_mm = 10.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return !in.torch_breakaway; }));
  EXPECT_GT(s.in().torch_height_mm, -kFloatTravel - kOvertravel);
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return !in.float_switch; }));
  EXPECT_GT(s.in().torch_height_mm, -kFloatTravel);
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
  EXPECT_FALSE(s.in().float_switch);
  EXPECT_FALSE(s.in().torch_breakaway);
  EXPECT_FALSE(s.in().ohmic_sense);
}

// A plate warped along X (scripts/hal-sim sheet --warp A,L): the contact is made where the
// surface is at that X, A sin(2 pi x / L), not at the nominal 0.
TEST(HalSignals, AWarpedPlateIsTouchedAtItsSurfaceUnderTheTorch) {
  test::HalSim sim;
  test::HalPins pins;
  constexpr double kA = 2.0, kL = 800.0;
  test::hal_sim(fmt::format("sheet --warp {},{}", kA, kL));
  // The simulation's sine is a lincurve of 15 straight pieces on the half wave: within 0.55 %
  // of A of the true sine (datasets/hal/sim_common.hal).
  const double table = 0.0055 * kA + 1e-6;
  for (const double x : {200.0, 700.0}) {  // a crest, then a trough's side
    test::hal_sim(fmt::format("home {} 0", x));
    const double surface = kA * std::sin(2 * std::numbers::pi * x / kL);
    Session s({x, 0});
    s.out.ohmic_enable = true;
    ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
    EXPECT_FALSE(s.in().ohmic_sense);
    s.out.torch_height_target_mm = -6.0;
    ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.ohmic_sense; })) << "x " << x;
    std::printf("x %.0f: surface %.4f mm, ohmic contact at %.4f mm\n", x, surface, s.in().torch_height_mm);
    EXPECT_NEAR(s.in().torch_height_mm, surface, table + kStep) << "x " << x;
    ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.float_switch; })) << "x " << x;
    EXPECT_NEAR(s.in().torch_height_mm, surface - kFloatTravel, table + kStep) << "x " << x;
    ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.torch_breakaway; })) << "x " << x;
    EXPECT_NEAR(s.in().torch_height_mm, surface - kFloatTravel - kOvertravel, table + kStep) << "x " << x;
  }
  // Flat again: the contact is at 0 wherever the torch stands.
  test::hal_sim("sheet --flat");
  Session s({700, 0});
  s.out.ohmic_enable = true;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
  EXPECT_FALSE(s.in().ohmic_sense);
  s.out.torch_height_target_mm = -1.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.ohmic_sense; }));
  EXPECT_LE(s.in().torch_height_mm, 0.0);
  EXPECT_GT(s.in().torch_height_mm, -kStep);
}

// The offset probe: machplan.offset-probe follows Outputs::offset_probe and drops with the
// E-stop chain like torch-on; while it is deployed the simulation's float switch reads the plate
// under the probe (X plus probe-shift.in1), not under the torch.
TEST(HalSignals, TheOffsetProbeReadsThePlateBesideTheTorchAndDropsWithTheEstopChain) {
  test::HalSim sim;
  test::HalPins pins;
  constexpr double kA = 2.0, kL = 800.0, kOffsetX = -100.0, kX = 300.0;  // the probe over x 200, a crest
  test::hal_sim(fmt::format("sheet --warp {},{}", kA, kL));
  test::hal_sim(fmt::format("home {} 0", kX));
  pins.set_pin("probe-shift.in1", kOffsetX);
  const double table = 0.0055 * kA + 1e-6;
  const double under_probe = kA * std::sin(2 * std::numbers::pi * (kX + kOffsetX) / kL);
  const double under_torch = kA * std::sin(2 * std::numbers::pi * kX / kL);
  Session s({kX, 0});
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
  EXPECT_FALSE(pins.bit("machplan.offset-probe"));
  s.out.offset_probe = true;
  EXPECT_TRUE(s.until_pin(pins, "machplan.offset-probe", true));
  s.out.torch_height_target_mm = -6.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.float_switch; }));
  std::printf("offset probe: plate %.4f mm under it, %.4f mm under the torch; contact at %.4f mm\n", under_probe, under_torch,
              s.in().torch_height_mm);
  EXPECT_NEAR(s.in().torch_height_mm, under_probe - kFloatTravel, table + kStep);
  EXPECT_GT(std::abs(s.in().torch_height_mm - (under_torch - kFloatTravel)), 0.5) << "not the plate under the torch";
  s.out.torch_height_target_mm = 10.0;
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return std::abs(in.torch_height_mm - 10.0) < 1e-6; }));
  pins.set_signal("estop-open", 1);
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.estop; }, 50));
  s.catch_up(pins);
  EXPECT_FALSE(pins.bit("machplan.offset-probe")) << "gated by the E-stop chain";
  pins.set_signal("estop-open", 0);
  pins.set_pin("probe-shift.in1", 0.0);
  test::hal_sim("sheet --flat");
}

// ohmic-enable is gated like torch-on: the E-stop chain drops it in the component, whatever
// machplan goes on commanding.
TEST(HalSignals, OhmicEnableDropsWithTheEstopChain) {
  test::HalSim sim;
  test::HalPins pins;
  Session s({0, 0});
  s.out.ohmic_enable = true;
  s.out.torch_height_target_mm = -0.5;  // the shield on the plate
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.ohmic_sense; }));
  EXPECT_TRUE(pins.bit("machplan.ohmic-enable"));
  pins.set_signal("estop-open", 1);
  ASSERT_TRUE(s.run_until([](const Inputs& in) { return in.estop; }, 50));
  const Inputs& after = s.catch_up(pins);
  EXPECT_FALSE(pins.bit("machplan.ohmic-enable"));
  EXPECT_FALSE(pins.bit("machplan.enable"));
  EXPECT_FALSE(after.ohmic_sense);  // no shield voltage, no contact
  EXPECT_FALSE(after.op.estop);     // the chain's, not the operator's
  pins.set_signal("estop-open", 0);
}

}  // namespace
}  // namespace machplan
