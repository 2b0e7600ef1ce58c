// Backends by name: the one place that knows which backends exist. `machplan run --backend
// NAME` and every caller that runs a machine ask here; a new backend (a fieldbus drive) is one
// more entry in make_backend() and in backend_names(), and one more line in the contract test
// suite (tests/hardware/backend_contract_test.cpp).
//
//   sim  the simulated machine (models/sim/sim_backend.h)
//   hal  a machine through LinuxCNC's HAL (engine/hardware/hal_backend.h): the machine file
//        gives the servo period, the axis signals and which torch pins must be linked. Only in
//        a build with the HAL backend (MACHPLAN_HAL); without it, asking for "hal" is an
//        InputError that says this build has no HAL.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "engine/hardware/backend.h"
#include "engine/hardware/hal_backend.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"

namespace machplan::backends {

struct BackendOptions {
  std::string name = "sim";  // one of backend_names()
  sim::SimOptions sim;       // for "sim"
  // For "hal": the connection's own settings; make_backend() fills in what the machine file
  // says (period, axis signals, torch pins).
  hardware::HalOptions hal;
  // Throws InputError naming the field: an unknown name (listing the known backends), a
  // field of the simulator's options ("sim.faults"), or what only the simulator does (injected
  // faults, an operator timeline, a warped sheet) asked of another backend.
  void validate() const;
};

std::vector<std::string> backend_names();  // the backends this build has
// Throws InputError::field("name", ...) naming the known backends when `o.name` is unknown.
std::unique_ptr<hardware::Backend> make_backend(const cutting::MachineConfig& machine, const BackendOptions& o);

}  // namespace machplan::backends
