#include "models/backends/backend_factory.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "engine/common/error.h"

namespace machplan::backends {

// MACHPLAN_HAL_BACKEND is 1 when this build has the HAL backend (models/CMakeLists.txt).
std::vector<std::string> backend_names() {
#if MACHPLAN_HAL_BACKEND
  return {"sim", "hal"};
#else
  return {"sim"};
#endif
}

namespace {

#if MACHPLAN_HAL_BACKEND

hardware::HalOptions hal_options(const cutting::MachineConfig& m, hardware::HalOptions o) {
  const executor::MachineSetup setup = m.setup();
  o.period_s = m.servo_period_s;
  for (int i = 0; i < hardware::kAxes; ++i) o.signals[i] = setup.signals[i];
  o.torch = setup.torch.kind != executor::TorchSetup::Kind::none;
  o.arc_ok_signal = setup.torch.kind == executor::TorchSetup::Kind::plasma;
  o.torch_height = setup.torch.height_axis;
  return o;
}
#endif

}  // namespace

void BackendOptions::validate() const {
  const std::vector<std::string> names = backend_names();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    if (name == "hal")
      throw InputError::field("name", fmt::format("this machplan was built without LinuxCNC's HAL (MACHPLAN_HAL=OFF, or "
                                                  "LinuxCNC not found when it was built): no 'hal' backend (known: {})",
                                                  fmt::join(names, ", ")));
    throw InputError::field("name", fmt::format("unknown backend '{}' (known: {})", excerpt(name), fmt::join(names, ", ")));
  }
  validate_member("sim", sim);
#if MACHPLAN_HAL_BACKEND
  if (name == "hal") validate_member("hal", hal);
#endif
  // What only a simulated machine does: another backend would silently go without it.
  if (name != "sim") {
    const auto refuse = [&](const char* field, const std::string& what, const char* rule) {
      throw InputError::field(field, fmt::format("{}: {} on the simulator only (backend sim), not on backend {}", what, rule, name));
    };
    if (!sim.faults.empty())
      refuse("sim.faults", fmt::format("{} at {:g} s", sim::to_string(sim.faults.front().kind), sim.faults.front().at_s),
             "faults are injected");
    if (!sim.operator_events.empty())
      refuse("sim.operator_events",
             fmt::format("events from {:g} s to {:g} s", sim.operator_events.front().at_s, sim.operator_events.back().at_s),
             "a timeline of operator events plays");
    if (sim.sheet_warp_mm)
      refuse("sim.sheet_warp_mm", fmt::format("{:g} mm over {:g} mm", sim.sheet_warp_mm->first, sim.sheet_warp_mm->second),
             "the sheet's warp is simulated");
    if (sim.sheet_map) refuse("sim.sheet_map", sim.sheet_map->source, "the sheet's height map is simulated");
  }
}

std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o) {
  o.validate();
#if MACHPLAN_HAL_BACKEND
  if (o.name == "hal") return std::make_unique<hardware::HalBackend>(hal_options(machine, o.hal));
#endif
  MACHPLAN_ASSERT(o.name == "sim", "backend '{}' is in backend_names() but make_backend() does not build it", o.name);
  return std::make_unique<sim::SimBackend>(machine, o.sim);
}

}  // namespace machplan::backends
