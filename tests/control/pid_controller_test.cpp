// The axial P / PID law (engine/control/pid_controller.h) on hand-computed cases.
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/control/pid_controller.h"

namespace machplan::control {
namespace {

constexpr double T = 0.001;

TEST(AxialPid, ProportionalAndFeedForwardTerms) {
  PidGains g;
  g.kp_per_s = 100;
  g.velocity_ff = 0.5;
  g.acceleration_ff_s = 0.004;
  AxialPid a;
  a.configure(g, 500, T);
  // 100 * (2.0 - 1.9) + 0.5 * 20 + 0.004 * 1000 = 10 + 10 + 4
  EXPECT_NEAR(a.update(2.0, 20, 1000, 1.9), 24.0, 1e-12);
  EXPECT_NEAR(a.last_error_mm(), 0.1, 1e-15);
  EXPECT_FALSE(a.saturated());
  EXPECT_DOUBLE_EQ(a.integral_mm_per_s(), 0.0);  // Ki = 0: no integral at all
}

TEST(AxialPid, FrictionFeedForwardFollowsTheReferenceDirectionWithARamp) {
  PidGains g;
  g.kp_per_s = 0;
  g.friction_ff_mm_per_s = 2;
  g.friction_ff_band_mm_per_s = 0.5;
  AxialPid a;
  a.configure(g, 500, T);
  EXPECT_NEAR(a.update(0, 10, 0, 0), 2.0, 1e-12);
  EXPECT_NEAR(a.update(0, -0.25, 0, 0), -1.0, 1e-12);  // half way into the band
  EXPECT_EQ(a.update(0, 0, 0, 0), 0.0);                // at rest: nothing
}

TEST(AxialPid, IntegralAccumulatesTKiE) {
  PidGains g;
  g.kp_per_s = 10;
  g.ki_per_s2 = 2000;
  AxialPid a;
  a.configure(g, 500, T);
  // e = 0.5 each tick: u0 = 5, I1 = 0.001 * 2000 * 0.5 = 1; u1 = 5 + 1; u2 = 5 + 2.
  EXPECT_NEAR(a.update(0.5, 0, 0, 0), 5.0, 1e-12);
  EXPECT_NEAR(a.update(0.5, 0, 0, 0), 6.0, 1e-12);
  EXPECT_NEAR(a.update(0.5, 0, 0, 0), 7.0, 1e-12);
}

TEST(AxialPid, FilteredDerivativeOfTheError) {
  PidGains g;
  g.kp_per_s = 0;
  g.kd = 2;
  g.derivative_filter_s = 0.003;
  AxialPid a;
  a.configure(g, 500, T);
  EXPECT_EQ(a.update(0, 0, 0, 0), 0.0);  // the first tick has no previous error
  // e jumps by 1: D = (0.003 * 0 + 2 * 1) / (0.003 + 0.001) = 500
  EXPECT_NEAR(a.update(1, 0, 0, 0), 500.0, 1e-9);
  // e stays: D decays by Tf / (Tf + T) = 0.75
  EXPECT_NEAR(a.update(1, 0, 0, 0), 375.0, 1e-9);
}

TEST(AxialPid, BackCalculationPullsTheIntegratorBackWhileSaturated) {
  PidGains g;
  g.kp_per_s = 100;
  g.ki_per_s2 = 1000;
  g.tracking_time_s = 0.01;
  AxialPid a;
  a.configure(g, 50, T);
  // e = 1: v = 100, u = 50, I += 0.001 * (1000 * 1 + (50 - 100) / 0.01) = 1 - 5 = -4.
  EXPECT_EQ(a.update(1, 0, 0, 0), 50.0);
  EXPECT_TRUE(a.saturated());
  EXPECT_NEAR(a.integral_mm_per_s(), -4.0, 1e-12);
  // Held in saturation the integrator settles where 1000 e = (v - u) / Tt, i.e. v - u = 10,
  // I = -40 (v = 60); conditional integration would have frozen it at 0 and a plain one
  // would grow without end.
  for (int k = 0; k < 5000; ++k) a.update(1, 0, 0, 0);
  EXPECT_NEAR(a.integral_mm_per_s(), -40.0, 1e-6);
  // As soon as the error falls below what the limit can hold the command leaves the limit.
  EXPECT_LT(a.update(0.1, 0, 0, 0), 50.0);
}

TEST(AxialPid, DefaultTrackingTimeIsKpOverKi) {
  PidGains g;
  g.kp_per_s = 100;
  g.ki_per_s2 = 1000;  // Tt = 0.1 s
  AxialPid a;
  a.configure(g, 50, T);
  a.update(1, 0, 0, 0);
  EXPECT_NEAR(a.integral_mm_per_s(), 0.001 * (1000 - 50 / 0.1), 1e-12);
}

TEST(PidGains, ValidateNamesTheField) {
  PidGains g;
  g.kd = -1;
  try {
    g.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "kd");
    EXPECT_NE(std::string(e.what()).find("kd: -1 must be finite and >= 0"), std::string::npos) << e.what();
  }
}

TEST(AxialPid, BacklashFeedForwardCrossesTheGapAtAReversalOnly) {
  PidGains g;
  g.kp_per_s = 0;
  g.backlash_ff_mm = 0.004;
  g.friction_ff_band_mm_per_s = 0.5;
  AxialPid a;
  a.configure(g, 500, T);
  // Motor travel added by the feed-forward, mm: the sum of its speed over the periods.
  const auto travel = [&](std::initializer_list<double> v_refs) {
    double s = 0;
    for (double v : v_refs) s += a.update(0, v, 0, 0) * T;
    return s;
  };
  EXPECT_NEAR(travel({0.0, 0.25, 1.0, 5.0}), 0.002, 1e-12);   // first start: from mid-gap, b/2
  EXPECT_NEAR(travel({1.0, 0.1, 0.0, 0.0, 2.0}), 0.0, 1e-12);  // stop and go on: nothing
  EXPECT_NEAR(travel({0.2, -0.1, -0.3, -3.0}), -0.004, 1e-12); // reversal: the whole gap, b
  EXPECT_NEAR(travel({-1.0, 0.0, 4.0}), 0.004, 1e-12);         // and back
}

}  // namespace
}  // namespace machplan::control
