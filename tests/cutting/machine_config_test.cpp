// Machine files: the bundled ones load with the paper's numbers; bad files are refused with
// FILE:LINE and the key.
#include <algorithm>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "models/cutting/machine_config.h"
#include "tests/support/temp_dir.h"

namespace machplan::cutting {
namespace {

std::string bundled(const std::string& name) {
  return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/" + name + ".yaml";
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(MachineConfig, GantryCarriesThePaperNumbers) {
  const MachineConfig m = load_machine(bundled("thermal_gantry"));
  EXPECT_EQ(m.name, "thermal_gantry");
  for (const AxisConfig& a : m.axes) {
    EXPECT_EQ(a.travel_mm, 2800);
    EXPECT_NEAR(a.plant.max_speed_mm_per_s(), 81.8, 0.05);       // 6000 rpm / 120 * 98.175 mm
    EXPECT_NEAR(a.plant.mm_per_count() * 4, 0.0995, 0.0001);       // 149.285 / 1500 per line
    EXPECT_EQ(a.plant.decoding, 4);
    EXPECT_EQ(a.plant.counter_bits, 16);
    EXPECT_EQ(a.plant.dac_bits, 12);
    EXPECT_DOUBLE_EQ(a.plant.gain_factor, 0.7);
    // The 70 % drive must still reach the motor's top speed from the DAC's full scale.
    EXPECT_GE(a.plant.gain_factor * a.plant.dac_full_scale_mm_per_s(), a.plant.max_speed_mm_per_s());
  }
  EXPECT_NEAR(m.limits.velocity_mm_per_s, 80.0, 1e-9);  // under the drives' 81.8 mm/s top
  EXPECT_EQ(m.limits.acceleration_mm_per_s2, 500);
  EXPECT_EQ(m.limits.jerk_mm_per_s3, 20000);
  EXPECT_EQ(m.torch.kind, executor::TorchSetup::Kind::plasma);
  EXPECT_TRUE(m.torch.has_oxy_fuel);
  EXPECT_TRUE(m.torch_height.fitted);
  EXPECT_EQ(m.torch_height.travel_height_over_cut_mm, 40.0);
  EXPECT_GE(m.torch_height.travel_height_over_cut_mm, m.torch_height.retract_height_mm);
  const executor::MachineSetup s = m.setup();
  EXPECT_NO_THROW(s.validate());
  EXPECT_NEAR(s.signals[0].dac_full_scale_mm_per_s, 9000.0 / 60 / 120 * 98.175, 1e-9);
}

TEST(MachineConfig, XyTableCarriesThePaperNumbers) {
  const MachineConfig m = load_machine(bundled("xy_table"));
  EXPECT_EQ(m.axes[0].travel_mm, 400);
  EXPECT_EQ(m.axes[1].travel_mm, 350);
  EXPECT_NEAR(m.axes[0].plant.max_speed_mm_per_s(), 1200, 1e-9);
  EXPECT_EQ(m.axes[0].plant.mm_per_rev, 20);
  EXPECT_EQ(m.limits.acceleration_mm_per_s2, 5000);
  EXPECT_EQ(m.limits.jerk_mm_per_s3, 200000);
  // The hybrid paper's milling table: a spindle, no torch.
  EXPECT_EQ(m.torch.kind, executor::TorchSetup::Kind::spindle);
  ASSERT_TRUE(m.spindle.has_value());
  EXPECT_EQ(m.spindle->spin_up_s, 0.8);
  EXPECT_EQ(m.setup().torch.spin_down_s, 0.5);
}

TEST(MachineConfig, FindsBundledMachinesByName) {
  const std::string p = find_machine("thermal_gantry");
  EXPECT_NE(p.find("datasets/machines/thermal_gantry.yaml"), std::string::npos) << p;
  EXPECT_EQ(load_machine(p).name, "thermal_gantry");
  EXPECT_EQ(find_machine(bundled("xy_table")), bundled("xy_table"));
  const std::string msg = test::error_of([] { find_machine("no_such_machine"); });
  EXPECT_NE(msg.find("machine: no machine named 'no_such_machine'"), std::string::npos) << msg;
  EXPECT_NE(test::error_of([] { find_machine("missing/file.yaml"); }).find("no such machine file"), std::string::npos);
}

// Replaces the first occurrence of `from` in the gantry file and returns the loader's error.
std::string error_after(const std::string& from, const std::string& to) {
  std::string text = read(bundled("thermal_gantry"));
  const auto at = text.find(from);
  if (at == std::string::npos) return "<'" + from + "' not in the bundled file>";
  text.replace(at, from.size(), to);
  test::TempDir dir;
  const std::string path = dir.write("m.yaml", text);
  return test::error_of([&] { load_machine(path); });
}

int line_of(const std::string& needle) {
  const std::string text = read(bundled("thermal_gantry"));
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + text.find(needle), '\n'));
}

TEST(MachineConfig, RefusesUnknownKeysWithLine) {
  const std::string e = error_after("      gain_factor: 0.7", "      gain_factr: 0.7");
  EXPECT_NE(e.find(fmt::format("m.yaml:{}: unknown key 'axes.x.drive.gain_factr'", line_of("      gain_factor: 0.7"))),
            std::string::npos)
      << e;
}

TEST(MachineConfig, RefusesBadValuesNamingTheKey) {
  EXPECT_NE(error_after("      decoding: 4", "      decoding: 3").find("key 'axes.x.encoder.decoding' must be 1, 2 or 4"),
            std::string::npos);
  EXPECT_NE(error_after("    dac_bits: 12", "    dac_bits: 40").find("key 'axes.x.dac_bits' must be between 8 and 24"),
            std::string::npos);
  EXPECT_NE(error_after("      gain_factor: 0.7", "      gain_factor: -1").find("key 'axes.x.drive.gain_factor'"),
            std::string::npos);
  EXPECT_NE(error_after("  velocity_mm_per_s: 80", "  velocity_mm_per_s: 120")
                .find("key 'limits.velocity_mm_per_s' is 120 but axis x tops out at 81.81 mm/s"),
            std::string::npos);
  EXPECT_NE(error_after("  kind: plasma", "  kind: laser").find("key 'torch.kind' must be 'plasma' or 'oxy_fuel'"),
            std::string::npos);
  EXPECT_NE(error_after("      bits: 16", "      bits: 4").find("key 'axes.x.counter.bits' must be between 8 and 32"),
            std::string::npos);
  const std::string huge = error_after("      kp_per_s: 90\n", "      kp_per_s: 1e9\n");
  EXPECT_NE(huge.find("axes.x.servo.kp_per_s"), std::string::npos) << huge;
  EXPECT_NE(huge.find("<= 100000"), std::string::npos) << huge;
  EXPECT_NE(error_after("  travel_height_over_cut_mm: 40.0", "  travel_height_over_cut_mm: 10")
                .find("key 'torch_height.travel_height_over_cut_mm' must be at least retract_height_mm"),
            std::string::npos);
  EXPECT_NE(error_after("  travel_height_over_cut_mm: 40.0", "  travel_height_over_cut_mm: 200")
                .find("beyond the height axis' timeout_s 3 s"),
            std::string::npos);
  const std::string missing = error_after("      kp_per_s: 90\n", "");
  EXPECT_NE(missing.find("missing required key 'axes.x.servo.kp_per_s'"), std::string::npos) << missing;
}

TEST(MachineConfig, TheProbeBlockIsReadAndItsBadValuesRefusedWithTheirLine) {
  const MachineConfig m = load_machine(bundled("thermal_gantry"));
  const auto& p = m.torch_height.probe;
  EXPECT_TRUE(p.ohmic && p.float_switch);
  EXPECT_DOUBLE_EQ(p.probe_height_mm, 5.0);
  EXPECT_DOUBLE_EQ(p.float_travel_mm, 1.5);
  EXPECT_EQ(m.setup().torch.probe.skip_distance_mm, p.skip_distance_mm);
  const std::string height = error_after("    probe_height_mm: 5.0", "    probe_height_mm: 20");
  EXPECT_NE(height.find(fmt::format("m.yaml:{}: key 'torch_height.probe.probe_height_mm' must be below retract_height_mm (15 mm)",
                                    line_of("    probe_height_mm: 5.0"))),
            std::string::npos)
      << height;
  EXPECT_NE(error_after("    probe_speed_mm_per_s: 10.0", "    probe_speed_mm_per_s: 80")
                .find("key 'torch_height.probe.probe_speed_mm_per_s' must not exceed the height axis' speed_mm_per_s (50)"),
            std::string::npos);
  const std::string neither = error_after("    ohmic: true                       # the shield touches the plate: tried first\n"
                                          "    float_switch: true",
                                          "    ohmic: false\n    float_switch: false");
  EXPECT_NE(neither.find("key 'torch_height.probe' names no sensor: set float_switch, ohmic or both to true"), std::string::npos)
      << neither;
  EXPECT_NE(error_after("    debounce_periods: 3", "    debounce_periods: 0").find("key 'torch_height.probe.debounce_periods'"),
            std::string::npos);
  // An offset probe closes the float-switch input, and ohmic sensing cannot be done beside the torch.
  const std::string offset_ohmic = error_after("    debounce_periods: 3", "    debounce_periods: 3\n    offset_x_mm: -60");
  EXPECT_NE(offset_ohmic.find("key 'torch_height.probe.ohmic' must be false with an offset probe"), std::string::npos)
      << offset_ohmic;
  const std::string offset_alone = error_after("    ohmic: true                       # the shield touches the plate: tried first\n"
                                               "    float_switch: true",
                                               "    ohmic: true\n    float_switch: false\n    offset_y_mm: 40");
  EXPECT_NE(offset_alone.find("has an offset probe (offset_x_mm, offset_y_mm): set float_switch to true"), std::string::npos)
      << offset_alone;
  EXPECT_NE(error_after("    debounce_periods: 3", "    debounce_periods: 3\n    offset_delay_s: 20")
                .find("key 'torch_height.probe.offset_delay_s'"),
            std::string::npos);
  const std::string old = error_after("  probe:   ", "  initial_height_sense_s: 0.4\n  probe:   ");
  EXPECT_NE(old.find("key 'torch_height.initial_height_sense_s' is no longer read: the torch finds the sheet by probing"),
            std::string::npos)
      << old;
}

TEST(MachineConfig, ASpindleMachineHasNoTorch) {
  // The gantry's file with a spindle block besides its torch: one or the other.
  const std::string both = error_after("name: thermal_gantry\n", "name: thermal_gantry\nspindle: {spin_up_s: 1, spin_down_s: 1}\n");
  EXPECT_NE(both.find("a machine has a torch or a spindle, not both"), std::string::npos) << both;
}

}  // namespace
}  // namespace machplan::cutting
