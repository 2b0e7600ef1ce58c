// The machine session: the one place that builds the rig a job runs on. Every caller that
// drives a machine (`machplan run`, the tuning's evaluations, the guard's roughing and
// finishing, `calibrate record`, the web panel, the tests) asks a MachineSession for it;
// nothing else constructs a backend and an executor together.
//
//   machine      a bundled name or a YAML path (cutting::find_machine), loaded once; or a
//                machine the caller already holds (tuning varies its drive gain; the paper
//                modes count the encoders x1)
//   calibration  none, the machine's active one in the store, or one given: applied to the
//                executor's setup (feed-forward start, backlash compensation, encoder scale);
//                in the paper modes it gives the open-loop factor for a feed instead
//   controller   a kind and gains (engine/control/controller_factory.h), or "tuned": the
//                machine's active tuning in the store, its gains overridden by any given
//   backend      by name through the factory (models/backends/backend_factory.h), opened on
//                first use; it stays open for the session's life, so jobs run one after the
//                other on the same machine (a simulator keeps its state between them)
//   operator     the operator's inputs from any thread (a keyboard, the panel, a script):
//                merged into the backend's own inputs at every exchange, so they reach the
//                executor as every other signal does, sampled each period
//   trace        streamed to a CSV file during each run, when asked
//
// A run takes its Termination (stop request, deadline in machine time, budget of periods) and
// Progress from the caller; run() goes to the end of the job or the first fault, start()
// hands the caller an executor::Session to tick itself (the guard's jog sessions).
//
// Errors: a bad machine, store, controller or option throws InputError before anything
// opens (fields named as in MachineSessionOptions); a backend that disagrees with the machine
// file throws InputError when it opens. Once a run has started nothing throws: faults are in
// the result. The rules that tie one option to another live in validate(), so that every
// caller (the command line, the panel, a library) meets the same refusal: the paper modes'
// settings (blu_mm, calibration_factor) outside the paper modes, a paper mode asked for a feed
// hold, override or recovery (paper_mode_lacks()), a calibration in a paper mode without its
// feed; what only the simulator does is refused on another backend by BackendOptions.
//
// Threading: one thread runs jobs; operator() may be written from any thread.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "engine/common/progress.h"
#include "engine/common/termination.h"
#include "engine/control/controller_factory.h"
#include "engine/executor/executor.h"
#include "engine/hardware/operator_channel.h"
#include "models/backends/backend_factory.h"
#include "models/cutting/machine_config.h"
#include "solvers/calibration/store.h"

namespace machplan::session {

struct MachineSessionOptions {
  // A bundled machine name or a machine YAML path. Ignored when `machine_config` is set.
  std::string machine = "thermal_gantry";
  // A machine the caller has loaded (and maybe changed); wins over `machine`.
  std::optional<cutting::MachineConfig> machine_config;

  // The backend by name and its own options (the simulator's seed, pacing, injected faults,
  // operator timeline). The simulator starts where the first job starts.
  backends::BackendOptions backend;

  // The servo controller: "" for the executor's default (pid_ff on the machine's servo
  // section), a kind of control::controller_kinds(), or "tuned" for the machine's active
  // tuning in the store. `gains` override the defaults (or the stored gains); gains without a
  // kind are refused.
  std::string controller;
  control::Gains gains;

  // The calibration: a given one, or the machine's active one in the store.
  std::optional<calibration::StoredFit> calibration;
  bool active_calibration = false;
  // Paper modes with a calibration: the feed whose open-loop factor the executor uses, mm/s
  // (the paper measured one factor per feed). Needed then; ignored otherwise.
  double paper_feed_mm_per_s = 0.0;

  // The store of calibrations and tunings; "" for the default (calibration::default_store_path).
  std::string store_path;

  // Mode, supervision, trace in memory.
  executor::ExecutorOptions executor;
  // When set, each run's trace is streamed to this CSV file.
  std::string trace_csv_path;

  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// The paper modes' BLU vectors run a stretch at one speed from its first vector to its last:
// they have no feed hold, cycle start, override or cut recovery. What `inputs` asks of those
// ("a feed hold", "a feed override of 50 %", ...), "" when it asks nothing the paper modes
// lack (stop, THC and the E-stop they take). kPaperModesLack is the rule, for messages.
std::string paper_mode_lacks(const hardware::OperatorInputs& inputs);
inline constexpr const char* kPaperModesLack =
    "the paper modes take no feed hold, override or recovery (only stop and thc)";
// paper-open or paper-closed.
bool paper_mode(executor::Mode mode);

class MachineSession {
 public:
  // Loads the machine, the calibration and the tuning the options name and makes the
  // controller; opens nothing yet.
  explicit MachineSession(MachineSessionOptions options);
  ~MachineSession();
  MachineSession(const MachineSession&) = delete;
  MachineSession& operator=(const MachineSession&) = delete;

  const cutting::MachineConfig& machine() const;
  // The executor's view of the machine, the calibration applied.
  const executor::MachineSetup& setup() const;
  // The controller's model of the machine (its servo section with the calibration applied).
  const control::ControllerPlant& plant() const;
  const std::optional<calibration::StoredFit>& calibration() const;
  // The servo controller's kind ("pid_ff" for the default).
  const std::string& controller_name() const;
  const executor::ExecutorOptions& executor_options() const;

  // The backend, opened on first use (a simulator at `start_mm`; a real machine is where it
  // is). Throws InputError when it cannot open or disagrees with the machine file.
  hardware::Backend& backend(const Eigen::Vector2d& start_mm = Eigen::Vector2d::Zero());
  bool backend_open() const;

  // The operator's inputs, merged into the backend's at every exchange (engine/hardware/
  // operator_channel.h). Any thread.
  hardware::OperatorChannel& operator_inputs();
  // The machine's state, published by the running job's tick every period (engine/executor/
  // live_state.h); any thread may read it.
  Latest<executor::LiveState>& live();

  // What a run is made of beyond the session's own parts.
  struct RunHooks {
    executor::SetpointSource* source = nullptr;   // default: the one the mode names
    executor::DemandFilter* filter = nullptr;     // between source and controller (the guard)
    control::Controller* controller = nullptr;    // this run only (a tuning candidate)
    Termination* termination = nullptr;           // stop request, deadline, budget
    Progress* progress = nullptr;
    double expected_s = 0.0;                      // the job's expected machine time, s
  };

  // Runs `job` on the backend (opened at job.start_mm if it is not yet) to its end, a fault
  // or its termination. `trajectories` as executor::Executor::run.
  executor::ExecutionResult run(const motion::Job& job, const executor::Trajectories& trajectories,
                                const RunHooks& hooks);
  executor::ExecutionResult run(const motion::Job& job, const executor::Trajectories& trajectories) {
    return run(job, trajectories, RunHooks{});
  }
  // The same, tick by tick: the caller calls tick() until it returns false, then finish().
  // The session must outlive the returned object, and runs nothing else meanwhile.
  std::unique_ptr<executor::Session> start(const motion::Job& job, const executor::Trajectories& trajectories,
                                           const RunHooks& hooks);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace machplan::session
