#include "models/sim/simulate.h"

namespace machplan::sim {

executor::ExecutionResult simulate(const cutting::MachineConfig& machine, const motion::Job& job,
                                   const executor::Trajectories& trajectories, const executor::ExecutorOptions& options,
                                   const SimOptions& sim, const std::function<void(SimBackend&)>& prepare,
                                   const executor::RunParts& parts) {
  SimOptions so = sim;
  so.start_mm = job.start_mm;
  SimBackend backend(machine, so);
  if (prepare) prepare(backend);
  executor::Executor ex(machine.setup(), options);
  return ex.run(job, trajectories, backend, parts);
}

}  // namespace machplan::sim
