// The adaptive control constraint (engine/control/acc.h, on the turning model of
// models/turning/turning_process.h) against Koren's turning result: with
// Kc = 0.5 and F_r = 1500 N the feed falls from 0.5 to about 0.25 mm/rev at engagement, the
// force settles at 1500 N after every 2 mm depth step, and the feed falls with each step; the
// variable-gain law keeps its open-loop gain constant; a too-high fixed gain goes unstable.
#include <cmath>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/control/acc.h"
#include "models/turning/turning_process.h"

namespace machplan::control {
namespace {

using namespace machplan::turning;

const AccSample& at(const std::vector<AccSample>& run, double t) {
  for (const AccSample& s : run)
    if (std::abs(s.t_s - t) < 1e-6) return s;
  ADD_FAILURE() << "no sample at " << t;
  return run.front();
}

TEST(Acc, ReproducesKorensDepthSteps) {
  const TurningProcess p;
  const AccOptions o;  // Kc 0.5, F_r 1500 N, T 0.1 s, feed 0.5 mm/rev before engagement
  const auto run = simulate_acc(p, o, koren_depth_steps(), 10.0);
  EXPECT_GT(at(run, 0.9).feed_mm_per_rev, 0.45) << "the programmed feed in air";
  EXPECT_EQ(at(run, 0.9).force_n, 0.0);
  // Engagement at 2 mm: feed from 0.5 to about 0.25 mm/rev, force at 1500 N.
  EXPECT_NEAR(at(run, 3.9).feed_mm_per_rev, 0.25, 0.02);
  EXPECT_NEAR(at(run, 3.9).force_n, 1500.0, 30.0);
  // Each 2 mm step: the force returns to 1500 N, the feed is lower than before.
  double last_feed = at(run, 3.9).feed_mm_per_rev;
  for (double t : {6.9, 9.9}) {
    EXPECT_NEAR(at(run, t).force_n, 1500.0, 15.0) << t;
    EXPECT_LT(at(run, t).feed_mm_per_rev, last_feed - 0.03) << t;
    EXPECT_NEAR(at(run, t).feed_mm_per_rev, p.feed_for_force(at(run, t).depth_mm, 1500.0), 0.005) << t;
    last_feed = at(run, t).feed_mm_per_rev;
  }
  // The force jumps at each step ("a small transient") and settles within 1.5 s.
  for (double from : {4.0, 7.0}) {
    const AccStepResponse r = acc_step_response(run, 1500.0, from, from + 3.0);
    EXPECT_LT(r.settling_s, 1.5) << from;
    EXPECT_LT(r.overshoot, 0.05) << from;
  }
}

TEST(Acc, VariableGainKeepsTheOpenLoopGain) {
  const TurningProcess p;
  AccOptions fixed;
  AccOptions variable = fixed;
  variable.variable_gain = true;
  variable.open_loop_gain = 0.5;
  const AccController cf(fixed, p.beta), cv(variable, p.beta);
  // The fixed law's open-loop gain grows as the feed falls; the variable law's does not.
  EXPECT_GT(cf.open_loop_gain(0.06), 3.5 * cf.open_loop_gain(0.25));
  EXPECT_DOUBLE_EQ(cv.open_loop_gain(0.06), cv.open_loop_gain(0.25));
  // In simulation: the variable-gain settling time hardly changes with depth.
  const auto run = simulate_acc(p, variable, koren_depth_steps(), 10.0);
  const double s1 = acc_step_response(run, 1500, 4.0, 7.0).settling_s, s2 = acc_step_response(run, 1500, 7.0, 10.0).settling_s;
  EXPECT_LT(std::abs(s1 - s2), 0.25);
  EXPECT_NEAR(at(run, 9.9).force_n, 1500.0, 15.0);
}

TEST(Acc, TooHighFixedGainGoesUnstableOnDeepCuts) {
  const TurningProcess p;
  AccOptions o;
  o.kc = 4.0;
  const auto run = simulate_acc(p, o, koren_depth_steps(), 10.0);
  const AccStepResponse shallow = acc_step_response(run, 1500, 1.0, 4.0);
  const AccStepResponse deep = acc_step_response(run, 1500, 7.0, 10.0);
  EXPECT_TRUE(std::isfinite(shallow.settling_s));
  EXPECT_FALSE(std::isfinite(deep.settling_s)) << "open-loop gain " << AccController(o, p.beta).open_loop_gain(0.058);
}

TEST(Acc, RejectsBadOptions) {
  TurningProcess p;
  AccOptions o;
  o.sample_s = 0.0;
  EXPECT_THROW(simulate_acc(p, o, koren_depth_steps(), 1.0), InputError);
  o = AccOptions{};
  EXPECT_THROW(simulate_acc(p, o, {{1.0, -2.0}}, 1.0), InputError);
  EXPECT_THROW(simulate_acc(p, o, {{2.0, 1.0}, {1.0, 2.0}}, 3.0), InputError);
  p.beta = 0;
  EXPECT_THROW(simulate_acc(p, o, {}, 1.0), InputError);
}

TEST(Acc, NoiseIsDeterministicPerSeed) {
  TurningProcess p;
  p.force_noise_n = 20.0;
  const AccOptions o;
  const auto a = simulate_acc(p, o, koren_depth_steps(), 5.0, 7), b = simulate_acc(p, o, koren_depth_steps(), 5.0, 7),
             c = simulate_acc(p, o, koren_depth_steps(), 5.0, 8);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.back().measured_force_n, b.back().measured_force_n);
  EXPECT_NE(a.back().measured_force_n, c.back().measured_force_n);
}

}  // namespace
}  // namespace machplan::control
