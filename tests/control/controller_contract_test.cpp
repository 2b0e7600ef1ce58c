// The controller contract (engine/control/controller.h), one suite run against every
// implementation. A new controller is one more entry in kControllers.
#include <functional>
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "engine/control/controller.h"
#include "engine/control/controller_factory.h"
#include "engine/control/pid_ff_controller.h"

namespace machplan::control {
namespace {

constexpr double kLimit = 120.0;  // mm/s
constexpr double kPeriod = 0.001;

std::array<ServoGains, kAxes> gains() {
  ServoGains g;
  g.kp_per_s = 90;
  g.ki_per_s2 = 40;
  g.acceleration_ff_s = 0.012;
  g.ff_adaptation_per_s2 = 900;
  g.following_error_limit_mm = 2.0;
  return {g, g};
}

// The factory's plant with the suite's gains and limit (drive: tau 4 ms, gain 1, one tick of
// latency each way).
ControllerPlant plant() {
  ControllerPlant p;
  p.servo = gains();
  p.output_limit_mm_per_s = {kLimit, kLimit};
  p.drive_time_constant_s = {0.004, 0.004};
  p.command_latency_ticks = p.reading_latency_ticks = {1, 1};
  p.position_quantum_mm = {0.002, 0.002};
  p.coulomb_friction_mm_per_s = {2.0, 2.0};
  p.backlash_mm = {0.002, 0.002};
  p.period_s = kPeriod;
  return p;
}

// The axial loops' optional parts on: friction and backlash feed-forward, the position observer
// (which then acts on its prediction where the input previews far enough).
const Gains kObserved{{"velocity_ff", 1.0}, {"friction_ff_mm_per_s", 2.0}, {"backlash_ff_mm", 0.002}, {"observer_per_s", 150.0}};

struct Entry {
  const char* name;
  std::function<std::unique_ptr<Controller>()> make;
};

const Entry kControllers[] = {
    {"pid_ff",
     [] {
       auto c = std::make_unique<PidFfController>();
       c->configure(gains(), {kLimit, kLimit}, kPeriod);
       return c;
     }},
    {"p", [] { return make_controller("p", {}, plant()); }},
    {"pid", [] { return make_controller("pid", {{"kd", 0.5}, {"velocity_ff", 1.0}}, plant()); }},
    {"zpetc", [] { return make_controller("zpetc", {}, plant()); }},
    {"ccc", [] { return make_controller("ccc", {{"ccc_ki_per_s2", 500.0}, {"velocity_ff", 1.0}}, plant()); }},
    {"flc", [] { return make_controller("flc", {{"velocity_ff", 1.0}}, plant()); }},
    {"p_observed", [] { return make_controller("p", kObserved, plant()); }},
    {"ccc_observed",
     [] {
       Gains g = kObserved;
       g["ccc_ki_per_s2"] = 500.0;
       return make_controller("ccc", g, plant());
     }},
};

// A deterministic stream of inputs: a circle with noise on the measurement.
std::vector<ControllerInput> inputs(int n) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<ControllerInput> v(n);
  for (int k = 0; k < n; ++k) {
    const double t = k * kPeriod, w = 1.6;
    v[k].r_mm = {50 * std::cos(w * t), 50 * std::sin(w * t)};
    v[k].v_ff_mm_per_s = {-50 * w * std::sin(w * t), 50 * w * std::cos(w * t)};
    v[k].a_ff_mm_per_s2 = {-50 * w * w * std::cos(w * t), -50 * w * w * std::sin(w * t)};
    v[k].y_mm = {v[k].r_mm[0] - 0.1 + noise(rng), v[k].r_mm[1] + noise(rng)};
  }
  return v;
}

class ControllerContract : public ::testing::TestWithParam<Entry> {};

TEST_P(ControllerContract, ResetRepeatsTheSameCommandsExactly) {
  auto c = GetParam().make();
  const auto in = inputs(3000);
  std::vector<ControllerOutput> first(in.size()), second(in.size());
  c->reset();
  for (std::size_t k = 0; k < in.size(); ++k) c->update(in[k], first[k]);
  c->reset();
  for (std::size_t k = 0; k < in.size(); ++k) c->update(in[k], second[k]);
  for (std::size_t k = 0; k < in.size(); ++k) ASSERT_EQ(first[k].u_mm_per_s, second[k].u_mm_per_s) << k;
}

TEST_P(ControllerContract, CommandsStayInTheDriveRangeAndSaturationIsReported) {
  auto c = GetParam().make();
  c->reset();
  ControllerInput far;
  far.r_mm = {1000, -1000};  // a huge error
  ControllerOutput out;
  for (int k = 0; k < 100; ++k) {
    c->update(far, out);
    for (int i = 0; i < kAxes; ++i) ASSERT_LE(std::abs(out.u_mm_per_s[i]), kLimit);
  }
  EXPECT_TRUE(c->saturated(0));
  EXPECT_TRUE(c->saturated(1));
  EXPECT_TRUE(c->following_error_exceeded(0));
  // r - y, y the measured position (or the observer's estimate, within half a count of it)
  EXPECT_NEAR(c->following_error_mm(0), 1000.0, 0.001);
  EXPECT_NEAR(c->following_error_mm(1), -1000.0, 0.001);
}

TEST_P(ControllerContract, AtRestOnTargetCommandsNothing) {
  auto c = GetParam().make();
  c->reset();
  ControllerInput still;
  still.r_mm = still.y_mm = {10, 20};
  ControllerOutput out;
  for (int k = 0; k < 100; ++k) c->update(still, out);
  EXPECT_EQ(out.u_mm_per_s[0], 0.0);
  EXPECT_EQ(out.u_mm_per_s[1], 0.0);
  EXPECT_FALSE(c->saturated(0));
  EXPECT_FALSE(c->following_error_exceeded(1));
}

TEST_P(ControllerContract, ErrorIsCorrectedInItsOwnDirection) {
  auto c = GetParam().make();
  c->reset();
  ControllerInput in;
  in.r_mm = {0.5, -0.5};
  ControllerOutput out;
  c->update(in, out);
  EXPECT_GT(out.u_mm_per_s[0], 0.0);
  EXPECT_LT(out.u_mm_per_s[1], 0.0);
}

INSTANTIATE_TEST_SUITE_P(Every, ControllerContract, ::testing::ValuesIn(kControllers),
                         [](const auto& info) { return std::string(info.param.name); });

// The first implementation is exactly the per-axis servo the executor ran before.
TEST(PidFfController, GivesTheAxisServosNumbers) {
  PidFfController c;
  c.configure(gains(), {kLimit, kLimit}, kPeriod);
  c.reset();
  std::array<AxisServo, kAxes> axes;
  for (int i = 0; i < kAxes; ++i) axes[i].configure(gains()[i], kLimit, kPeriod);
  ControllerOutput out;
  for (const ControllerInput& in : inputs(5000)) {
    c.update(in, out);
    for (int i = 0; i < kAxes; ++i)
      ASSERT_EQ(out.u_mm_per_s[i], axes[i].update(in.r_mm[i], in.v_ff_mm_per_s[i], in.a_ff_mm_per_s2[i], in.y_mm[i]));
  }
  EXPECT_EQ(c.axis(0).feed_forward_gain(), axes[0].feed_forward_gain());
}

}  // namespace
}  // namespace machplan::control
