#include "models/backends/backend_factory.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "engine/common/error.h"

namespace machplan::backends {

std::vector<std::string> backend_names() { return {"sim", "hal"}; }

namespace {

hardware::HalOptions hal_options(const cutting::MachineConfig& m, hardware::HalOptions o) {
  const executor::MachineSetup setup = m.setup();
  o.period_s = m.servo_period_s;
  for (int i = 0; i < hardware::kAxes; ++i) o.signals[i] = setup.signals[i];
  o.torch = setup.torch.kind != executor::TorchSetup::Kind::none;
  o.arc_ok_signal = setup.torch.kind == executor::TorchSetup::Kind::plasma;
  o.torch_height = setup.torch.height_axis;
  return o;
}

}  // namespace

void BackendOptions::validate() const {
  const std::vector<std::string> names = backend_names();
  if (std::find(names.begin(), names.end(), name) == names.end())
    throw InputError::field("name", fmt::format("unknown backend '{}' (known: {})", excerpt(name), fmt::join(names, ", ")));
  validate_member("sim", sim);
  if (name == "hal") validate_member("hal", hal);
}

std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o) {
  o.validate();
  if (o.name == "hal") return std::make_unique<hardware::HalBackend>(hal_options(machine, o.hal));
  MACHPLAN_ASSERT(o.name == "sim", "backend '{}' is in backend_names() but make_backend() does not build it", o.name);
  return std::make_unique<sim::SimBackend>(machine, o.sim);
}

}  // namespace machplan::backends
