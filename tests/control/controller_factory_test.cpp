// Controllers by name (engine/control/controller_factory.h): kinds, gain specs, defaults and
// the refusals the CLI and the tuner rely on.
#include <algorithm>
#include <functional>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/control/controller_factory.h"
#include "engine/control/pid_ff_controller.h"
#include "models/cutting/controller_plant.h"

namespace machplan::control {
namespace {

ControllerPlant factory_plant() {
  ControllerPlant p;
  for (int i = 0; i < kAxes; ++i) {
    p.servo[i].kp_per_s = 150;
    p.servo[i].ki_per_s2 = 3000;
    p.servo[i].acceleration_ff_s = 0.004;
    p.output_limit_mm_per_s[i] = 1200;
    p.drive_time_constant_s[i] = 0.004;
    p.command_latency_ticks[i] = p.reading_latency_ticks[i] = 1;
  }
  p.servo[1].kp_per_s = 120;  // a per-axis default
  return p;
}

std::string input_error_where(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.where() + ": " + e.message();
  }
  return "no error";
}

TEST(ControllerFactory, EveryKindBuildsWithItsDefaultsAndNamesItself) {
  const std::vector<std::string> kinds = controller_kinds();
  for (const char* k : {"p", "pid", "pid_ff"}) EXPECT_NE(std::find(kinds.begin(), kinds.end(), k), kinds.end()) << k;
  for (const std::string& k : kinds) {
    auto c = make_controller(k, {}, factory_plant());
    ASSERT_TRUE(c) << k;
    EXPECT_EQ(std::string(c->name()), k);
    for (const GainSpec& s : gain_specs(k, factory_plant())) {
      EXPECT_LE(s.min_value, s.default_value) << k << " " << s.name;
      EXPECT_LE(s.default_value, s.max_value) << k << " " << s.name;
      EXPECT_LT(s.min_value, s.max_value) << k << " " << s.name;
      if (s.log_scale) { EXPECT_GT(s.min_value, 0.0) << k << " " << s.name; }
      EXPECT_FALSE(s.description.empty()) << k << " " << s.name;
    }
  }
}

TEST(ControllerFactory, PIsKpTimesTheErrorWithOptionalFeedForward) {
  auto c = make_controller("p", {{"kp_per_s", 100.0}}, factory_plant());
  ControllerInput in;
  in.r_mm = {1.0, 2.0};
  in.y_mm = {0.9, 2.05};
  in.v_ff_mm_per_s = {30, 40};
  ControllerOutput out;
  c->update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 10.0, 1e-12);  // no feed-forward unless asked for
  EXPECT_NEAR(out.u_mm_per_s[1], -5.0, 1e-12);  // the given kp applies to both axes
  auto ff = make_controller("p", {{"kp_per_s", 100.0}, {"velocity_ff", 1.0}}, factory_plant());
  ff->update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 40.0, 1e-12);
}

TEST(ControllerFactory, MissingGainsTakeEachAxisServoSection) {
  auto c = make_controller("p", {}, factory_plant());
  ControllerInput in;
  in.r_mm = {0.1, 0.1};
  ControllerOutput out;
  c->update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], 15.0, 1e-12);
  EXPECT_NEAR(out.u_mm_per_s[1], 12.0, 1e-12);
}

TEST(ControllerFactory, PidFfWithDefaultsIsTheExecutorsServo) {
  const ControllerPlant p = factory_plant();
  auto c = make_controller("pid_ff", {}, p);
  PidFfController ref;
  ref.configure(p.servo, p.output_limit_mm_per_s, p.period_s);
  ref.reset();
  ControllerInput in;
  ControllerOutput a, b;
  for (int k = 0; k < 200; ++k) {
    in.r_mm = {0.01 * k, -0.02 * k};
    in.v_ff_mm_per_s = {10, -20};
    in.y_mm = {0.01 * k - 0.003, -0.02 * k + 0.001 * (k % 3)};
    c->update(in, a);
    ref.update(in, b);
    ASSERT_EQ(a.u_mm_per_s, b.u_mm_per_s) << k;
  }
}

TEST(ControllerFactory, RefusesUnknownKindsGainsAndValuesOutsideTheBox) {
  EXPECT_NE(input_error_where([] { make_controller("pd", {}, factory_plant()); }).find("controller: unknown controller 'pd'"),
            std::string::npos);
  EXPECT_EQ(input_error_where([] { gain_specs("nope", factory_plant()); }).rfind("controller: ", 0), 0u);
  const std::string unknown = input_error_where([] { make_controller("p", {{"ki_per_s2", 5.0}}, factory_plant()); });
  EXPECT_NE(unknown.find("gains: controller 'p' has no gain 'ki_per_s2'"), std::string::npos) << unknown;
  const std::string box = input_error_where([] { make_controller("pid", {{"kp_per_s", 1e7}}, factory_plant()); });
  EXPECT_NE(box.find("kp_per_s = 10000000 is outside"), std::string::npos) << box;
  EXPECT_EQ(input_error_where([] { make_controller("pid", {{"kd", std::nan("")}}, factory_plant()); }).rfind("gains: ", 0), 0u);
  ControllerPlant bad = factory_plant();
  bad.output_limit_mm_per_s[1] = 0;
  EXPECT_NE(input_error_where([&] { make_controller("p", {}, bad); }).find("output_limit_mm_per_s[1]"),
            std::string::npos);
}

TEST(ControllerFactory, ZpetcNeedsTheDriveTimeConstant) {
  ControllerPlant p = factory_plant();
  p.drive_time_constant_s = {0, 0};  // what plant_from_setup leaves: unknown
  EXPECT_NE(input_error_where([&] { make_controller("zpetc", {}, p); }).find("set model_time_constant_s"),
            std::string::npos);
  EXPECT_NO_THROW(make_controller("zpetc", {{"model_time_constant_s", 0.004}}, p));
}

TEST(ControllerFactory, ParsesGainFlags) {
  Gains g;
  parse_gain("kp_per_s=120", g);
  parse_gain("kd=1e-2", g);
  EXPECT_DOUBLE_EQ(g.at("kp_per_s"), 120.0);
  EXPECT_DOUBLE_EQ(g.at("kd"), 0.01);
  for (const char* bad : {"kp_per_s", "=3", "kp=", "kp=abc", "kp=1x", "kp=inf"})
    EXPECT_EQ(input_error_where([&] { parse_gain(bad, g); }).rfind("gains: ", 0), 0u) << bad;
  EXPECT_NE(input_error_where([&] { parse_gain("kd=3", g); }).find("given twice"), std::string::npos);
}

TEST(ControllerFactory, PlantFromTheBundledMachineFile) {
  const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("xy_table"));
  const ControllerPlant p = cutting::controller_plant(m);
  EXPECT_DOUBLE_EQ(p.period_s, 0.001);
  EXPECT_DOUBLE_EQ(p.drive_time_constant_s[0], 0.004);
  EXPECT_DOUBLE_EQ(p.gain_factor[1], 1.0);
  EXPECT_DOUBLE_EQ(p.servo[0].kp_per_s, 150.0);
  EXPECT_EQ(p.command_latency_ticks[0], 1);
  EXPECT_NEAR(p.output_limit_mm_per_s[0], 1200.0, 1e-9);
}

}  // namespace
}  // namespace machplan::control
