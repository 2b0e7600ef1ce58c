#include "models/cutting/machine_config.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <vector>

#include "engine/common/error.h"
#include "engine/config/yaml.h"

namespace machplan::cutting {

namespace {

const NumberRule kPositive{.min = 0, .min_exclusive = true};
const NumberRule kNonNegative{.min = 0};

AxisConfig read_axis(const Yaml& a, const std::string& name) {
  a.reject_unknown_keys({"travel_mm", "drive", "encoder", "counter", "dac_bits", "latency", "servo"});
  AxisConfig ax;
  ax.name = name;
  ax.travel_mm = a.number("travel_mm", kPositive);
  axis::AxisPlantParams& p = ax.plant;

  const Yaml d = a.at("drive");
  d.reject_unknown_keys({"motor_max_rpm", "gear_ratio", "mm_per_rev", "dac_full_scale_rpm",
                         "velocity_loop_time_constant_s", "max_acceleration_mm_per_s2", "gain_factor",
                         "coulomb_friction_mm_per_s", "viscous_friction_ratio", "speed_noise_mm_per_s", "backlash_mm",
                         "start_shock_mm_per_s", "substeps"});
  p.motor_max_rpm = d.number("motor_max_rpm", kPositive);
  p.gear_ratio = d.number("gear_ratio", kPositive);
  p.mm_per_rev = d.number("mm_per_rev", kPositive);
  p.dac_full_scale_rpm = d.number_or("dac_full_scale_rpm", p.motor_max_rpm, kPositive);
  p.velocity_loop_time_constant_s = d.number("velocity_loop_time_constant_s", {.min = 1e-5, .max = 10});
  p.max_acceleration_mm_per_s2 = d.number_or("max_acceleration_mm_per_s2", 0.0, kNonNegative);
  p.gain_factor = d.number_or("gain_factor", 1.0, {.min = 0, .max = 2, .min_exclusive = true});
  p.coulomb_friction_mm_per_s = d.number_or("coulomb_friction_mm_per_s", 0.0, kNonNegative);
  p.viscous_friction_ratio = d.number_or("viscous_friction_ratio", 0.0, {.min = 0, .max = 10});
  p.speed_noise_mm_per_s = d.number_or("speed_noise_mm_per_s", 0.0, kNonNegative);
  p.backlash_mm = d.number_or("backlash_mm", 0.0, {.min = 0, .max = 10});
  p.start_shock_mm_per_s = d.number_or("start_shock_mm_per_s", 0.0, kNonNegative);
  if (d.has("substeps")) p.substeps = d.at("substeps").integer(1, 1000);

  const Yaml e = a.at("encoder");
  e.reject_unknown_keys({"lines_per_rev", "mm_per_rev", "decoding"});
  p.encoder_lines_per_rev = e.at("lines_per_rev").integer(1, 10'000'000);
  p.encoder_mm_per_rev = e.number("mm_per_rev", kPositive);
  p.decoding = e.at("decoding").integer(1, 4);
  if (p.decoding == 3) e.at("decoding").fail("must be 1, 2 or 4 (edges counted per encoder line), got 3");

  const Yaml c = a.at("counter");
  c.reject_unknown_keys({"bits", "direction_bit"});
  p.counter_bits = c.at("bits").integer(8, 32);
  if (!c.boolean_or("direction_bit", true))
    c.at("direction_bit").fail("must be true: only down counters with a direction bit are modelled");

  p.dac_bits = a.at("dac_bits").integer(8, 24);
  if (const auto l = a.get("latency")) {
    l->reject_unknown_keys({"command_ticks", "reading_ticks"});
    if (l->has("command_ticks")) p.command_latency_ticks = l->at("command_ticks").integer(0, axis::AxisPlantParams::kMaxLatencyTicks);
    if (l->has("reading_ticks")) p.reading_latency_ticks = l->at("reading_ticks").integer(0, axis::AxisPlantParams::kMaxLatencyTicks);
  }

  const Yaml s = a.at("servo");
  s.reject_unknown_keys({"kp_per_s", "ki_per_s2", "kd", "velocity_ff", "acceleration_ff_s", "ff_adaptation_per_s2", "ff_adaptation_min_speed_mm_per_s", "following_error_limit_mm",
                         "backlash_compensation_mm", "backlash_compensation_time_s"});
  control::ServoGains& g = ax.servo;
  // The upper bounds lie far beyond any loop that is stable at the usual periods (a P loop needs
  // Kp T < 2, Kp < 2000 /s at 1 ms): a gain above them is a typing mistake, not a tuning.
  g.kp_per_s = s.number("kp_per_s", {.min = 0, .max = 1e5});
  g.ki_per_s2 = s.number_or("ki_per_s2", 0.0, {.min = 0, .max = 1e8});
  g.kd = s.number_or("kd", 0.0, {.min = 0, .max = 10});
  g.velocity_ff = s.number_or("velocity_ff", 1.0, {.min = 0, .max = 3});
  g.acceleration_ff_s = s.number_or("acceleration_ff_s", 0.0, {.min = 0, .max = 1});
  g.ff_adaptation_per_s2 = s.number_or("ff_adaptation_per_s2", 0.0, {.min = 0, .max = 1e5});
  g.ff_adaptation_min_speed_mm_per_s = s.number_or("ff_adaptation_min_speed_mm_per_s", g.ff_adaptation_min_speed_mm_per_s,
                                                   {.min = 0, .max = 1e4, .min_exclusive = true});
  g.following_error_limit_mm = s.number("following_error_limit_mm", {.min = 0, .max = 1000, .min_exclusive = true});
  g.backlash_compensation_mm = s.number_or("backlash_compensation_mm", 0.0, {.min = 0, .max = 5});
  g.backlash_compensation_time_s =
      s.number_or("backlash_compensation_time_s", g.backlash_compensation_time_s, {.min = 0, .max = 1, .min_exclusive = true});

  try {
    p.validate();
    g.validate();
  } catch (const InputError& ex) {
    if (!ex.is_field()) throw;
    a.fail(ex.what());
  }
  return ax;
}

// The plasma process beyond the torch: torch height control and the simulated sheet's warp.
// The torch_height block's probe block: how the torch finds the sheet.
executor::ProbeSetup read_probe(const Yaml& p, const TorchHeightConfig& th) {
  p.reject_unknown_keys({"float_switch", "ohmic", "probe_height_mm", "probe_speed_mm_per_s", "float_travel_mm",
                         "ohmic_offset_mm", "max_depth_mm", "skip_distance_mm", "debounce_periods", "offset_x_mm",
                         "offset_y_mm", "offset_delay_s"});
  executor::ProbeSetup s;
  s.float_switch = p.boolean_or("float_switch", false);
  s.ohmic = p.boolean_or("ohmic", false);
  if (!s.fitted()) p.fail("names no sensor: set float_switch, ohmic or both to true");
  s.probe_height_mm = p.number_or("probe_height_mm", s.probe_height_mm, {.min = 0.0, .max = 100.0, .min_exclusive = true});
  if (s.probe_height_mm >= th.retract_height_mm)
    p.at("probe_height_mm").fail(fmt::format("must be below retract_height_mm ({:g} mm): the probe starts from there", th.retract_height_mm));
  s.probe_speed_mm_per_s = p.number_or("probe_speed_mm_per_s", s.probe_speed_mm_per_s, {.min = 0.0, .max = 100.0, .min_exclusive = true});
  if (s.probe_speed_mm_per_s > th.speed_mm_per_s)
    p.at("probe_speed_mm_per_s").fail(fmt::format("must not exceed the height axis' speed_mm_per_s ({:g})", th.speed_mm_per_s));
  s.float_travel_mm = p.number_or("float_travel_mm", s.float_travel_mm, {.min = 0.0, .max = 20.0});
  s.ohmic_offset_mm = p.number_or("ohmic_offset_mm", s.ohmic_offset_mm, {.min = -5.0, .max = 5.0});
  s.max_depth_mm = p.number_or("max_depth_mm", s.max_depth_mm, {.min = 0.0, .max = 100.0, .min_exclusive = true});
  s.skip_distance_mm = p.number_or("skip_distance_mm", s.skip_distance_mm, {.min = 0.0, .max = 1000.0});
  if (const auto d = p.get("debounce_periods")) s.debounce_periods = d->integer(1, 100);
  s.offset_x_mm = p.number_or("offset_x_mm", 0.0, {.min = -1000.0, .max = 1000.0});
  s.offset_y_mm = p.number_or("offset_y_mm", 0.0, {.min = -1000.0, .max = 1000.0});
  s.offset_delay_s = p.number_or("offset_delay_s", s.offset_delay_s, {.min = 0.0, .max = 10.0});
  if (s.offset()) {
    if (!s.float_switch) p.fail("has an offset probe (offset_x_mm, offset_y_mm): set float_switch to true, the input it closes");
    if (s.ohmic) p.at("ohmic").fail("must be false with an offset probe: ohmic sensing needs the torch over the pierce point");
  }
  return s;
}

void read_plasma_process(const Yaml& root, MachineConfig& m) {
  if (const auto th = root.get("thc")) {
    th->reject_unknown_keys({"enabled", "delay_s", "sample_s", "threshold_v", "speed_mm_per_s_per_v", "max_speed_mm_per_s",
                             "velocity_anti_dive_pct", "void_anti_dive_v_per_s", "max_correction_mm"});
    executor::ThcSettings& c = m.thc;
    c.enabled = th->boolean_or("enabled", c.enabled);
    c.delay_s = th->number_or("delay_s", c.delay_s, {.min = 0.0, .max = 60.0});
    c.sample_s = th->number_or("sample_s", c.sample_s, {.min = 0.0, .max = 10.0, .min_exclusive = true});
    c.threshold_v = th->number_or("threshold_v", c.threshold_v, {.min = 0.0, .max = 50.0});
    c.speed_mm_per_s_per_v = th->number_or("speed_mm_per_s_per_v", c.speed_mm_per_s_per_v, {.min = 0.0, .max = 100.0, .min_exclusive = true});
    c.max_speed_mm_per_s = th->number_or("max_speed_mm_per_s", c.max_speed_mm_per_s, {.min = 0.0, .max = 1000.0, .min_exclusive = true});
    c.velocity_anti_dive_pct = th->number_or("velocity_anti_dive_pct", c.velocity_anti_dive_pct, {.min = 0.0, .max = 100.0});
    c.void_anti_dive_v_per_s = th->number_or("void_anti_dive_v_per_s", c.void_anti_dive_v_per_s, {.min = 0.0, .max = 1e6, .min_exclusive = true});
    c.max_correction_mm = th->number_or("max_correction_mm", c.max_correction_mm, {.min = 0.0, .max = 50.0});
  }
  if (const auto sh = root.get("sheet")) {
    sh->reject_unknown_keys({"warp_amplitude_mm", "warp_wavelength_mm", "ohmic_miss_probability"});
    m.sheet_warp_amplitude_mm = sh->number_or("warp_amplitude_mm", 0.0, {.min = 0.0, .max = 50.0});
    m.sheet_warp_wavelength_mm = sh->number_or("warp_wavelength_mm", 500.0, {.min = 1.0, .max = 1e5});
    m.sheet_ohmic_miss_probability = sh->number_or("ohmic_miss_probability", 0.0, {.min = 0.0, .max = 1.0});
  }
}

}  // namespace

const char* to_string(MachineUse use) {
  switch (use) {
    case MachineUse::cutting: return "cutting";
    case MachineUse::placement: return "placement";
    case MachineUse::unreadable: break;
  }
  return "unreadable";
}

MachineUse machine_use(const Yaml& root) {
  if (!root.is_map()) return MachineUse::unreadable;
  return root.has("kind") || root.has("struts") ? MachineUse::placement : MachineUse::cutting;
}

namespace {

// The `torch` block: the process (plasma or oxy-fuel) and its settings, the paused-motion speed.
void read_torch(const Yaml& t, MachineConfig& m) {
  t.reject_unknown_keys({"kind", "plasma", "oxy_fuel", "paused_motion_speed_mm_per_s"});
  m.torch.paused_motion_speed_mm_per_s =
      t.number_or("paused_motion_speed_mm_per_s", m.torch.paused_motion_speed_mm_per_s,
                   {.min = 0.0, .max = m.limits.velocity_mm_per_s, .min_exclusive = true});
  if (const auto p = t.get("plasma")) {
    p->reject_unknown_keys({"arc_start_delay_s", "arc_ok_timeout_s", "pierce_delay_s", "arc_start_failure_probability",
                            "on_arc_loss", "arc_volts_base_v", "volts_per_mm", "arc_voltage_noise_v", "kerf_crossing_rise_v"});
    m.torch.has_plasma = true;
    m.torch.plasma.arc_start_delay_s = p->number("arc_start_delay_s", kNonNegative);
    m.torch.plasma.arc_ok_timeout_s = p->number("arc_ok_timeout_s", kPositive);
    m.torch.plasma.pierce_delay_s = p->number("pierce_delay_s", kNonNegative);
    m.torch.plasma.arc_start_failure_probability =
        p->number_or("arc_start_failure_probability", 0.0, {.min = 0, .max = 1});
    if (const auto loss = p->get("on_arc_loss")) {
      const std::string v = loss->string();
      if (v != "stop" && v != "recover") loss->fail("must be 'stop' or 'recover', got '" + excerpt(v) + "'");
      m.torch.plasma.recover_on_arc_loss = v == "recover";
    }
    PlasmaConfig& pc = m.torch.plasma;
    pc.arc_volts_base_v = p->number_or("arc_volts_base_v", pc.arc_volts_base_v, {.min = 0.0, .max = 1000.0});
    pc.volts_per_mm = p->number_or("volts_per_mm", pc.volts_per_mm, {.min = 0.0, .max = 1000.0, .min_exclusive = true});
    pc.arc_voltage_noise_v = p->number_or("arc_voltage_noise_v", pc.arc_voltage_noise_v, {.min = 0.0, .max = 100.0});
    pc.kerf_crossing_rise_v = p->number_or("kerf_crossing_rise_v", pc.kerf_crossing_rise_v, {.min = 0.0, .max = 1000.0});
    if (m.torch.plasma.arc_start_delay_s >= m.torch.plasma.arc_ok_timeout_s)
      p->at("arc_ok_timeout_s").fail("must be longer than arc_start_delay_s, or no arc could ever start in time");
  }
  if (const auto o = t.get("oxy_fuel")) {
    o->reject_unknown_keys({"preheat_s", "pierce_delay_s"});
    m.torch.has_oxy_fuel = true;
    m.torch.oxy_fuel.preheat_s = o->number("preheat_s", kNonNegative);
    m.torch.oxy_fuel.pierce_delay_s = o->number("pierce_delay_s", kNonNegative);
  }
  const std::string kind = t.string("kind");
  if (kind == "plasma") {
    if (!m.torch.has_plasma) t.at("kind").fail("is 'plasma' but there is no 'torch.plasma' section");
    m.torch.kind = executor::TorchSetup::Kind::plasma;
  } else if (kind == "oxy_fuel") {
    if (!m.torch.has_oxy_fuel) t.at("kind").fail("is 'oxy_fuel' but there is no 'torch.oxy_fuel' section");
    m.torch.kind = executor::TorchSetup::Kind::oxy_fuel;
  } else {
    t.at("kind").fail("must be 'plasma' or 'oxy_fuel', got '" + excerpt(kind) + "'");
  }
}

}  // namespace

MachineConfig machine_from_yaml(const Yaml& root) {
  // A placement machine would otherwise be refused on its first key this reader does not
  // know, which tells a user nothing about what went wrong.
  if (machine_use(root) == MachineUse::placement)
    throw InputError(root.file(), 0,
                     fmt::format("'{}' is a machine for placement ({}): it is named by a scene's `machine:` for "
                                 "`machplan place` and `machplan check`, and cannot run programs. `machplan machines` "
                                 "lists each machine's use",
                                 excerpt(root.string_or("name", std::filesystem::path(root.file()).stem().string()), 60),
                                 root.has("kind") ? "kind " + excerpt(root.string("kind"), 40) : "a hexapod"));
  root.reject_unknown_keys({"name", "description", "servo_period_s", "limits", "axes", "torch", "torch_height",
                           "slug_tip_size_mm", "origin_mm", "gcode", "cut_order", "spindle", "thc", "sheet",
                           "laser"});
  MachineConfig m;
  m.source = root.file();
  m.name = root.string("name");
  m.description = root.string_or("description", "");
  m.servo_period_s = root.number_or("servo_period_s", 0.001, {.min = 1e-5, .max = 0.1});
  m.slug_tip_size_mm = root.number_or("slug_tip_size_mm", m.slug_tip_size_mm, {.min = 0.0, .max = 1e6});
  if (const auto c = root.get("cut_order")) {
    m.cut_order = c->string();  // the name is checked where it is read (motion::cut_order_of)
    m.cut_order_line = c->line();
  }
  if (const auto o = root.get("origin_mm")) {
    const std::vector<double> xy = o->numbers(2, {.min = -1e6, .max = 1e6});
    m.origin_mm = std::array<double, 2>{xy[0], xy[1]};
  }
  if (const auto l = root.get("laser")) {
    l->reject_unknown_keys({"offset_mm"});
    const std::vector<double> xy = l->at("offset_mm").numbers(2, {.min = -1000, .max = 1000});
    m.laser_offset_mm = std::array<double, 2>{xy[0], xy[1]};
  }
  if (const auto g = root.get("gcode")) {
    g->reject_unknown_keys({"spindles", "params"});
    if (g->has("spindles")) m.gcode_spindles = g->at("spindles").integer(1, 100);
    if (const auto ps = g->get("params")) {
      if (!ps->is_sequence()) ps->fail("must be a list of {name: NAME, value: NUMBER}");
      for (const Yaml& p : ps->items()) {
        p.reject_unknown_keys({"name", "value"});
        m.gcode_params.emplace_back(p.string("name"), p.number("value"));
      }
    }
  }

  const Yaml l = root.at("limits");
  l.reject_unknown_keys(
      {"velocity_mm_per_s", "acceleration_mm_per_s2", "jerk_mm_per_s3", "rapid_mm_per_s", "contour_error_mm"});
  m.limits.velocity_mm_per_s = l.number("velocity_mm_per_s", kPositive);
  m.limits.acceleration_mm_per_s2 = l.number("acceleration_mm_per_s2", kPositive);
  m.limits.jerk_mm_per_s3 = l.number("jerk_mm_per_s3", kPositive);
  m.limits.rapid_mm_per_s = l.number("rapid_mm_per_s", kPositive);
  m.limits.contour_error_mm = l.number_or("contour_error_mm", m.limits.contour_error_mm, {.min = 1e-3, .max = 100.0});

  const Yaml axes = root.at("axes");
  axes.reject_unknown_keys({"x", "y"});
  m.axes[0] = read_axis(axes.at("x"), "x");
  m.axes[1] = read_axis(axes.at("y"), "y");
  for (const AxisConfig& ax : m.axes) {
    const double top = ax.plant.max_speed_mm_per_s();
    if (m.limits.velocity_mm_per_s > top * (1 + 1e-3))
      l.at("velocity_mm_per_s")
          .fail(fmt::format("is {} but axis {} tops out at {:.2f} mm/s (motor rpm / gear ratio * mm per rev)",
                            m.limits.velocity_mm_per_s, ax.name, top));
    if (m.limits.rapid_mm_per_s > top * (1 + 1e-3))
      l.at("rapid_mm_per_s").fail(fmt::format("is {} but axis {} tops out at {:.2f} mm/s", m.limits.rapid_mm_per_s,
                                              ax.name, top));
  }

  if (const auto t = root.get("torch")) read_torch(*t, m);
  read_plasma_process(root, m);
  if (const auto sp = root.get("spindle")) {
    if (root.has("torch")) sp->fail("a machine has a torch or a spindle, not both");
    if (root.has("torch_height")) sp->fail("a spindle machine has no torch height axis (torch_height)");
    sp->reject_unknown_keys({"spin_up_s", "spin_down_s", "max_speed_rpm"});
    SpindleConfig s;
    s.spin_up_s = sp->number("spin_up_s", {.min = 0.0, .max = 600.0});
    s.spin_down_s = sp->number("spin_down_s", {.min = 0.0, .max = 600.0});
    s.max_speed_rpm = sp->number_or("max_speed_rpm", s.max_speed_rpm, {.min = 0.0, .max = 1e6, .min_exclusive = true});
    m.spindle = s;
    m.torch.kind = executor::TorchSetup::Kind::spindle;
  }
  if (const auto h = root.get("torch_height")) {
    if (h->has("initial_height_sense_s"))
      h->at("initial_height_sense_s")
          .fail("is no longer read: the torch finds the sheet by probing (a `probe` block with float_switch and/or ohmic)");
    h->reject_unknown_keys({"pierce_height_mm", "cut_height_mm", "retract_height_mm", "speed_mm_per_s", "timeout_s",
                            "travel_height_over_cut_mm", "probe"});
    TorchHeightConfig& th = m.torch_height;
    th.fitted = true;
    th.pierce_height_mm = h->number("pierce_height_mm", kPositive);
    th.cut_height_mm = h->number("cut_height_mm", kPositive);
    th.retract_height_mm = h->number("retract_height_mm", kPositive);
    th.speed_mm_per_s = h->number("speed_mm_per_s", kPositive);
    th.timeout_s = h->number("timeout_s", kPositive);
    if (th.retract_height_mm < th.pierce_height_mm)
      h->at("retract_height_mm").fail("must be at least pierce_height_mm");
    const double worst = th.retract_height_mm / th.speed_mm_per_s;
    if (th.timeout_s <= worst)
      h->at("timeout_s").fail(fmt::format("must exceed a full stroke from the retract height ({:.3f} s)", worst));
    if (const auto p = h->get("probe")) th.probe = read_probe(*p, th);
    th.travel_height_over_cut_mm = h->number_or("travel_height_over_cut_mm", 0.0, {.min = 0.0, .max = 1000.0});
    if (th.travel_height_over_cut_mm > 0.0) {
      if (th.travel_height_over_cut_mm < th.retract_height_mm)
        h->at("travel_height_over_cut_mm").fail("must be at least retract_height_mm (or 0: the retract height)");
      const double stroke = th.travel_height_over_cut_mm / th.speed_mm_per_s;
      if (th.timeout_s <= stroke)
        h->at("travel_height_over_cut_mm")
            .fail(fmt::format("is a stroke of {:.3f} s, beyond the height axis' timeout_s {:g} s", stroke, th.timeout_s));
    }
  }
  return m;
}

MachineConfig load_machine(const std::string& path) { return machine_from_yaml(Yaml::load_file(path)); }

executor::MachineSetup MachineConfig::setup() const {
  executor::MachineSetup s;
  s.name = name;
  s.servo_period_s = servo_period_s;
  for (int i = 0; i < 2; ++i) {
    const auto& p = axes[i].plant;
    s.signals[i] = {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), p.command_latency_ticks,
                    p.reading_latency_ticks};
    s.servo[i] = axes[i].servo;
    s.max_speed_mm_per_s[i] = p.max_speed_mm_per_s();
  }
  s.max_velocity_mm_per_s = limits.velocity_mm_per_s;
  s.max_acceleration_mm_per_s2 = limits.acceleration_mm_per_s2;
  s.max_jerk_mm_per_s3 = limits.jerk_mm_per_s3;
  s.contour_error_limit_mm = limits.contour_error_mm;
  s.rapid_mm_per_s = limits.rapid_mm_per_s;
  s.torch.kind = torch.kind;
  s.torch.arc_ok_timeout_s = torch.plasma.arc_ok_timeout_s;
  s.torch.pierce_delay_s =
      torch.kind == executor::TorchSetup::Kind::oxy_fuel ? torch.oxy_fuel.pierce_delay_s : torch.plasma.pierce_delay_s;
  s.torch.preheat_s = torch.oxy_fuel.preheat_s;
  if (spindle) {
    s.torch.pierce_delay_s = 0.0;
    s.torch.spin_up_s = spindle->spin_up_s;
    s.torch.spin_down_s = spindle->spin_down_s;
  }
  s.torch.height_axis = torch_height.fitted;
  s.torch.pierce_height_mm = torch_height.pierce_height_mm;
  s.torch.cut_height_mm = torch_height.cut_height_mm;
  s.torch.retract_height_mm = torch_height.retract_height_mm;
  s.torch.height_timeout_s = torch_height.timeout_s;
  s.torch.height_speed_mm_per_s = torch_height.speed_mm_per_s;
  s.torch.probe = torch_height.probe;
  s.torch.recover_on_arc_loss = torch.kind == executor::TorchSetup::Kind::plasma && torch.plasma.recover_on_arc_loss;
  s.torch.volts_per_mm = torch.plasma.volts_per_mm;
  s.torch.paused_motion_speed_mm_per_s = torch.paused_motion_speed_mm_per_s;
  s.torch.thc = thc;
  return s;
}

namespace {

namespace fs = std::filesystem;

fs::path running_program() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return {};
  buf[n] = 0;
  return fs::path(buf);
}

// `dir` is `root` or inside it (both absolute and normal).
bool is_inside(const fs::path& dir, const fs::path& root) {
  const auto [r, d] = std::mismatch(root.begin(), root.end(), dir.begin(), dir.end());
  return r == root.end();
}

void add_folder(std::vector<MachineFolder>& out, fs::path path, const char* kind) {
  if (path.empty()) return;
  path = path.lexically_normal();
  for (const auto& f : out)
    if (f.path == path.string()) return;
  std::error_code ec;
  out.push_back({path.string(), kind, fs::is_directory(path, ec)});
}

}  // namespace

std::vector<MachineFolder> machine_folders() {
  std::vector<MachineFolder> folders;
  std::error_code ec;
  // 1. The user's own machines, per the XDG base directory convention.
  fs::path config;
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg != nullptr && xdg[0] == '/')
    config = xdg;
  else if (const char* home = std::getenv("HOME"); home != nullptr && home[0] == '/')
    config = fs::path(home) / ".config";
  if (!config.empty()) {
    const fs::path user = config / "machplan" / "machines";
    fs::create_directories(user, ec);  // a read-only home only means the folder stays absent
    add_folder(folders, user, "user");
  }
  // 2. Installed: relative to the running program first, so that an installed tree can be
  // moved; then the prefix it was configured for (a program of another project that links
  // the installed libraries).
  const fs::path exe = running_program();
  if (!exe.empty()) add_folder(folders, exe.parent_path().parent_path() / "share" / "machplan" / "machines", "installed");
#ifdef MACHPLAN_INSTALL_DATADIR
  add_folder(folders, fs::path(MACHPLAN_INSTALL_DATADIR) / "machines", "installed");
#endif
  // 3. A program of this build tree (the CLI, the tests) uses the source tree's machines.
#if defined(MACHPLAN_BUILD_DIR) && defined(MACHPLAN_SOURCE_DIR)
  if (!exe.empty() && is_inside(exe.lexically_normal(), fs::path(MACHPLAN_BUILD_DIR).lexically_normal()))
    add_folder(folders, fs::path(MACHPLAN_SOURCE_DIR) / "datasets" / "machines", "source");
#endif
  return folders;
}

std::string find_machine(const std::string& name_or_path) {
  std::error_code ec;
  const bool looks_like_name = name_or_path.find('/') == std::string::npos && name_or_path.find('.') == std::string::npos &&
                               !name_or_path.empty();
  if (!looks_like_name) {
    // A folder, a FIFO or a device goes on to the reader, which says what it is.
    if (fs::exists(name_or_path, ec)) return name_or_path;
    throw InputError::field("machine", fmt::format("no such machine file '{}'", excerpt(name_or_path)));
  }
  const std::vector<MachineFolder> folders = machine_folders();
  for (const MachineFolder& f : folders) {
    const fs::path candidate = fs::path(f.path) / (name_or_path + ".yaml");
    if (fs::is_regular_file(candidate, ec)) return candidate.string();
  }
  std::string searched;
  for (const auto& f : folders) searched += fmt::format("{}{} ({})", searched.empty() ? "" : ", ", f.path, f.kind);
  throw InputError::field("machine", fmt::format("no machine named '{}' (looked for {}.yaml in {}; `machplan machines` "
                                                 "lists the machines found; a file in the current folder is used only "
                                                 "as a path, ./{}.yaml)",
                                                 name_or_path, name_or_path, searched.empty() ? "no folder" : searched,
                                                 name_or_path));
}

std::vector<MachineEntry> list_machines() {
  std::vector<MachineEntry> out;
  std::set<std::string> seen;
  for (const MachineFolder& f : machine_folders()) {
    if (!f.exists) continue;
    std::vector<fs::path> files;
    std::error_code ec;
    for (fs::directory_iterator it(f.path, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().extension() == ".yaml" && it->is_regular_file(ec)) files.push_back(it->path());
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      const std::string name = file.stem().string();
      MachineEntry entry;
      entry.name = name;
      entry.path = file.string();
      entry.kind = f.kind;
      entry.shadowed = !seen.insert(name).second;
      try {
        entry.use = machine_use(Yaml::load_file(entry.path));
        if (entry.use == MachineUse::unreadable) entry.problem = "its top level is not a map of keys";
      } catch (const InputError& e) {
        entry.problem = e.what();
      }
      out.push_back(std::move(entry));
    }
  }
  return out;
}

}  // namespace machplan::cutting
