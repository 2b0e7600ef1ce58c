// The torch sequencer alone, on hand-made inputs: each sequence's order, its waits, its
// timeouts, and kill() from any phase.
#include <gtest/gtest.h>

#include "engine/executor/torch_sequencer.h"

namespace machplan::executor {
namespace {

using S = TorchSequencer::Tick;

TorchSetup plasma_with_height() {
  TorchSetup t;
  t.kind = TorchSetup::Kind::plasma;
  t.height_axis = true;
  t.pierce_height_mm = 3.8;
  t.cut_height_mm = 1.5;
  t.retract_height_mm = 15.0;
  t.height_tolerance_mm = 0.05;
  t.height_timeout_s = 1.0;
  t.arc_ok_timeout_s = 0.5;
  t.pierce_delay_s = 0.2;
  return t;
}

// A height axis that moves at `speed` toward its target, an arc that lights `arc_delay` after
// firing (never, if negative).
struct Plant {
  double height = 15.0, speed = 50.0, arc_delay = 0.1, fired_for = 0.0;
  void step(const hardware::Outputs& o, hardware::Inputs& in, double dt) {
    const double d = o.torch_height_target_mm - height;
    height += std::clamp(d, -speed * dt, speed * dt);
    fired_for = o.torch_fire ? fired_for + dt : 0.0;
    in.torch_height_mm = height;
    in.arc_ok = o.torch_fire && arc_delay >= 0 && fired_for >= arc_delay;
  }
};

// Runs until the sequencer is no longer busy; returns its status and the time taken.
std::pair<S, double> run(TorchSequencer& seq, Plant& p, hardware::Outputs& out, double limit_s = 10) {
  hardware::Inputs in;
  const double dt = 0.001;
  for (double t = 0; t < limit_s; t += dt) {
    p.step(out, in, dt);
    const S s = seq.tick(in, out);
    if (s != S::busy) return {s, t + dt};
  }
  return {S::busy, limit_s};
}

TEST(TorchSequencer, PlasmaOnGoesDownFiresWaitsPiercesAndLowersToCutHeight) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  hardware::Outputs out;
  out.torch_height_target_mm = 15.0;
  Plant p;
  seq.start_on(false, out);
  EXPECT_TRUE(seq.busy());
  EXPECT_FALSE(out.torch_fire);  // not before the pierce height is reached
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 3.8);
  const auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_TRUE(out.torch_fire);
  EXPECT_TRUE(seq.lit());
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 1.5);
  EXPECT_NEAR(p.height, 1.5, 0.05);
  // Down 11.2 mm at 50 mm/s, arc after 0.1 s, pierce 0.2 s, down 2.3 mm: about 0.57 s.
  EXPECT_NEAR(t, 11.15 / 50 + 0.1 + 0.2 + 2.25 / 50, 0.01);
}

TEST(TorchSequencer, ProgrammedPierceEndsAtThePierceAndLowersOnRequest) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  hardware::Outputs out;
  Plant p;
  seq.start_on(true, out);
  auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_TRUE(seq.lit());
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 3.8);  // still at pierce height: the G4 dwell runs next
  seq.lower_to_cut_height(out);
  std::tie(s, t) = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_NEAR(p.height, 1.5, 0.05);
}

TEST(TorchSequencer, NoArcOkFailsTheStartAfterTheTimeout) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  hardware::Outputs out;
  Plant p;
  p.arc_delay = -1;
  seq.start_on(false, out);
  const auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::failed);
  EXPECT_EQ(seq.failure(), TorchSequencer::Failure::arc_start_failed);
  EXPECT_NEAR(t, 11.15 / 50 + 0.5, 0.01);
  EXPECT_FALSE(seq.lit());
}

TEST(TorchSequencer, StuckHeightAxisTimesOut) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  hardware::Outputs out;
  Plant p;
  p.speed = 0.0;
  seq.start_on(false, out);
  const auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::failed);
  EXPECT_EQ(seq.failure(), TorchSequencer::Failure::torch_height_timeout);
  EXPECT_NEAR(t, 1.0, 0.002);
  EXPECT_FALSE(out.torch_fire);  // never fired off the plate
}

TEST(TorchSequencer, OxyFuelPreheatsThenOpensTheOxygen) {
  TorchSetup ts = plasma_with_height();
  ts.kind = TorchSetup::Kind::oxy_fuel;
  ts.height_axis = false;
  ts.preheat_s = 0.3;
  TorchSequencer seq;
  seq.configure(ts, 0.001);
  hardware::Outputs out;
  Plant p;
  seq.start_on(false, out);
  EXPECT_FALSE(out.torch_fire);
  const auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_TRUE(out.torch_fire);
  EXPECT_NEAR(t, 0.3 + 0.2, 0.003);
}

TEST(TorchSequencer, OffRetractsAndKillWorksFromAnyPhase) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  hardware::Outputs out;
  Plant p;
  seq.start_on(false, out);
  run(seq, p, out);
  seq.start_off(out);
  EXPECT_FALSE(out.torch_fire);  // off in the same period
  EXPECT_FALSE(seq.lit());
  const auto [s, t] = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_NEAR(p.height, 15.0, 0.05);
  // Kill in the middle of the arc wait.
  seq.start_on(false, out);
  hardware::Inputs in;
  for (int k = 0; k < 300; ++k) {
    p.step(out, in, 0.001);
    seq.tick(in, out);
  }
  ASSERT_TRUE(out.torch_fire);
  seq.kill(out);
  EXPECT_FALSE(out.torch_fire);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 15.0);
  EXPECT_FALSE(seq.busy());
}

TEST(TorchSequencer, OffRetractsToAHigherTravelHeightWhenAsked) {
  // A rapid over parts already cut follows: the torch goes up to 40 mm, not 15, and the next
  // pierce comes down from there.
  TorchSequencer seq;
  TorchSetup t = plasma_with_height();
  t.height_timeout_s = 2.0;
  seq.configure(t, 0.001);
  hardware::Outputs out;
  Plant p;
  seq.start_on(false, out);
  run(seq, p, out);
  seq.start_off(out, 40.0);
  EXPECT_FALSE(out.torch_fire);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 40.0);
  const auto [s, up] = run(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_NEAR(p.height, 40.0, 0.05);
  EXPECT_NEAR(up, (40.0 - 1.5) / 50, 0.01);  // from cut height at 50 mm/s
  // A height below the retract height changes nothing.
  seq.start_on(false, out);
  run(seq, p, out);
  seq.start_off(out, 5.0);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 15.0);
  run(seq, p, out);
  EXPECT_NEAR(p.height, 15.0, 0.05);
}

}  // namespace
}  // namespace machplan::executor
