// Counter decoding across the wrap, plausibility checks, and the servo law.
#include <cmath>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/control/counter_decoder.h"
#include "engine/control/servo.h"

namespace machplan::control {
namespace {

TEST(CounterDecoder, DeltaIsRightAcrossTheWrapAndThePaperFormulaIsNot) {
  // Down counter at 5 moves 7 edges forward: 5, 4, 3, 2, 1, 0, 65535, 65534.
  EXPECT_EQ(down_counter_delta(5, 65534, false, 16), 7);
  EXPECT_EQ(down_counter_delta(5, 65534, true, 16), -7);
  EXPECT_EQ(down_counter_delta(1000, 990, false, 16), 10);
  EXPECT_EQ(down_counter_delta(0, 0, false, 16), 0);
  EXPECT_EQ(paper_wrap_delta(5, 65534, false), 4);      // the paper's rule: wrong across the wrap
  EXPECT_EQ(paper_wrap_delta(1000, 990, false), 10);    // and right away from it
  EXPECT_EQ(down_counter_delta(3, 250, false, 8), 9);   // other widths too
}

TEST(CounterDecoder, UnwrapsManyWrapsBothWays) {
  CounterDecoder d;
  d.configure(0.025, 16, 10);
  std::uint32_t c = 7;
  d.reset(c, 100.0);
  std::int64_t truth = 0;
  // 200000 counts forward in steps of 3 (three wraps), then back 250000 in steps of 5.
  for (int i = 0; i < 200000 / 3; ++i) {
    c = (c - 3) & 0xFFFF;
    truth += 3;
    ASSERT_EQ(d.update(c, false), CounterDecoder::Verdict::ok);
  }
  for (int i = 0; i < 50000; ++i) {
    c = (c - 5) & 0xFFFF;  // a down counter counts down in both directions
    truth -= 5;
    ASSERT_EQ(d.update(c, true), CounterDecoder::Verdict::ok);
  }
  EXPECT_EQ(d.counts(), truth);
  EXPECT_NEAR(d.position_mm(), 100.0 + (truth + 0.5) * 0.025, 1e-9);  // the middle of the count
}

TEST(CounterDecoder, RefusesImpossibleJumpsAndKeepsTheLastPosition) {
  CounterDecoder d;
  d.configure(0.025, 16, 7);
  d.reset(30000, 0.0);
  ASSERT_EQ(d.update(29996, false), CounterDecoder::Verdict::ok);
  const double before = d.position_mm();
  EXPECT_EQ(d.update(29996 - 100, false), CounterDecoder::Verdict::implausible_jump);
  EXPECT_EQ(d.last_jump_counts(), 100);
  EXPECT_EQ(d.position_mm(), before);
  // A high byte read one off: 256 counts away (plus a real move of 2).
  EXPECT_EQ(d.update(29996 - 2 - 256, false), CounterDecoder::Verdict::byte_carry_misread);
  EXPECT_EQ(d.update(29996 - 2 + 256, true), CounterDecoder::Verdict::byte_carry_misread);
  EXPECT_EQ(d.position_mm(), before);
  EXPECT_EQ(d.update(29994, false), CounterDecoder::Verdict::ok);  // the true reading is still accepted
}

TEST(ServoLaw, FeedForwardPlusPidMatchesTheEquation) {
  ServoGains g;
  g.kp_per_s = 50;
  g.ki_per_s2 = 200;
  g.kd = 0.5;
  g.velocity_ff = 1.2;
  g.acceleration_ff_s = 0.01;
  AxisServo s;
  s.configure(g, 1000.0, 0.001);
  const double u1 = s.update(1.0, 10.0, 100.0, 0.9);  // e = 0.1, first tick: no derivative
  EXPECT_NEAR(u1, 1.2 * (10 + 0.01 * 100) + 50 * 0.1, 1e-12);
  const double u2 = s.update(1.0, 10.0, 100.0, 0.95);  // e = 0.05, I = 200 * 0.001 * 0.1
  EXPECT_NEAR(u2, 1.2 * 11 + 50 * 0.05 + 200 * 0.001 * 0.1 + 0.5 * (0.05 - 0.1) / 0.001, 1e-9);
}

TEST(ServoLaw, SaturatesAndDoesNotWindUp) {
  ServoGains g;
  g.kp_per_s = 10;
  g.ki_per_s2 = 1000;
  AxisServo s;
  s.configure(g, 50.0, 0.001);
  for (int i = 0; i < 5000; ++i) EXPECT_LE(std::abs(s.update(100.0, 0, 0, 0.0)), 50.0);
  // Pushing into the limit froze the integral: it never grew while saturated.
  EXPECT_EQ(s.integral_mm_per_s(), 0.0);
  EXPECT_TRUE(s.following_error_exceeded());
}

// A first-order drive with gain 0.7 and a P + adaptive FF loop: theta learns 1/0.7.
TEST(ServoLaw, AdaptiveFeedForwardLearnsTheDriveGain) {
  ServoGains g;
  g.kp_per_s = 60;
  g.ki_per_s2 = 0;
  g.velocity_ff = 1.0;
  g.ff_adaptation_per_s2 = 900;
  AxisServo s;
  const double T = 0.001, tau = 0.01, gain = 0.7;
  s.configure(g, 1000.0, T);
  double x = 0, v = 0;
  for (int k = 0; k < 3000; ++k) {
    const double r = 50.0 * k * T, vr = 50.0;
    const double u = s.update(r, vr, 0.0, x);
    v += (gain * u - v) / tau * T;
    x += v * T;
  }
  EXPECT_NEAR(s.feed_forward_gain(), 1 / 0.7, 0.01);
  EXPECT_LT(std::abs(s.last_error_mm()), 0.01);
  // Without adaptation the same loop lags by about 0.3 v / (0.7 Kp).
  g.ff_adaptation_per_s2 = 0;
  s.configure(g, 1000.0, T);
  x = v = 0;
  for (int k = 0; k < 3000; ++k) {
    const double u = s.update(50.0 * k * T, 50.0, 0.0, x);
    v += (gain * u - v) / tau * T;
    x += v * T;
  }
  EXPECT_NEAR(s.last_error_mm(), 0.3 * 50 / (0.7 * 60), 0.02);
}

TEST(ServoLaw, BacklashCompensationAddsTheGapOnReversal) {
  ServoGains g;
  g.kp_per_s = 0;
  g.velocity_ff = 1.0;
  g.backlash_compensation_mm = 0.05;
  g.backlash_compensation_time_s = 0.005;
  AxisServo s;
  s.configure(g, 1000.0, 0.001);
  double extra = 0;
  for (int i = 0; i < 10; ++i) extra += (s.update(0, 5.0, 0, 0) - 5.0) * 0.001;
  EXPECT_NEAR(extra, 0.0, 1e-12);  // first motion: no pulse
  for (int i = 0; i < 20; ++i) extra += (s.update(0, -5.0, 0, 0) + 5.0) * 0.001;
  EXPECT_NEAR(extra, -0.05, 1e-9);  // reversal: exactly the gap, in the new direction
}

TEST(ServoGains, ValidateNamesTheField) {
  ServoGains g;
  g.following_error_limit_mm = 0;
  try {
    g.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("following_error_limit_mm: 0 must be > 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace machplan::control
