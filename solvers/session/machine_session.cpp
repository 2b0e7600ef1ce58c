#include "solvers/session/machine_session.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "models/cutting/controller_plant.h"
#include "solvers/calibration/apply.h"
#include "solvers/session/tuning_store.h"

namespace machplan::session {

bool paper_mode(executor::Mode mode) { return mode == executor::Mode::paper_open || mode == executor::Mode::paper_closed; }

std::string paper_mode_lacks(const hardware::OperatorInputs& in) {
  if (in.feed_hold) return "a feed hold";
  if (in.cycle_start) return "a cycle start";
  if (in.feed_override_pct != 100.0) return fmt::format("a feed override of {:g} %", in.feed_override_pct);
  if (in.rapid_override_pct != 100.0) return fmt::format("a rapid override of {:g} %", in.rapid_override_pct);
  if (in.paused_motion_mm != 0.0) return fmt::format("a paused motion of {:g} mm", in.paused_motion_mm);
  if (in.paused_motion_speed != 0.0) return fmt::format("a paused motion at {:g} of its speed", in.paused_motion_speed);
  return {};
}

void MachineSessionOptions::validate() const {
  if (!machine_config && machine.empty()) throw InputError::field("machine", "names no machine");
  if (controller.empty() && !gains.empty())
    throw InputError::field("gains", "gains need a controller kind");
  if (!controller.empty() && controller != "tuned") control::parse_controller_kind(controller);
  if (calibration && active_calibration)
    throw InputError::field("calibration", "a calibration is given and the active one is asked for: choose one");
  const bool paper = paper_mode(executor.mode);
  if (paper && (calibration || active_calibration) && !(std::isfinite(paper_feed_mm_per_s) && paper_feed_mm_per_s > 0))
    throw InputError::field("paper_feed_mm_per_s",
                            "a calibration in the paper modes needs the feed: the open-loop factor depends on it");
  // The paper modes' own settings: another mode would silently ignore them. (Their defaults
  // are every mode's.)
  const executor::ExecutorOptions defaults;
  if (!paper && executor.blu_mm != defaults.blu_mm)
    throw InputError::field("executor.blu_mm", fmt::format("{} mm: a vector length applies to the paper modes only (mode "
                                                           "paper-open or paper-closed), not to mode {}",
                                                           executor.blu_mm, executor::to_string(executor.mode)));
  if (!paper && executor.calibration_factor != defaults.calibration_factor)
    throw InputError::field("executor.calibration_factor",
                            fmt::format("{}: a factor applies to the paper modes only (mode paper-open or paper-closed); "
                                        "mode {} takes the machine's active calibration instead",
                                        executor.calibration_factor, executor::to_string(executor.mode)));
  if (paper)
    for (const hardware::OperatorEvent& e : backend.sim.operator_events)
      if (const std::string lacks = paper_mode_lacks(e.inputs); !lacks.empty())
        throw InputError::field("backend.sim.operator_events", fmt::format("{} at {:g} s: {}", lacks, e.at_s, kPaperModesLack));
  validate_member("executor", executor);
  validate_member("backend", backend);
}

struct MachineSession::Impl {
  MachineSessionOptions o;
  cutting::MachineConfig machine;
  executor::MachineSetup setup;
  control::ControllerPlant plant;
  std::optional<calibration::StoredFit> calibration;
  std::string controller_name = "pid_ff";
  std::unique_ptr<control::Controller> controller;
  std::optional<executor::Executor> executor;
  std::unique_ptr<hardware::Backend> backend;
  hardware::OperatorChannel channel;
  Latest<executor::LiveState> live;
  std::unique_ptr<hardware::OperatorMerge> merged;
  std::unique_ptr<executor::TraceStream> trace;

  std::string store() const { return o.store_path.empty() ? calibration::default_store_path() : o.store_path; }
  executor::RunParts parts(const RunHooks& h);
};

executor::RunParts MachineSession::Impl::parts(const RunHooks& h) {
  executor::RunParts p;
  p.source = h.source;
  p.filter = h.filter;
  p.controller = h.controller ? h.controller : controller.get();
  p.termination = h.termination;
  p.progress = h.progress;
  p.expected_s = h.expected_s;
  p.live = &live;
  if (!o.trace_csv_path.empty()) {
    trace = std::make_unique<executor::TraceStream>(o.trace_csv_path);
    p.trace_stream = trace.get();
  }
  return p;
}

MachineSession::MachineSession(MachineSessionOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  options.validate();
  m.o = std::move(options);
  m.machine = m.o.machine_config ? *m.o.machine_config : cutting::load_machine(cutting::find_machine(m.o.machine));
  m.setup = m.machine.setup();

  // The calibration: given, or the machine's active one.
  if (m.o.calibration) m.calibration = m.o.calibration;
  if (m.o.active_calibration) {
    m.calibration = calibration::CalibrationStore(m.store()).active(m.machine.name);
    if (!m.calibration)
      throw InputError::field("active_calibration", fmt::format("no active calibration for '{}' in {}", m.machine.name, m.store()));
  }
  executor::ExecutorOptions eo = m.o.executor;
  if (m.calibration) {
    const bool paper = paper_mode(eo.mode);
    // Paper modes: the open-loop factor for the feed; otherwise the whole fit, applied to the
    // executor's setup.
    if (paper) eo.calibration_factor = calibration::open_loop_factor(*m.calibration, m.o.paper_feed_mm_per_s);
    else m.setup = calibration::apply_calibration(m.setup, *m.calibration);
  }
  m.plant = cutting::controller_plant(m.machine);
  m.plant.servo = m.setup.servo;  // with the calibration, when one is applied

  // The controller: given, or the machine's active tuning (a given gain overrides a stored one).
  std::string kind = m.o.controller;
  control::Gains gains = m.o.gains;
  if (kind == "tuned") {
    const auto t = tuning::TuningStore(m.store()).active(m.machine.name);
    if (!t)
      throw InputError::field("controller",
                              fmt::format("no active tuning for '{}' in {}: none has been stored for this machine (machplan "
                                          "tune stores one)",
                                          m.machine.name, m.store()));
    kind = t->controller;
    gains = t->gains;
    for (const auto& [name, value] : m.o.gains) gains[name] = value;
  }
  if (!kind.empty()) {
    m.controller = control::make_controller(control::parse_controller_kind(kind).value, gains, m.plant);
    m.controller_name = m.controller->name();
  }
  m.executor.emplace(m.setup, eo);
}

MachineSession::~MachineSession() = default;

const cutting::MachineConfig& MachineSession::machine() const { return impl_->machine; }
const executor::MachineSetup& MachineSession::setup() const { return impl_->setup; }
const control::ControllerPlant& MachineSession::plant() const { return impl_->plant; }
const std::optional<calibration::StoredFit>& MachineSession::calibration() const { return impl_->calibration; }
const std::string& MachineSession::controller_name() const { return impl_->controller_name; }
const executor::ExecutorOptions& MachineSession::executor_options() const { return impl_->executor->options(); }
hardware::OperatorChannel& MachineSession::operator_inputs() { return impl_->channel; }
Latest<executor::LiveState>& MachineSession::live() { return impl_->live; }
bool MachineSession::backend_open() const { return impl_->backend != nullptr; }

hardware::Backend& MachineSession::backend(const Eigen::Vector2d& start_mm) {
  Impl& m = *impl_;
  if (!m.backend) {
    backends::BackendOptions bo = m.o.backend;
    bo.sim.start_mm = start_mm;
    bo.hal.start_mm = start_mm;  // a position-mode machine must stand there
    m.backend = backends::make_backend(m.machine, bo);
    m.merged = std::make_unique<hardware::OperatorMerge>(*m.backend, m.channel);
  }
  return *m.merged;
}

executor::ExecutionResult MachineSession::run(const motion::Job& job, const executor::Trajectories& trajectories,
                                              const RunHooks& hooks) {
  hardware::Backend& be = backend(job.start_mm);
  return impl_->executor->run(job, trajectories, be, impl_->parts(hooks));
}

std::unique_ptr<executor::Session> MachineSession::start(const motion::Job& job, const executor::Trajectories& trajectories,
                                                         const RunHooks& hooks) {
  hardware::Backend& be = backend(job.start_mm);
  return std::make_unique<executor::Session>(*impl_->executor, job, trajectories, be, impl_->parts(hooks));
}

}  // namespace machplan::session
