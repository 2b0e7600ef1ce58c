// The torch sequencer alone, on hand-made inputs: each sequence's order, its waits, its
// timeouts, and kill() from any phase.
#include <gtest/gtest.h>

#include "engine/executor/torch_sequencer.h"
#include "tests/support/torch_plant.h"

namespace machplan::executor {
namespace {

using S = TorchSequencer::Tick;

using test::plasma_with_height;
// Without a plate under it: no sensor closes.
struct Plant : test::TorchPlant {
  Plant() { plate.reset(); }
};

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
  const auto [s, t] = test::run_torch(seq, p, out);
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
  auto [s, t] = test::run_torch(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_TRUE(seq.lit());
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 3.8);  // still at pierce height: the G4 dwell runs next
  seq.lower_to_cut_height(out);
  std::tie(s, t) = test::run_torch(seq, p, out);
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
  const auto [s, t] = test::run_torch(seq, p, out);
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
  const auto [s, t] = test::run_torch(seq, p, out);
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
  const auto [s, t] = test::run_torch(seq, p, out);
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
  test::run_torch(seq, p, out);
  seq.start_off(out);
  EXPECT_FALSE(out.torch_fire);  // off in the same period
  EXPECT_FALSE(seq.lit());
  const auto [s, t] = test::run_torch(seq, p, out);
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
  test::run_torch(seq, p, out);
  seq.start_off(out, 40.0);
  EXPECT_FALSE(out.torch_fire);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 40.0);
  const auto [s, up] = test::run_torch(seq, p, out);
  EXPECT_EQ(s, S::done);
  EXPECT_NEAR(p.height, 40.0, 0.05);
  EXPECT_NEAR(up, (40.0 - 1.5) / 50, 0.01);  // from cut height at 50 mm/s
  // A height below the retract height changes nothing.
  seq.start_on(false, out);
  test::run_torch(seq, p, out);
  seq.start_off(out, 5.0);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 15.0);
  test::run_torch(seq, p, out);
  EXPECT_NEAR(p.height, 15.0, 0.05);
}

// A ramp pierce: motion allowed from its motion delay on, the height going from the pierce
// height to the end height over the rest of the delay, a wait there, then cut height.
TEST(TorchSequencer, RampPierceAllowsMotionFromItsDelayAndDescendsToItsEndHeight) {
  TorchSequencer seq;
  seq.configure(plasma_with_height(), 0.001);
  motion::CutParameters m;
  m.pierce_height_mm = 6.0;
  m.pierce_delay_s = 1.0;
  m.cut_height_mm = 2.0;
  m.ramp_pierce = true;
  m.pierce_motion_delay_pct = 40;
  m.pierce_end_height_mm = 3.0;
  m.cut_height_delay_s = 0.1;
  seq.use_material(&m);
  ASSERT_EQ(seq.ramp(), &m);
  hardware::Outputs out;
  out.torch_height_target_mm = 15.0;
  Plant p;
  seq.start_on(false, out, false, 1.0);
  hardware::Inputs in;
  double arc_s = NAN, motion_s = NAN, end_s = NAN, done_s = NAN, height_at_delay_end = NAN;
  for (double t = 0; t < 5 && std::isnan(done_s); t += 0.001) {
    p.step(out, in, 0.001);
    const S s = seq.tick(in, out);
    if (std::isnan(arc_s) && in.arc_ok) arc_s = t;
    if (std::isnan(motion_s) && seq.motion_allowed()) motion_s = t;
    if (std::isnan(end_s) && seq.lit()) end_s = t, height_at_delay_end = p.height;
    if (s == S::done) done_s = t;
    ASSERT_NE(s, S::failed);
  }
  EXPECT_NEAR(motion_s - arc_s, 0.4, 0.003);
  EXPECT_NEAR(end_s - arc_s, 1.0, 0.003);
  EXPECT_NEAR(height_at_delay_end, 3.0, 0.1);  // followed the end height down
  EXPECT_GT(done_s - end_s, 0.1);              // the cut height delay, then down 1 mm
  EXPECT_NEAR(p.height, 2.0, 0.05);
  EXPECT_FALSE(seq.motion_allowed());          // the sequence is over
  // Without a moving delay (a re-pierce) the same material pierces standing.
  seq.start_off(out);
  test::run_torch(seq, p, out);
  seq.start_on(false, out);
  hardware::Inputs in2;
  bool moved = false;
  for (double t = 0; t < 5 && seq.busy(); t += 0.001) {
    p.step(out, in2, 0.001);
    seq.tick(in2, out);
    moved = moved || seq.motion_allowed();
  }
  EXPECT_FALSE(moved);
}

}  // namespace
}  // namespace machplan::executor
