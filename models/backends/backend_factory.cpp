#include "models/backends/backend_factory.h"

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

std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o) {
  if (o.name == "sim") return std::make_unique<sim::SimBackend>(machine, o.sim);
  if (o.name == "hal") return std::make_unique<hardware::HalBackend>(hal_options(machine, o.hal));
  throw InputError("--backend", 0,
                   fmt::format("unknown backend '{}' (known: {})", o.name, fmt::join(backend_names(), ", ")));
}

}  // namespace machplan::backends
