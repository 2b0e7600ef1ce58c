// The axis plant: each effect in isolation, and determinism from the seed.
#include <cmath>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "models/axis/plant.h"

namespace machplan::axis {
namespace {

// An ideal axis: every effect off, fine DAC, 1 um encoder.
AxisPlantParams ideal() {
  AxisPlantParams p;
  p.motor_max_rpm = 6000;
  p.gear_ratio = 120;
  p.mm_per_rev = 98.175;
  p.dac_full_scale_rpm = 6000;
  p.dac_bits = 24;
  p.velocity_loop_time_constant_s = 0.01;
  p.encoder_lines_per_rev = 100000;
  p.encoder_mm_per_rev = 400;
  p.decoding = 4;
  p.counter_bits = 32;
  return p;
}

std::int32_t code_for(const AxisPlantParams& p, double mm_per_s) {
  return static_cast<std::int32_t>(std::lround(mm_per_s / p.dac_full_scale_mm_per_s() * (p.dac_max_code() + 1)));
}

void run(AxisPlant& a, std::int32_t code, int ticks, std::mt19937_64& rng) {
  for (int i = 0; i < ticks; ++i) a.step(code, true, 1e-3, rng);
}

TEST(AxisPlant, FirstOrderDriveReachesGainTimesCommand) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.gain_factor = 0.7;
  AxisPlant a(p);
  run(a, code_for(p, 40.0), 10, rng);  // one time constant
  EXPECT_NEAR(a.velocity_mm_per_s(), 0.7 * 40 * (1 - std::exp(-1.0)), 0.2);
  run(a, code_for(p, 40.0), 200, rng);
  EXPECT_NEAR(a.velocity_mm_per_s(), 0.7 * 40, 1e-3);
  // Saturation at the motor's top speed even when the DAC asks for more.
  p.dac_full_scale_rpm = 12000;
  p.gain_factor = 1.0;
  AxisPlant b(p);
  run(b, p.dac_max_code(), 300, rng);
  EXPECT_NEAR(b.velocity_mm_per_s(), p.max_speed_mm_per_s(), 1e-6);
}

TEST(AxisPlant, CoulombFrictionMakesADeadZoneAndADroop) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.coulomb_friction_mm_per_s = 1.0;
  p.viscous_friction_ratio = 0.1;
  AxisPlant a(p);
  run(a, code_for(p, 0.9), 500, rng);
  EXPECT_EQ(a.velocity_mm_per_s(), 0.0);  // below the breakaway
  EXPECT_EQ(a.load_position_mm(), 0.0);
  run(a, code_for(p, 21.0), 500, rng);
  EXPECT_NEAR(a.velocity_mm_per_s(), (21.0 - 1.0) / 1.1, 1e-3);
  run(a, 0, 500, rng);  // friction stops it, and it stays stopped
  EXPECT_EQ(a.velocity_mm_per_s(), 0.0);
}

TEST(AxisPlant, BacklashDelaysTheLoadOnReversal) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.backlash_mm = 0.2;
  AxisPlant a(p);
  run(a, code_for(p, 10), 200, rng);
  EXPECT_NEAR(a.motor_position_mm() - a.load_position_mm(), 0.1, 1e-9);  // pushing on one flank
  const double load_at_reversal = a.load_position_mm();
  run(a, code_for(p, -10), 20, rng);  // the motor turns back but is still inside the gap
  EXPECT_GT(a.motor_position_mm(), load_at_reversal - 0.1);
  EXPECT_GE(a.load_position_mm(), load_at_reversal - 1e-12);
  run(a, code_for(p, -10), 200, rng);
  EXPECT_NEAR(a.load_position_mm() - a.motor_position_mm(), 0.1, 1e-9);
}

TEST(AxisPlant, DownCounterCountsEveryEdgeAndWraps) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.encoder_lines_per_rev = 1500;
  p.encoder_mm_per_rev = 149.285;
  p.decoding = 1;
  p.counter_bits = 16;
  AxisPlant a(p, 0.0, 5);
  run(a, code_for(p, 50), 40, rng);
  const double q = 149.285 / 1500;
  const auto edges = static_cast<std::uint32_t>(std::floor(a.load_position_mm() / q));
  ASSERT_GT(edges, 5u);  // the counter went through zero
  CounterReading r = a.read();
  EXPECT_EQ(r.value, (5u + 65536u - edges) & 0xFFFFu);
  EXPECT_FALSE(r.direction_negative);
  run(a, code_for(p, -50), 100, rng);
  EXPECT_TRUE(a.read().direction_negative);
}

TEST(AxisPlant, LatencyDelaysCommandAndReading) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.command_latency_ticks = 3;
  p.reading_latency_ticks = 2;
  AxisPlant a(p);
  a.step(code_for(p, 50), true, 1e-3, rng);
  a.step(0, true, 1e-3, rng);
  a.step(0, true, 1e-3, rng);
  EXPECT_EQ(a.velocity_mm_per_s(), 0.0);  // the command is still in the pipe
  a.step(0, true, 1e-3, rng);
  EXPECT_GT(a.velocity_mm_per_s(), 0.0);  // it arrived at the 4th tick
  // Reading: after the axis stops moving the reading keeps changing for 2 ticks.
  AxisPlant b(p);
  const std::uint32_t start = b.read().value;
  b.step(code_for(p, 50), true, 1e-3, rng);
  for (int i = 0; i < 3; ++i) b.step(0, true, 1e-3, rng);
  const std::uint32_t first_move_tick = b.read().value;  // counts from tick 4 are not visible yet
  EXPECT_EQ(first_move_tick, start);
  b.step(0, true, 1e-3, rng);
  b.step(0, true, 1e-3, rng);
  EXPECT_NE(b.read().value, start);
}

TEST(AxisPlant, StartShockOnlyWithoutAZeroFirstCommand) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.start_shock_mm_per_s = 15;
  AxisPlant a(p);
  a.step(code_for(p, 5), true, 1e-3, rng);
  EXPECT_EQ(a.shock_count(), 1);
  EXPECT_GT(a.velocity_mm_per_s(), 10.0);  // the jolt, far above the 5 mm/s asked
  AxisPlant b(p);
  b.step(0, true, 1e-3, rng);  // the paper's cure: a zero speed first
  run(b, code_for(p, 5), 50, rng);
  EXPECT_EQ(b.shock_count(), 0);
  EXPECT_LT(b.velocity_mm_per_s(), 5.0 + 1e-9);
  b.step(0, false, 1e-3, rng);  // disabling re-arms the latch
  b.step(code_for(p, 5), true, 1e-3, rng);
  EXPECT_EQ(b.shock_count(), 1);
}

TEST(AxisPlant, DacQuantisesTheCommand) {
  std::mt19937_64 rng(1);
  AxisPlantParams p = ideal();
  p.dac_bits = 8;  // 128 steps of 0.64 mm/s
  AxisPlant a(p);
  run(a, 3, 500, rng);
  EXPECT_NEAR(a.velocity_mm_per_s(), 3.0 / 128 * p.dac_full_scale_mm_per_s(), 1e-6);
}

TEST(AxisPlant, SameSeedSameRunOtherSeedOtherRun) {
  AxisPlantParams p = ideal();
  p.speed_noise_mm_per_s = 0.5;
  auto final_position = [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    AxisPlant a(p);
    run(a, code_for(p, 20), 300, rng);
    return a.load_position_mm();
  };
  EXPECT_EQ(final_position(7), final_position(7));
  EXPECT_NE(final_position(7), final_position(8));
}

TEST(AxisPlant, GaussianHasUnitMomentsAndUniformStaysInRange) {
  std::mt19937_64 rng(42);
  double s = 0, s2 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double g = gaussian(rng);
    s += g;
    s2 += g * g;
    const double u = uniform01(rng);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.02);
}

TEST(AxisPlant, ValidateNamesTheField) {
  AxisPlantParams p = ideal();
  p.decoding = 3;
  try {
    p.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("decoding: 3 must be 1, 2 or 4"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace machplan::axis
