// The fuzzy-logic controller (engine/control/fuzzy_controller.h): the rule surface at the set
// centres and between them, and the scaling gains.
#include <gtest/gtest.h>

#include "engine/control/fuzzy_controller.h"

namespace machplan::control {
namespace {

TEST(FuzzySurface, RuleCentresGiveTheRuleOutputs) {
  // At the centres one rule fires fully: C_{clamp(i + j)} with c = -1 -.75 -.45 0 .45 .75 1.
  EXPECT_EQ(fuzzy_surface(0, 0), 0.0);
  EXPECT_NEAR(fuzzy_surface(1.0 / 3, 0), 0.45, 1e-12);        // PS, ZE -> PS
  EXPECT_NEAR(fuzzy_surface(1.0 / 3, 1.0 / 3), 0.75, 1e-12);  // PS, PS -> PM
  EXPECT_NEAR(fuzzy_surface(2.0 / 3, -1.0 / 3), 0.45, 1e-12); // PM, NS -> PS
  EXPECT_NEAR(fuzzy_surface(2.0 / 3, 2.0 / 3), 1.0, 1e-12);   // PM, PM -> clamp(4) = PB
  EXPECT_NEAR(fuzzy_surface(-1, 1), 0.0, 1e-12);              // NB, PB -> ZE
  EXPECT_NEAR(fuzzy_surface(5, 5), 1.0, 1e-12);               // inputs are clamped to the universe
}

TEST(FuzzySurface, BetweenCentresTheWeightedAverageInterpolates) {
  // x1 half way between ZE and PS, x2 = ZE: 0.5 * 0 + 0.5 * 0.45.
  EXPECT_NEAR(fuzzy_surface(1.0 / 6, 0), 0.225, 1e-12);
  // Both half way: weights 1/4 on (ZE,ZE) (ZE,PS) (PS,ZE) (PS,PS): (0 + .45 + .45 + .75) / 4.
  EXPECT_NEAR(fuzzy_surface(1.0 / 6, 1.0 / 6), 0.4125, 1e-12);
  // Odd and monotone.
  for (double a = -1; a <= 1; a += 0.05)
    for (double b = -1; b <= 1; b += 0.05) {
      EXPECT_NEAR(fuzzy_surface(-a, -b), -fuzzy_surface(a, b), 1e-12);
      EXPECT_LE(fuzzy_surface(a, b), fuzzy_surface(a + 0.05, b) + 1e-12);
      EXPECT_LE(fuzzy_surface(a, b), fuzzy_surface(a, b + 0.05) + 1e-12);
    }
  // Steeper near zero than on average (the friction-compensating shape).
  EXPECT_GT(fuzzy_surface(0.1, 0) / 0.1, fuzzy_surface(1, 0) / 1);
}

TEST(FuzzyController, ScalingGainsAndFeedForward) {
  FuzzyGains g;
  g.ke_per_mm = 10;       // 0.1 mm is the edge of the universe
  g.kde_s_per_mm = 0.01;  // 100 mm/s of error rate is
  g.ku_mm_per_s = 200;
  g.velocity_ff = 1;
  FuzzyController c;
  c.configure({g, g}, {500, 500}, 0.001);
  ControllerInput in;
  in.r_mm = {1.0 / 30, 0};  // e = 1/30 mm: x1 = 1/3, PS; first tick de = 0
  in.v_ff_mm_per_s = {5, 0};
  ControllerOutput out;
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 5 + 200 * 0.45, 1e-9);
  EXPECT_NEAR(out.u_mm_per_s[1], 0.0, 1e-12);
  // The error grows by 1/30 mm in one period: de = 33.3 mm/s, x2 = 1/3; x1 = 2/3: PM + PS -> PB.
  in.r_mm = {2.0 / 30, 0};
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 5 + 200 * 1.0, 1e-9);
  EXPECT_FALSE(c.saturated(0));
}

TEST(FuzzyController, OptionalIntegralOfTheFuzzyOutput) {
  FuzzyGains g;
  g.ke_per_mm = 10;
  g.kde_s_per_mm = 0.01;
  g.ku_mm_per_s = 200;
  g.ki_per_s = 100;
  FuzzyController c;
  c.configure({g, g}, {120, 120}, 0.001);
  ControllerInput in;
  in.r_mm = {1.0 / 30, 0};  // fuzzy output 200 * 0.45 = 90 mm/s every tick (de = 0 after the first)
  ControllerOutput out;
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 90.0, 1e-9);
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 90.0 + 0.001 * 100 * 90, 1e-9);
  // Held at the 120 mm/s limit the integrator stops where it reached it (conditional integration).
  for (int k = 0; k < 1000; ++k) c.update(in, out);
  EXPECT_EQ(out.u_mm_per_s[0], 120.0);
  EXPECT_TRUE(c.saturated(0));
  in.r_mm = {-1.0 / 30, 0};  // the error reverses: the command leaves the limit at once
  c.update(in, out);
  c.update(in, out);
  EXPECT_LT(out.u_mm_per_s[0], 0.0);
}

}  // namespace
}  // namespace machplan::control
