#include "models/backends/backend_factory.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "engine/common/error.h"

namespace machplan::backends {

std::vector<std::string> backend_names() { return {"sim"}; }

void BackendOptions::validate() const {
  const std::vector<std::string> names = backend_names();
  if (std::find(names.begin(), names.end(), name) == names.end())
    throw InputError::field("name", fmt::format("unknown backend '{}' (known: {})", excerpt(name), fmt::join(names, ", ")));
  validate_member("sim", sim);
}

std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o) {
  o.validate();
  MACHPLAN_ASSERT(o.name == "sim", "backend '{}' is in backend_names() but make_backend() does not build it", o.name);
  return std::make_unique<sim::SimBackend>(machine, o.sim);
}

}  // namespace machplan::backends
