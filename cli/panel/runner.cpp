// The panel's runner thread (cli/panel/panel.h): jobs, frames, jog sessions and guard sessions
// on the machine session, one at a time, and how each ended.
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "cli/json/cut_order_json.h"
#include "cli/json/run.h"
#include "cli/panel/panel.h"
#include "engine/common/error.h"
#include "engine/common/stop.h"
#include "engine/common/summary.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/supervisor.h"
#include "solvers/motion/from_line.h"

namespace machplan::panel {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

// How a run ended, in Summary's spelling: the one place the panel reads it from a run.
std::string ending_of(const motion::RunOutcome& r) { return to_string(r.summary.status); }

// A stop asked for (the stop button, a stop request) ends a run as cancelled: it is the run's
// ending, not a fault of the machine to show in the fault banner.
bool a_stop(executor::FaultKind k) { return k == executor::FaultKind::stop_requested || k == executor::FaultKind::operator_stop; }

}  // namespace

// ---- the runner -------------------------------------------------------------------------------

void Panel::runner_loop() {
  for (;;) {
    Command c;
    std::optional<int> from_line;
    {
      std::unique_lock<std::mutex> lock(cmd_mutex_);
      cmd_cv_.wait(lock, [&] { return cmd_ != Command::none; });
      c = cmd_;
      from_line = cmd_from_line_;
      if (c == Command::quit) return;
    }
    try {
      switch (c) {
        case Command::run: run_job(from_line); break;
        case Command::frame: run_frame(); break;
        case Command::jog: run_jog(); break;
        case Command::guard: run_guard_session(); break;
        case Command::none:
        case Command::quit: break;
      }
    } catch (const std::exception& e) {
      // Planning a job again (a run from a line, a run after a change of origin) can be
      // stopped (the E-stop, the stop button) or find the job cannot be done.
      const bool cancelled = dynamic_cast<const Cancelled*>(&e) != nullptr;
      const bool infeasible = !cancelled && dynamic_cast<const Infeasible*>(&e) != nullptr;
      const std::lock_guard<std::mutex> lock(job_mutex_);
      last_end_ = to_string(cancelled ? Status::cancelled : infeasible ? Status::infeasible : Status::faulted);
      last_fault_json_ = cancelled ? json::array()
                                   : json::array({{{"kind", "error"}, {"message", clean(e.what())}, {"line", 0}}});
    }
    {
      const std::lock_guard<std::mutex> lock(stop_mutex_);
      current_stop_ = nullptr;
    }
    planning_ = false;
    {
      const std::lock_guard<std::mutex> lock(op_mutex_);
      op_.stop = op_.feed_hold = op_.cycle_start = false;  // buttons held for this activity are let go
      publish_inputs();
    }
    {
      const std::lock_guard<std::mutex> lock(cmd_mutex_);
      if (cmd_ != Command::quit) cmd_ = Command::none;
      activity_ = Activity::idle;
    }
    if (c == Command::run || c == Command::frame) ++runs_finished_;
  }
}

bool Panel::quitting() {
  const std::lock_guard<std::mutex> lock(cmd_mutex_);
  return cmd_ == Command::quit;
}

void Panel::run_job(std::optional<int> from_line) {
  Termination t;
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    current_stop_ = &t;
  }
  std::optional<motion::PlannedRun> plan;
  motion::Job programmed;
  std::string path;
  JobRequest request;
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    if (!from_line && plan_) plan = std::move(plan_);
    plan_.reset();
    programmed = programmed_;
    path = job_path_;
    request = job_request_;
    last_fault_json_ = json::array();
    last_end_ = "running";
  }
  const motion::RunOptions options = job_options(request, request.materials);
  if (!plan) {
    // Again (a job runs more than once), or from a line.
    planning_ = true;
    if (from_line) {
      plan.emplace(motion::plan_job(job_from_line(programmed, *from_line), options, session_->machine(), {&t, nullptr, nullptr}));
    } else {
      plan.emplace(motion::plan_program(path, options, session_->machine(), {&t, nullptr, nullptr}));
    }
    planning_ = false;
  }
  run_plan(std::move(*plan), options, t, json(), path);
}

void Panel::run_frame() {
  Termination t;
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    current_stop_ = &t;
  }
  std::optional<motion::PlannedRun> plan;
  json frame;
  JobRequest request;
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    plan = std::move(frame_plan_);
    frame_plan_.reset();
    frame = frame_json_;
    request = job_request_;
    last_fault_json_ = json::array();
    last_end_ = "running";
  }
  if (!plan) return;
  run_plan(std::move(*plan), job_options(request, request.materials), t, frame);
}

void Panel::run_plan(motion::PlannedRun plan, const motion::RunOptions& options, Termination& t, const json& frame,
                     const std::string& record_program) {
  if (session_->backend_open()) {
    // Where the machine stands: the last setpoint, which the servo holds. The measured position
    // differs from it by the servo's error at rest, and after a job that ends at the travel's
    // corner it may lie a hundredth of a millimetre outside the travel, where no rapid starts.
    const Eigen::Vector2d at = session_->live().read().commanded_mm;
    if ((plan.job.start_mm - at).norm() > 0.01 && !move_to(at, plan.job.start_mm, t)) return;
  }
  motion::RunOutcome outcome = motion::execute(*session_, std::move(plan), options, {&t, nullptr, nullptr});
  json j = cli::to_json(outcome);
  j["cut_order"] = cli::cut_order_json(outcome.cut_order);
  if (!frame.is_null()) j["frame"] = frame;
  auto text = std::make_shared<const std::string>(j.dump(-1, ' ', false, json::error_handler_t::replace));
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    report_ = std::move(text);
  }
  record_end(ending_of(outcome), outcome.result.faults);
  if (!record_program.empty()) record_job(outcome.result, record_program);
}

void Panel::record_end(const std::string& ending, const std::vector<executor::FaultReport>& faults) {
  const std::lock_guard<std::mutex> lock(job_mutex_);
  last_end_ = ending;
  last_fault_json_ = json::array();
  for (const executor::FaultReport& f : faults)
    if (!a_stop(f.kind))
      last_fault_json_.push_back({{"kind", executor::to_string(f.kind)}, {"message", clean(f.message)}, {"line", f.source_line}});
}

bool Panel::move_to(const Eigen::Vector2d& from, const Eigen::Vector2d& target, Termination& t) {
  // The rapid a run from a line starts with (solvers/motion/from_line.h), planned and run as
  // `machplan run` plans and runs a job: round the declared no-go zones, no kerf.
  motion::RunOptions options = o_.run;
  options.kerf_mm = 0.0;
  options.kerf_from_materials = false;
  planning_ = true;
  motion::PlannedRun plan =
      motion::plan_job(motion::rapid_job(from, target, session_->machine().limits.rapid_mm_per_s, "panel: rapid to the job's start"),
                       options, session_->machine(), {&t, nullptr, nullptr});
  planning_ = false;
  const motion::RunOutcome r = motion::execute(*session_, std::move(plan), options, {&t, nullptr, nullptr});
  if (r.summary.done()) return true;
  record_end(ending_of(r), r.result.faults);
  return false;
}

void Panel::run_jog() {
  Termination t;
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    current_stop_ = &t;
  }
  motion::Job job;
  job.source = "jog";
  job.start_mm = session_->backend_open() ? session_->live().read().measured_mm : Eigen::Vector2d::Zero();
  executor::JogSource source(session_->executor_options().jog);
  session::MachineSession::RunHooks hooks;
  hooks.source = &source;
  hooks.termination = &t;
  const std::unique_ptr<executor::Session> s = session_->start(job, {}, hooks);
  // The simulator unpaced (tests): the loop paces itself, outside the tick, as a jog is a
  // person's and only makes sense in real time.
  const bool self_paced = !session_->backend(job.start_mm).realtime();
  const auto period = std::chrono::duration<double>(session_->setup().servo_period_s);
  auto next = Clock::now();
  while (s->tick()) {
    if (!t.ended()) {
      const double centred_s = (now_ns() - last_deflection_ns_.load()) * 1e-9;
      if (centred_s > o_.jog_idle_end_s || quitting()) t.request_stop();
    }
    if (self_paced) {
      next += std::chrono::duration_cast<Clock::duration>(period);
      std::this_thread::sleep_until(next);
    }
  }
  const executor::ExecutionResult r = s->finish();
  // A jog ends by its own stop request (or the stop button); only a fault is an ending worth
  // showing.
  for (const executor::FaultReport& f : r.faults)
    if (!a_stop(f.kind)) return record_end(to_string(Status::faulted), r.faults);
}

void Panel::run_guard_session() {
  Termination t;
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    current_stop_ = &t;
  }
  GuardRequest request;
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    request = *guard_request_;
  }
  guard::GuardLink link;
  link.stick = &stick_;
  link.estop = &estop_;
  link.live = &guard_live_;
  link.paced_finish = o_.pace;
  guard_live_valid_ = true;
  const guard::GuardRunResult r = guard::run_guard_file(request.profile, request.options, t, nullptr, &link);
  json d = json::parse(*guard_drawing());
  d["result"] = cli::to_json(r);
  d["report"] = r.summary.full_report();
  json passes = json::array();
  for (const guard::FinishPass& f : r.finish) {
    json pts = json::array();
    for (const Eigen::Vector2d& p : f.path_mm) pts.push_back(p.x()), pts.push_back(p.y());
    passes.push_back({{"allowance_mm", f.allowance_mm}, {"completed", f.completed}, {"points", pts}});
  }
  d["finish_paths"] = passes;
  json strokes = json::array();
  for (const guard::Attempt& a : r.attempts) {
    json pts = json::array();
    for (const Eigen::Vector2d& p : a.path_mm) pts.push_back(p.x()), pts.push_back(p.y());
    strokes.push_back({{"success", a.success}, {"closest_mm", a.closest_mm}, {"points", pts}});
  }
  d["attempts"] = strokes;
  const std::lock_guard<std::mutex> lock(job_mutex_);
  guard_drawing_ = std::make_shared<const std::string>(d.dump(-1, ' ', false, json::error_handler_t::replace));
}

}  // namespace machplan::panel
