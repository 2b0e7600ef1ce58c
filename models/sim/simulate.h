// One call to run a job on the simulated machine: builds the SimBackend from the machine file's
// numbers (its own options: seed, pacing, injected faults, operator inputs; start at
// job.start_mm) and runs the executor on it.
#pragma once

#include <functional>

#include "engine/executor/executor.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"

namespace machplan::sim {

// `prepare` (optional) sees the backend before the run, e.g. to inject faults.
executor::ExecutionResult simulate(const cutting::MachineConfig& machine, const motion::Job& job,
                                   const executor::Trajectories& trajectories, const executor::ExecutorOptions& options,
                                   const SimOptions& sim = {}, const std::function<void(SimBackend&)>& prepare = {},
                                   const executor::RunParts& parts = {});

}  // namespace machplan::sim
