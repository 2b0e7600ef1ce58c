#include "engine/control/controller_factory.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/control/cross_coupled_controller.h"
#include "engine/control/fuzzy_controller.h"
#include "engine/control/pid_controller.h"
#include "engine/control/pid_ff_controller.h"
#include "engine/control/zpetc_controller.h"

namespace machplan::control {

namespace {

using AxisGains = std::array<Gains, kAxes>;  // every gain of a kind resolved, per axis

// One kind: its gains on axis `axis` of a plant (defaults may differ per axis), and its maker.
struct Kind {
  Spelling name;  // canonical, and an old spelling still accepted
  std::vector<GainSpec> (*specs)(const ControllerPlant&, int axis);
  std::unique_ptr<Controller> (*make)(const AxisGains&, const ControllerPlant&);
};

// A box that holds `def`: log scale only when the whole box is positive.
GainSpec spec(const char* name, double def, double lo, double hi, bool log, const char* what) {
  lo = std::min(lo, def);
  hi = std::max(hi, def);
  return GainSpec{name, def, lo, hi, log && lo > 0, what};
}

// ---- p and pid -------------------------------------------------------------------------------

std::vector<GainSpec> p_specs(const ControllerPlant& pl, int i) {
  return {
      spec("kp_per_s", pl.servo[i].kp_per_s, 1, 3000, true, "proportional gain, mm/s per mm"),
      spec("velocity_ff", 0.0, 0, 2, false, "velocity feed-forward gain (1/g cancels the drive gain)"),
      spec("acceleration_ff_s", 0.0, 0, 0.1, false, "acceleration feed-forward time (the drive's tau)"),
      spec("friction_ff_mm_per_s", 0.0, 0, 20, false, "Coulomb friction feed-forward, mm/s along the reference"),
      spec("friction_ff_band_mm_per_s", 0.5, 0.01, 10, true, "reference speed over which the friction feed-forward ramps in"),
      spec("backlash_ff_mm", 0.0, 0, 0.05, false, "backlash feed-forward: motor travel added across a reversal, mm"),
      spec("observer_per_s", 0.0, 0, 1000, false, "bandwidth of the position observer between encoder counts, rad/s (0: off)"),
  };
}

// The drive model of axis i's position observer.
ObserverModel observer_model(const ControllerPlant& pl, int i) {
  ObserverModel m;
  m.period_s = pl.period_s;
  m.gain = pl.gain_factor[i];
  m.tau_s = pl.drive_time_constant_s[i];
  m.quantum_mm = pl.position_quantum_mm[i];
  m.coulomb_mm_per_s = pl.coulomb_friction_mm_per_s[i];
  m.backlash_mm = pl.backlash_mm[i];
  m.delay_ticks = std::min(pl.command_latency_ticks[i] + pl.reading_latency_ticks[i], ObserverModel::kMaxDelayTicks);
  return m;
}

std::array<ObserverModel, kAxes> observer_models(const ControllerPlant& pl) {
  std::array<ObserverModel, kAxes> m;
  for (int i = 0; i < kAxes; ++i) m[i] = observer_model(pl, i);
  return m;
}

std::vector<GainSpec> pid_specs(const ControllerPlant& pl, int i) {
  std::vector<GainSpec> s = p_specs(pl, i);
  s.insert(s.begin() + 1,
           {spec("ki_per_s2", pl.servo[i].ki_per_s2, 1, 1e5, true, "integral gain, mm/s per mm s"),
            spec("kd", pl.servo[i].kd, 0, 5, false, "derivative gain, mm/s per mm/s")});
  return s;
}

PidGains pid_gains(const Gains& g, const ControllerPlant& pl, int i) {
  PidGains p;
  p.kp_per_s = g.at("kp_per_s");
  p.ki_per_s2 = g.count("ki_per_s2") ? g.at("ki_per_s2") : 0.0;
  p.kd = g.count("kd") ? g.at("kd") : 0.0;
  p.velocity_ff = g.at("velocity_ff");
  p.acceleration_ff_s = g.at("acceleration_ff_s");
  p.friction_ff_mm_per_s = g.at("friction_ff_mm_per_s");
  p.friction_ff_band_mm_per_s = g.at("friction_ff_band_mm_per_s");
  p.backlash_ff_mm = g.at("backlash_ff_mm");
  p.observer_per_s = g.at("observer_per_s");
  p.following_error_limit_mm = pl.servo[i].following_error_limit_mm;
  return p;
}

template <const char* kName>
std::unique_ptr<Controller> make_pid(const AxisGains& g, const ControllerPlant& pl) {
  std::array<PidGains, kAxes> gains;
  for (int i = 0; i < kAxes; ++i) gains[i] = pid_gains(g[i], pl, i);
  auto c = std::make_unique<PidController>(kName);
  c->configure(gains, pl.output_limit_mm_per_s, pl.period_s, observer_models(pl));
  return c;
}
constexpr char kP[] = "p";
constexpr char kPid[] = "pid";

// ---- pid_ff ----------------------------------------------------------------------------------

std::vector<GainSpec> pid_ff_specs(const ControllerPlant& pl, int i) {
  const ServoGains& s = pl.servo[i];
  return {
      spec("kp_per_s", s.kp_per_s, 1, 3000, true, "proportional gain, mm/s per mm"),
      spec("ki_per_s2", s.ki_per_s2, 1, 1e5, true, "integral gain, mm/s per mm s"),
      spec("kd", s.kd, 0, 5, false, "derivative gain, mm/s per mm/s"),
      spec("velocity_ff", s.velocity_ff, 0, 3, false, "start of the adaptive velocity feed-forward gain"),
      spec("acceleration_ff_s", s.acceleration_ff_s, 0, 0.1, false, "acceleration feed-forward time"),
      spec("ff_adaptation_per_s2", s.ff_adaptation_per_s2, 0, 1e4, false, "feed-forward gain adaptation rate"),
  };
}

std::unique_ptr<Controller> make_pid_ff(const AxisGains& g, const ControllerPlant& pl) {
  std::array<ServoGains, kAxes> servo = pl.servo;
  for (int i = 0; i < kAxes; ++i) {
    servo[i].kp_per_s = g[i].at("kp_per_s");
    servo[i].ki_per_s2 = g[i].at("ki_per_s2");
    servo[i].kd = g[i].at("kd");
    servo[i].velocity_ff = g[i].at("velocity_ff");
    servo[i].acceleration_ff_s = g[i].at("acceleration_ff_s");
    servo[i].ff_adaptation_per_s2 = g[i].at("ff_adaptation_per_s2");
    servo[i].validate();
  }
  auto c = std::make_unique<PidFfController>();
  c->configure(servo, pl.output_limit_mm_per_s, pl.period_s);
  return c;
}

// ---- ccc -------------------------------------------------------------------------------------

std::vector<GainSpec> ccc_specs(const ControllerPlant& pl, int i) {
  std::vector<GainSpec> s = p_specs(pl, i);
  s.push_back(spec("ccc_kp_per_s", pl.servo[i].kp_per_s, 1, 5000, true, "contour loop gain Wp, mm/s per mm"));
  s.push_back(spec("ccc_ki_per_s2", 0.0, 0, 1e5, false, "contour loop integral gain Wi, mm/s per mm s"));
  s.push_back(spec("ccc_kd", 0.0, 0, 5, false, "contour loop derivative gain Wd, mm/s per mm/s"));
  return s;
}

std::unique_ptr<Controller> make_ccc(const AxisGains& g, const ControllerPlant& pl) {
  std::array<PidGains, kAxes> axial;
  for (int i = 0; i < kAxes; ++i) axial[i] = pid_gains(g[i], pl, i);
  ContourGains w;  // one contour loop: axis 0's values (the gains are the same on every axis)
  w.kp_per_s = g[0].at("ccc_kp_per_s");
  w.ki_per_s2 = g[0].at("ccc_ki_per_s2");
  w.kd = g[0].at("ccc_kd");
  auto c = std::make_unique<CrossCoupledController>();
  c->configure(axial, w, pl.output_limit_mm_per_s, pl.period_s, observer_models(pl));
  return c;
}

// ---- zpetc -----------------------------------------------------------------------------------

std::vector<GainSpec> zpetc_specs(const ControllerPlant& pl, int i) {
  return {
      spec("kp_per_s", pl.servo[i].kp_per_s, 1, 3000, true, "feedback loop gain, mm/s per mm"),
      spec("model_time_constant_s", pl.drive_time_constant_s[i], 1e-4, 0.5, true,
           "drive velocity-loop time constant of the inverted model (0: unknown, must be given)"),
      spec("model_gain", pl.gain_factor[i], 0.2, 2, false, "drive gain of the inverted model"),
      spec("zero_cancel_radius", 0.9, 0, 1, false, "model zeros at least this far from 0 are not cancelled"),
  };
}

std::unique_ptr<Controller> make_zpetc(const AxisGains& g, const ControllerPlant& pl) {
  std::array<ZpetcAxisOptions, kAxes> o;
  for (int i = 0; i < kAxes; ++i) {
    o[i].kp_per_s = g[i].at("kp_per_s");
    o[i].model_time_constant_s = g[i].at("model_time_constant_s");
    if (!(o[i].model_time_constant_s > 0))
      throw InputError::field("gains", "controller 'zpetc' needs the drive's time constant: the machine model gives "
                                       "none, so set model_time_constant_s");
    o[i].model_gain = g[i].at("model_gain");
    o[i].cancel_radius = g[i].at("zero_cancel_radius");
    o[i].latency_ticks = pl.command_latency_ticks[i] + pl.reading_latency_ticks[i];
    o[i].following_error_limit_mm = pl.servo[i].following_error_limit_mm;
  }
  auto c = std::make_unique<ZpetcController>();
  c->configure(o, pl.output_limit_mm_per_s, pl.period_s);
  return c;
}

// ---- flc -------------------------------------------------------------------------------------

// Defaults: the output spans the drive's range and the small-signal gain 1.35 Ku Ke equals the
// servo section's Kp, with a derivative time of 2 ms (Kde = 0.002 s Ke).
std::vector<GainSpec> flc_specs(const ControllerPlant& pl, int i) {
  const double ku = pl.output_limit_mm_per_s[i];
  const double ke = std::max(pl.servo[i].kp_per_s, 1.0) / (1.35 * ku);
  return {
      spec("ke_per_mm", ke, 1e-3, 1e3, true, "error scaling onto the fuzzy universe, 1/mm"),
      spec("kde_s_per_mm", 0.002 * ke, 1e-7, 10, true, "error-change scaling onto the fuzzy universe, s/mm"),
      spec("ku_mm_per_s", ku, 1, 1e4, true, "output scaling: the command at the universe's edge, mm/s"),
      spec("velocity_ff", 0.0, 0, 2, false, "velocity feed-forward gain"),
      spec("acceleration_ff_s", 0.0, 0, 0.1, false, "acceleration feed-forward time"),
      spec("ki_per_s", 0.0, 0, 1000, false, "integral of the fuzzy output, 1/s (0: none)"),
  };
}

std::unique_ptr<Controller> make_flc(const AxisGains& g, const ControllerPlant& pl) {
  std::array<FuzzyGains, kAxes> f;
  for (int i = 0; i < kAxes; ++i) {
    f[i].ke_per_mm = g[i].at("ke_per_mm");
    f[i].kde_s_per_mm = g[i].at("kde_s_per_mm");
    f[i].ku_mm_per_s = g[i].at("ku_mm_per_s");
    f[i].velocity_ff = g[i].at("velocity_ff");
    f[i].acceleration_ff_s = g[i].at("acceleration_ff_s");
    f[i].ki_per_s = g[i].at("ki_per_s");
    f[i].following_error_limit_mm = pl.servo[i].following_error_limit_mm;
  }
  auto c = std::make_unique<FuzzyController>();
  c->configure(f, pl.output_limit_mm_per_s, pl.period_s);
  return c;
}

// ---- the table -------------------------------------------------------------------------------

const Kind kKinds[] = {
    {{"p"}, p_specs, make_pid<kP>},
    {{"pid"}, pid_specs, make_pid<kPid>},
    {{"pid_ff", "pid-ff"}, pid_ff_specs, make_pid_ff},
    {{"zpetc"}, zpetc_specs, make_zpetc},
    {{"ccc"}, ccc_specs, make_ccc},
    {{"flc"}, flc_specs, make_flc},
};

constexpr std::size_t kKindCount = std::size(kKinds);

std::array<Spelling, kKindCount> kind_names() {
  std::array<Spelling, kKindCount> names;
  for (std::size_t i = 0; i < kKindCount; ++i) names[i] = kKinds[i].name;
  return names;
}

// A library caller's old spelling is accepted without the note.
const Kind& find_kind(std::string_view name) {
  return kKinds[parse_name(kind_names(), name, "controller", "controller").value];
}

}  // namespace

void ControllerPlant::validate() const {
  require_field(std::isfinite(period_s) && period_s > 0, "period_s", period_s, "must be > 0");
  for (int i = 0; i < kAxes; ++i) {
    const auto at = [i](const char* field) { return fmt::format("{}[{}]", field, i); };
    require_field(std::isfinite(output_limit_mm_per_s[i]) && output_limit_mm_per_s[i] > 0, at("output_limit_mm_per_s"),
                  output_limit_mm_per_s[i], "must be > 0");
    require_field(std::isfinite(drive_time_constant_s[i]) && drive_time_constant_s[i] >= 0, at("drive_time_constant_s"),
                  drive_time_constant_s[i], "must be >= 0 (0: unknown)");
    require_field(std::isfinite(gain_factor[i]) && gain_factor[i] > 0, at("gain_factor"), gain_factor[i], "must be > 0");
    require_field(command_latency_ticks[i] >= 0, at("command_latency_ticks"), command_latency_ticks[i], "must be >= 0");
    require_field(reading_latency_ticks[i] >= 0, at("reading_latency_ticks"), reading_latency_ticks[i], "must be >= 0");
    require_field(std::isfinite(position_quantum_mm[i]) && position_quantum_mm[i] >= 0, at("position_quantum_mm"),
                  position_quantum_mm[i], "must be >= 0 (0: unknown)");
    require_field(std::isfinite(backlash_mm[i]) && backlash_mm[i] >= 0, at("backlash_mm"), backlash_mm[i],
                  "must be >= 0 (0: none or unknown)");
    require_field(std::isfinite(coulomb_friction_mm_per_s[i]) && coulomb_friction_mm_per_s[i] >= 0,
                  at("coulomb_friction_mm_per_s"), coulomb_friction_mm_per_s[i], "must be >= 0 (0: unknown)");
  }
}

std::vector<std::string> controller_kinds() {
  std::vector<std::string> v;
  for (const Kind& k : kKinds) v.emplace_back(k.name.name);
  return v;
}

Parsed<std::string> parse_controller_kind(std::string_view text, const char* field) {
  const Parsed<std::size_t> p = parse_name(kind_names(), text, field, "controller");
  return {std::string(kKinds[p.value].name.name), p.note};
}

std::vector<GainSpec> gain_specs(const std::string& kind, const ControllerPlant& plant) {
  return find_kind(kind).specs(plant, 0);
}

std::unique_ptr<Controller> make_controller(const std::string& kind, const Gains& gains, const ControllerPlant& plant) {
  const Kind& k = find_kind(kind);
  plant.validate();
  AxisGains resolved;
  for (int i = 0; i < kAxes; ++i) {
    const std::vector<GainSpec> specs = k.specs(plant, i);
    for (const GainSpec& s : specs) resolved[i][s.name] = s.default_value;
    for (const auto& given : gains) {
      const std::string& name = given.first;
      const double value = given.second;
      const auto s = std::find_if(specs.begin(), specs.end(), [&](const GainSpec& x) { return x.name == name; });
      if (s == specs.end()) {
        std::string all;
        for (const GainSpec& x : specs) all += (all.empty() ? "" : ", ") + x.name;
        throw InputError::field("gains", fmt::format("controller '{}' has no gain '{}' (its gains: {})", kind,
                                                     excerpt(name), all));
      }
      if (!(std::isfinite(value) && value >= s->min_value && value <= s->max_value))
        throw InputError::field("gains", fmt::format("{} = {} is outside [{}, {}] for controller '{}'", name, value,
                                                     s->min_value, s->max_value, kind));
      resolved[i][name] = value;
    }
  }
  try {
    std::unique_ptr<Controller> c = k.make(resolved, plant);
    c->reset();
    return c;
  } catch (const InputError& e) {
    // A combination of gains that the controller's own validation refuses.
    if (!e.is_field()) throw;
    throw InputError::field("gains", fmt::format("controller '{}': {}", kind, e.what()));
  }
}

void parse_gain(const std::string& text, Gains& gains, const std::string& field) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw InputError::field(field, fmt::format("'{}': expected NAME=VALUE", excerpt(text)));
  const std::string name = text.substr(0, eq), num = text.substr(eq + 1);
  const std::optional<double> v = parse_finite(num);
  if (!v) throw InputError::field(field, fmt::format("'{}': '{}' is not a finite number", excerpt(text), excerpt(num)));
  if (!gains.emplace(name, *v).second) throw InputError::field(field, fmt::format("gain '{}' given twice", excerpt(name)));
}

}  // namespace machplan::control
