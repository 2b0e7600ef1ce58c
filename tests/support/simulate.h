// A job run once on a fresh machine session over the simulator (solvers/session/
// machine_session.h): the machine as loaded (or changed) by the test, the executor's options,
// the simulator's options (seed, faults, operator timeline; it starts at the job's start) and
// the run's parts (source, filter, controller, termination, progress).
#pragma once

#include <utility>

#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/session/machine_session.h"

namespace machplan::test {

inline executor::ExecutionResult simulate(const cutting::MachineConfig& machine, const motion::Job& job,
                                          const executor::Trajectories& trajectories,
                                          const executor::ExecutorOptions& options, const sim::SimOptions& sim = {},
                                          const session::MachineSession::RunHooks& hooks = {}) {
  session::MachineSessionOptions so;
  so.machine_config = machine;
  so.backend.sim = sim;
  so.executor = options;
  session::MachineSession s(std::move(so));
  return s.run(job, trajectories, hooks);
}

}  // namespace machplan::test
