#include "models/backends/backend_factory.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "engine/common/error.h"

namespace machplan::backends {

std::vector<std::string> backend_names() { return {"sim"}; }

std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o) {
  if (o.name == "sim") return std::make_unique<sim::SimBackend>(machine, o.sim);
  throw InputError("--backend", 0,
                   fmt::format("unknown backend '{}' (known: {})", o.name, fmt::join(backend_names(), ", ")));
}

}  // namespace machplan::backends
