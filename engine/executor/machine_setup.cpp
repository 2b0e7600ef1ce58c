#include "engine/executor/machine_setup.h"

#include <cmath>

#include <fmt/format.h>

#include "engine/control/controller_factory.h"
#include "engine/common/error.h"

namespace machplan::executor {

namespace {
void require(bool ok, const std::string& field, double value, std::string_view rule) { require_field(ok, field, value, rule); }
}  // namespace

void ProbeSetup::validate() const {
  if (!fitted()) return;
  require(std::isfinite(probe_height_mm) && probe_height_mm > 0 && probe_height_mm <= 100, "probe_height_mm", probe_height_mm,
          "must be in (0, 100] mm");
  require(std::isfinite(probe_speed_mm_per_s) && probe_speed_mm_per_s > 0 && probe_speed_mm_per_s <= 100, "probe_speed_mm_per_s",
          probe_speed_mm_per_s, "must be in (0, 100] mm/s");
  require(std::isfinite(float_travel_mm) && float_travel_mm >= 0 && float_travel_mm <= 20, "float_travel_mm", float_travel_mm,
          "must be in [0, 20] mm");
  require(std::isfinite(ohmic_offset_mm) && std::abs(ohmic_offset_mm) <= 5, "ohmic_offset_mm", ohmic_offset_mm,
          "must be in [-5, 5] mm");
  require(std::isfinite(max_depth_mm) && max_depth_mm > 0 && max_depth_mm <= 100, "max_depth_mm", max_depth_mm,
          "must be in (0, 100] mm");
  require(std::isfinite(skip_distance_mm) && skip_distance_mm >= 0 && skip_distance_mm <= 1000, "skip_distance_mm",
          skip_distance_mm, "must be in [0, 1000] mm");
  require(debounce_periods >= 1 && debounce_periods <= 100, "debounce_periods", debounce_periods, "must be 1 .. 100");
  require(std::isfinite(offset_x_mm) && std::abs(offset_x_mm) <= 1000, "offset_x_mm", offset_x_mm, "must be in [-1000, 1000] mm");
  require(std::isfinite(offset_y_mm) && std::abs(offset_y_mm) <= 1000, "offset_y_mm", offset_y_mm, "must be in [-1000, 1000] mm");
  require(std::isfinite(offset_delay_s) && offset_delay_s >= 0 && offset_delay_s <= 10, "offset_delay_s", offset_delay_s,
          "must be in [0, 10] s");
  if (offset()) {
    require(float_switch, "float_switch", 0, "must be true with an offset probe: the probe closes the float-switch input");
    require(!ohmic, "ohmic", 1, "must be false with an offset probe: ohmic sensing needs the torch over the pierce point");
  }
}

void TorchSetup::validate() const {
  require(std::isfinite(arc_ok_timeout_s) && arc_ok_timeout_s > 0, "arc_ok_timeout_s", arc_ok_timeout_s, "must be > 0");
  require(std::isfinite(pierce_delay_s) && pierce_delay_s >= 0, "pierce_delay_s", pierce_delay_s, "must be >= 0");
  require(std::isfinite(preheat_s) && preheat_s >= 0, "preheat_s", preheat_s, "must be >= 0");
  require(std::isfinite(spin_up_s) && spin_up_s >= 0 && spin_up_s <= 600, "spin_up_s", spin_up_s, "must be in [0, 600] s");
  require(std::isfinite(volts_per_mm) && volts_per_mm > 0 && volts_per_mm <= 1000, "volts_per_mm", volts_per_mm,
          "must be in (0, 1000] V/mm");
  validate_member("thc", thc);
  require(std::isfinite(spin_down_s) && spin_down_s >= 0 && spin_down_s <= 600, "spin_down_s", spin_down_s,
          "must be in [0, 600] s");
  require(std::isfinite(height_timeout_s) && height_timeout_s > 0, "height_timeout_s", height_timeout_s, "must be > 0");
  require(std::isfinite(height_speed_mm_per_s) && height_speed_mm_per_s > 0, "height_speed_mm_per_s", height_speed_mm_per_s,
          "must be > 0");
  validate_member("probe", probe);
  require(std::isfinite(paused_motion_speed_mm_per_s) && paused_motion_speed_mm_per_s > 0 && paused_motion_speed_mm_per_s <= 1000,
          "paused_motion_speed_mm_per_s", paused_motion_speed_mm_per_s, "must be in (0, 1000] mm/s");
  if (probe.fitted()) {
    require(height_axis, "probe", 1, "needs a torch height axis");
    require(probe.probe_height_mm < retract_height_mm, "probe.probe_height_mm", probe.probe_height_mm,
            fmt::format("must be below the retract height ({} mm): the probe starts from there", retract_height_mm));
  }
}

void MachineSetup::validate() const {
  for (int i = 0; i < hardware::kAxes; ++i) {
    const auto& s = signals[i];
    const std::string ax = fmt::format("signals[{}].", i);
    require(std::isfinite(s.mm_per_count) && s.mm_per_count > 0, ax + "mm_per_count", s.mm_per_count, "must be > 0");
    require(s.counter_bits >= 8 && s.counter_bits <= 32, ax + "counter_bits", s.counter_bits, "must be 8 .. 32");
    require(s.dac_bits >= 8 && s.dac_bits <= 24, ax + "dac_bits", s.dac_bits, "must be 8 .. 24");
    require(std::isfinite(s.dac_full_scale_mm_per_s) && s.dac_full_scale_mm_per_s > 0, ax + "dac_full_scale_mm_per_s",
            s.dac_full_scale_mm_per_s, "must be > 0");
    require(s.command_latency_ticks >= 0 && s.command_latency_ticks <= 100, ax + "command_latency_ticks",
            s.command_latency_ticks, "must be 0 .. 100");
    require(s.reading_latency_ticks >= 0 && s.reading_latency_ticks <= 100, ax + "reading_latency_ticks",
            s.reading_latency_ticks, "must be 0 .. 100");
    require(std::isfinite(max_speed_mm_per_s[i]) && max_speed_mm_per_s[i] > 0, fmt::format("max_speed_mm_per_s[{}]", i),
            max_speed_mm_per_s[i], "must be > 0");
    const double cal = calibrated_mm_per_count[i];
    require(std::isfinite(cal) && (cal == 0 || std::abs(cal / s.mm_per_count - 1) <= 0.1),
            fmt::format("calibrated_mm_per_count[{}]", i), cal,
            "must be 0 (not calibrated) or within 10 % of mm_per_count");
    validate_member(fmt::format("servo[{}]", i), servo[i]);
  }
  require(std::isfinite(max_acceleration_mm_per_s2) && max_acceleration_mm_per_s2 > 0, "max_acceleration_mm_per_s2",
          max_acceleration_mm_per_s2, "must be > 0");
  require(std::isfinite(max_jerk_mm_per_s3) && max_jerk_mm_per_s3 > 0, "max_jerk_mm_per_s3", max_jerk_mm_per_s3,
          "must be > 0");
  require(std::isfinite(contour_error_limit_mm) && contour_error_limit_mm > 0, "contour_error_limit_mm",
          contour_error_limit_mm, "must be > 0");
  require(std::isfinite(rapid_mm_per_s) && rapid_mm_per_s > 0, "rapid_mm_per_s", rapid_mm_per_s, "must be > 0");
  validate_member("torch", torch);
}

control::ControllerPlant plant_from_setup(const executor::MachineSetup& setup) {
  control::ControllerPlant p;
  p.servo = setup.servo;
  for (int i = 0; i < control::kAxes; ++i) {
    p.output_limit_mm_per_s[i] = setup.signals[i].dac_full_scale_mm_per_s;
    p.command_latency_ticks[i] = setup.signals[i].command_latency_ticks;
    p.reading_latency_ticks[i] = setup.signals[i].reading_latency_ticks;
    p.position_quantum_mm[i] =
        setup.calibrated_mm_per_count[i] > 0 ? setup.calibrated_mm_per_count[i] : setup.signals[i].mm_per_count;
  }
  if (setup.servo_period_s > 0) p.period_s = setup.servo_period_s;
  return p;
}

}  // namespace machplan::executor
