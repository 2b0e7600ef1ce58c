#include "models/sim/simulate.h"

namespace machplan::sim {

executor::ExecutionResult simulate(const cutting::MachineConfig& machine, const motion::Job& job,
                                   const executor::Trajectories& trajectories, const executor::ExecutorOptions& options,
                                   const std::function<void(SimBackend&)>& prepare) {
  SimOptions so;
  so.seed = options.seed;
  so.realtime = options.realtime;
  so.start_mm = job.start_mm;
  SimBackend backend(machine, so);
  if (prepare) prepare(backend);
  executor::Executor ex(machine.setup(), options);
  return ex.run(job, trajectories, backend);
}

}  // namespace machplan::sim
