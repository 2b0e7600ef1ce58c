#include "cli/panel/panel.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli/json/calibration.h"
#include "cli/json/cut_order_json.h"
#include "cli/json/guard.h"
#include "cli/json/run.h"
#include "cli/json/stats.h"
#include "cli/panel/job_drawing.h"
#include "engine/common/error.h"
#include "engine/common/internal/text_scan.h"
#include "engine/common/output_file.h"
#include "engine/common/stop.h"
#include "engine/common/summary.h"
#include "engine/common/text_file.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/supervisor.h"
#include "engine/geometry/region.h"
#include "engine/hardware/operator_input.h"
#include "models/cutting/machine_config.h"
#include "solvers/calibration/store.h"
#include "solvers/motion/from_line.h"
#include "solvers/session/job_stats.h"
#include "solvers/session/tuning_store.h"

namespace machplan::panel {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

const char* to_string(Panel::Activity a) {
  switch (a) {
    case Panel::Activity::idle: return "idle";
    case Panel::Activity::running: return "running";
    case Panel::Activity::jogging: return "jogging";
    case Panel::Activity::guarding: return "guarding";
  }
  return "?";
}

std::int64_t Panel::now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

void PanelOptions::validate() const {
  require_field(std::isfinite(jog_deadman_s) && jog_deadman_s >= 0.05 && jog_deadman_s <= 5, "jog_deadman_s", jog_deadman_s,
                "s must be in [0.05, 5]");
  require_field(std::isfinite(jog_idle_end_s) && jog_idle_end_s >= 0.1 && jog_idle_end_s <= 600, "jog_idle_end_s",
                jog_idle_end_s, "s must be in [0.1, 600]");
  require_field(std::isfinite(sim_speed) && sim_speed > 0 && sim_speed <= 1000, "sim_speed", sim_speed, "must be in (0, 1000]");
  validate_member("session", session);
  validate_member("run", run);
}

namespace {


// A file name safe to create in the panel's folder: letters, digits, '.', '-', '_' only.
std::string safe_name(const std::string& name) {
  std::string s;
  for (char c : name.substr(0, 64))
    s += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_') ? c : '_';
  if (s.empty() || s[0] == '.') s = "upload" + s;
  if (s.size() < 4 || s.substr(s.size() - 4) != ".ngc") s += ".ngc";
  return s;
}

json vec(const Eigen::Vector2d& v) { return json::array({v.x(), v.y()}); }

// A request's file: a path as it is, or (holding a newline) the file's text, stored as `file`
// and its path returned.
std::string stored(const std::string& path_or_text, const std::string& file) {
  if (path_or_text.find('\n') == std::string::npos) return path_or_text;
  write_file_atomically(file, path_or_text);  // a full disk: OutputError, no half program left
  return file;
}

const char* run_state(executor::LiveState::Run r) {
  using R = executor::LiveState::Run;
  switch (r) {
    case R::idle: return "idle";
    case R::running: return "running";
    case R::held: return "held";
    case R::stopping: return "stopping";
    case R::faulted: return "faulted";
    case R::done: return "done";
  }
  return "idle";
}

const char* phase_name(guard::GuardLive::Phase p) {
  switch (p) {
    case guard::GuardLive::Phase::roughing: return "roughing";
    case guard::GuardLive::Phase::finishing: return "finishing";
    case guard::GuardLive::Phase::done: return "done";
  }
  return "?";
}

}  // namespace

Panel::Panel(PanelOptions options) : o_(std::move(options)) {
  o_.validate();
  o_.session.executor.record_trace = false;
  o_.session.trace_csv_path.clear();
  o_.session.backend.sim.realtime = o_.pace;
  o_.session.backend.sim.realtime_speed = o_.sim_speed;
  o_.run.session = o_.session;
  session_ = std::make_unique<session::MachineSession>(o_.session);
  std::string tmpl = (fs::temp_directory_path() / "machplan-panel-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw InputError(tmpl, 0, "cannot create the panel's folder for uploaded programs");
  tmp_dir_ = tmpl;
  // The folders requests may read from, resolved once (symbolic links and '..' gone).
  std::error_code ec;
  const fs::path jobs = fs::canonical(o_.job_folder.empty() ? fs::current_path() : fs::path(o_.job_folder), ec);
  if (ec || !fs::is_directory(jobs, ec))
    throw InputError::field("job_folder", fmt::format("'{}' is not a folder", excerpt(o_.job_folder)));
  read_folders_.push_back(jobs.string());
  for (const cutting::MachineFolder& f : cutting::machine_folders()) {
    if (!f.exists || f.kind == "user") continue;
    const fs::path datasets = fs::canonical(fs::path(f.path).parent_path(), ec);
    if (!ec) read_folders_.push_back(datasets.string());
  }
  read_folders_.push_back(fs::canonical(tmp_dir_).string());
  runner_ = std::thread([this] { runner_loop(); });
}

std::string Panel::readable_file(const std::string& path, const char* field, FileKind kind) const {
  static const std::vector<std::string> kPrograms = {".ngc", ".nc", ".tap", ".gcode", ".cnc"};
  static const std::vector<std::string> kMaterials = {".cfg"};
  static const std::vector<std::string> kProfiles = {".dxf"};
  const std::vector<std::string>& endings = kind == FileKind::program     ? kPrograms
                                            : kind == FileKind::materials ? kMaterials
                                                                          : kProfiles;
  const char* what = kind == FileKind::program ? "program" : kind == FileKind::materials ? "material file" : "DXF profile";
  // The kind first, from the name alone: a file of another kind is never opened.
  const std::string ext = fs::path(path).extension().string();
  if (std::none_of(endings.begin(), endings.end(), [&](const std::string& e) { return text_scan::iequals(ext, e); }))
    throw InputError::field(field, fmt::format("'{}' is not a {} (its name must end in {})", excerpt(path), what,
                                               fmt::join(endings, ", ")));
  const InputError refused = InputError::field(
      field, fmt::format("'{}': no readable {} by that name in the job folder, the bundled datasets or the uploads",
                         excerpt(path), what));
  std::error_code ec;
  const fs::path real = fs::canonical(path, ec);
  if (ec) throw refused;
  const std::string r = real.string();
  const bool inside = std::any_of(read_folders_.begin(), read_folders_.end(), [&](const std::string& folder) {
    return r.size() > folder.size() && r.compare(0, folder.size(), folder) == 0 && r[folder.size()] == '/';
  });
  struct stat st {};
  if (!inside || ::stat(r.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || ::access(r.c_str(), R_OK) != 0) throw refused;
  return path;
}

Panel::~Panel() {
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    if (current_stop_) current_stop_.load()->request_stop();
  }
  {
    const std::lock_guard<std::mutex> lock(op_mutex_);
    op_.stop = true;  // a run under way ends with a controlled stop
    publish_inputs();
  }
  set_command(Command::quit);
  runner_.join();
  std::error_code ec;
  fs::remove_all(tmp_dir_, ec);
}

void Panel::set_command(Command c) {
  {
    const std::lock_guard<std::mutex> lock(cmd_mutex_);
    cmd_ = c;
  }
  cmd_cv_.notify_all();
}

void Panel::publish_inputs() { session_->operator_inputs().set(op_); }

std::string Panel::clean(const std::string& text) const {
  std::string s = text;
  const std::string prefix = tmp_dir_ + "/";
  for (std::size_t at; (at = s.find(prefix)) != std::string::npos;) s.erase(at, prefix.size());
  return s;
}

// ---- jobs -------------------------------------------------------------------------------------

Panel::PlanningScope::PlanningScope(Panel& panel, Termination& t) : p(panel) {
  const std::lock_guard<std::mutex> lock(p.stop_mutex_);
  p.current_stop_ = &t;
  p.planning_ = true;
}

Panel::PlanningScope::~PlanningScope() {
  const std::lock_guard<std::mutex> lock(p.stop_mutex_);
  p.current_stop_ = nullptr;
  p.planning_ = false;
}

motion::RunOptions Panel::job_options(const JobRequest& request, const std::string& materials_path) const {
  motion::RunOptions options = o_.run;
  options.origin_mm = request.origin_mm;
  options.align_mm = request.align_mm;
  options.materials_path = materials_path;
  options.default_material = request.material;  // plan_program validates the whole
  return options;
}

json Panel::load_job(const JobRequest& request) {
  if (activity_.load() != Activity::idle) throw Busy("the machine is busy: stop what runs before loading a job");
  std::unique_lock<std::mutex> planning(plan_mutex_, std::try_to_lock);
  if (!planning.owns_lock()) throw Busy("another job is being planned");
  if (request.program.empty()) throw InputError::field("program", "is empty: give a path or the program's text");
  if (request.origin_mm && !(request.origin_mm->allFinite() && request.origin_mm->cwiseAbs().maxCoeff() <= 1e6))
    throw InputError::field("origin", "must be two finite numbers within 1e6 mm");
  if (request.align_mm) {
    if (request.origin_mm)
      throw InputError::field("align", "the sheet alignment sets the program's zero: give the origin or the alignment, not both");
    for (const Eigen::Vector2d& p : {request.align_mm->first, request.align_mm->second})
      if (!(p.allFinite() && p.cwiseAbs().maxCoeff() <= 1e6))
        throw InputError::field("align", "each point must be two finite numbers within 1e6 mm");
    const double apart = (request.align_mm->second - request.align_mm->first).norm();
    if (apart < motion::RunOptions::kMinAlignEdgeMm)
      throw InputError::field("align", fmt::format("the two edge points are {:.3f} mm apart: take them at least {:g} mm apart "
                                                   "along the edge",
                                                   apart, motion::RunOptions::kMinAlignEdgeMm));
  }
  const std::string path =
      readable_file(stored(request.program, tmp_dir_ + "/" + safe_name(request.name)), "program", FileKind::program);
  std::string materials = stored(request.materials, tmp_dir_ + "/materials.cfg");
  if (!materials.empty()) materials = readable_file(materials, "materials", FileKind::materials);
  const motion::RunOptions options = job_options(request, materials);
  Termination t;
  std::optional<motion::PlannedRun> plan;
  try {
    const PlanningScope scope(*this, t);
    plan.emplace(motion::plan_program(path, options, session_->machine(), {&t, nullptr, nullptr}));
    if (!plan->summary.done()) {  // refused: the same replies as before (409 cancelled, 422 infeasible)
      if (plan->summary.status == Status::infeasible) throw Infeasible(plan->summary.message, plan->limit_field);
      throw Cancelled(plan->summary.message);
    }
  } catch (const InputError& e) {
    throw InputError(clean(e.where()), e.line(), clean(e.message()));
  }
  json summary;
  const std::lock_guard<std::mutex> lock(job_mutex_);
  ++job_id_;
  drawing_ = std::make_shared<const std::string>(job_drawing_json(*plan, job_id_));
  summary = {{"job_id", job_id_},
             {"source", clean(plan->job.source)},
             {"origin_mm", vec(plan->origin_mm)},
             {"origin_from", plan->origin_from},
             {"rotation_deg", plan->rotation_deg},
             {"steps", plan->job.steps.size()},
             {"estimate_s", plan->expected_s()},
             {"lower_bound_s", plan->lower_bound_s},
             {"warnings", plan->warnings},
             {"notes", plan->notes}};
  programmed_ = plan->programmed;
  job_path_ = path;
  job_request_ = request;
  job_request_.program.clear();  // the text is in the file now
  job_request_.materials = materials;
  plan_ = std::move(plan);
  return summary;
}

std::shared_ptr<const std::string> Panel::job_drawing() const {
  const std::lock_guard<std::mutex> lock(job_mutex_);
  return drawing_;
}

std::shared_ptr<const std::string> Panel::report() const {
  const std::lock_guard<std::mutex> lock(job_mutex_);
  return report_;
}

std::shared_ptr<const std::string> Panel::guard_drawing() const {
  const std::lock_guard<std::mutex> lock(job_mutex_);
  return guard_drawing_;
}

void Panel::require_idle() const {
  if (activity_.load() != Activity::idle || cmd_ != Command::none) throw Busy("the machine is busy: a job, a jog or a guard session runs");
  if (estop_.load()) throw Busy("the E-stop is latched: reset it first (POST /api/reset)");
}

void Panel::run(std::optional<int> from_line) {
  const std::lock_guard<std::mutex> lock(cmd_mutex_);
  require_idle();
  {
    const std::lock_guard<std::mutex> jl(job_mutex_);
    if (job_path_.empty()) throw Busy("no job is loaded (POST /api/job)");
    if (from_line) {
      if (*from_line < 1 || *from_line > 10000000) throw InputError::field("from_line", fmt::format("{} is not a line number", *from_line));
      job_from_line(programmed_, *from_line);  // throws when the program has no such line
    }
  }
  cmd_from_line_ = from_line;
  begin(Activity::running, Command::run);
}

void Panel::begin(Activity a, Command c) {
  {
    const std::lock_guard<std::mutex> lock(op_mutex_);
    if (op_.stop) {
      op_.stop = false;
      publish_inputs();
    }
  }
  activity_ = a;
  cmd_ = c;
  cmd_cv_.notify_all();
}

json Panel::frame(std::optional<double> feed_mm_per_s, std::optional<double> margin_mm, bool laser) {
  {
    const std::lock_guard<std::mutex> lock(cmd_mutex_);
    require_idle();
  }
  motion::FrameOptions fo;
  if (feed_mm_per_s) {
    if (!(std::isfinite(*feed_mm_per_s) && *feed_mm_per_s > 0.0))
      throw InputError::field("feed", fmt::format("{} must be a speed > 0, mm/s", *feed_mm_per_s));
    fo.feed_mm_per_s = *feed_mm_per_s;
  }
  if (margin_mm) {
    if (!(std::isfinite(*margin_mm) && *margin_mm >= 0.0 && *margin_mm <= 1000.0))
      throw InputError::field("margin", fmt::format("{} must be 0 .. 1000 mm", *margin_mm));
    fo.margin_mm = *margin_mm;
  }
  if (laser) {
    const cutting::MachineConfig& m = session_->machine();
    if (!m.laser_offset_mm)
      throw InputError::field("laser", fmt::format("machine '{}' has no laser pointer (a `laser: {{offset_mm: [x, y]}}` block)",
                                                   m.name));
    fo.pointer_offset_mm = {(*m.laser_offset_mm)[0], (*m.laser_offset_mm)[1]};
    fo.laser = true;
  }
  std::unique_lock<std::mutex> planning(plan_mutex_, std::try_to_lock);
  if (!planning.owns_lock()) throw Busy("another job is being planned");
  std::optional<motion::Job> job;  // as it will run: kerf and rapids planned
  std::string path;
  JobRequest request;
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    if (job_path_.empty()) throw Busy("no job is loaded (POST /api/job)");
    if (plan_) job = plan_->job;
    path = job_path_;
    request = job_request_;
  }
  const motion::RunOptions options = job_options(request, request.materials);
  // The E-stop stops this planning as it stops a job's (the job is planned again when it has run).
  Termination t;
  std::optional<motion::PlannedRun> replanned;  // the job has run: planned again
  std::optional<motion::FramePlan> f;
  {
    const PlanningScope scope(*this, t);
    if (!job) {
      replanned.emplace(motion::plan_program(path, options, session_->machine(), {&t, nullptr, nullptr}));
      if (replanned->summary.done()) job = replanned->job;
    }
    if (job) f.emplace(motion::plan_frame(*job, options, fo, session_->machine(), {&t, nullptr, nullptr}));
  }
  const motion::PlannedRun& refused = f ? f->plan : *replanned;
  if (!refused.summary.done()) {
    if (refused.summary.status == Status::infeasible) throw Infeasible(clean(refused.summary.message), refused.limit_field);
    throw Cancelled(refused.summary.message);
  }
  json j = cli::frame_json(*f);
  const std::lock_guard<std::mutex> lock(cmd_mutex_);
  require_idle();
  {
    const std::lock_guard<std::mutex> jl(job_mutex_);
    frame_plan_ = std::move(f->plan);
    frame_json_ = j;
  }
  begin(Activity::running, Command::frame);
  return j;
}

// ---- the operator -----------------------------------------------------------------------------

void Panel::press(bool hardware::OperatorInputs::*button) {
  const std::lock_guard<std::mutex> lock(op_mutex_);
  op_.*button = true;
  const executor::LiveState l = session_->live().read();
  press_session_ = l.session;
  press_tick_ = l.tick;
  press_time_ = Clock::now();
  publish_inputs();
}

void Panel::refuse_in_paper_mode(const hardware::OperatorInputs& asked) const {
  if (!session::paper_mode(o_.session.executor.mode)) return;
  if (const std::string lacks = session::paper_mode_lacks(asked); !lacks.empty())
    throw InputError("", 0, fmt::format("{}: {}", lacks, session::kPaperModesLack));
}

void Panel::hold() {
  hardware::OperatorInputs asked;
  asked.feed_hold = true;
  refuse_in_paper_mode(asked);
  press(&hardware::OperatorInputs::feed_hold);
}

void Panel::resume() {
  if (activity_.load() == Activity::guarding) {
    // Cycle start ends the manual part of a hybrid session (the guard's rule).
    hardware::StickState s = hardware::LiveOperator::unpack(stick_.load());
    s.quit = true;
    stick_.store(hardware::LiveOperator::pack(s));
    return;
  }
  hardware::OperatorInputs asked;
  asked.cycle_start = true;
  refuse_in_paper_mode(asked);
  press(&hardware::OperatorInputs::cycle_start);
}

void Panel::stop() {
  const Activity a = activity_.load();
  if (a == Activity::idle) return;  // nothing to stop, and nothing left to stop the next run
  {
    const std::lock_guard<std::mutex> lock(stop_mutex_);
    if (current_stop_ && (a != Activity::running || planning_.load())) current_stop_.load()->request_stop();
  }
  if (a == Activity::guarding) return;
  // The button stays pressed until the activity ends (the runner lets go of it): a run that
  // has not read its inputs yet (still planning, or between the rapid to the start and the
  // job) stops at its first period, which a pulse could miss.
  const std::lock_guard<std::mutex> lock(op_mutex_);
  op_.stop = true;
  publish_inputs();
}

void Panel::estop() {
  estop_.store(true);  // first: the guard's sessions read it every period
  {
    const std::lock_guard<std::mutex> lock(op_mutex_);
    op_.estop = true;
    op_.jog = {};
    publish_inputs();
  }
  // A run sees the E-stop in its next period through the channel. Planning and the guard's
  // sessions (which have channels of their own) are also told to stop.
  const std::lock_guard<std::mutex> lock(stop_mutex_);
  if (current_stop_ && (planning_.load() || activity_.load() == Activity::guarding)) current_stop_.load()->request_stop();
}

void Panel::reset() {
  if (activity_.load() != Activity::idle) throw Busy("the machine is still stopping: reset once it is at rest");
  estop_.store(false);
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    last_fault_json_ = json::array();  // acknowledged: the banner shows only what is in force
  }
  const std::lock_guard<std::mutex> lock(op_mutex_);
  op_.estop = false;
  publish_inputs();
}

void Panel::set_overrides(std::optional<double> feed_pct, std::optional<double> rapid_pct) {
  if (feed_pct && !(std::isfinite(*feed_pct) && *feed_pct >= 0 && *feed_pct <= 200))
    throw InputError::field("feed", fmt::format("{} % is out of range: the feed override is 0 .. 200 %", *feed_pct));
  if (rapid_pct && !(std::isfinite(*rapid_pct) && *rapid_pct >= 1 && *rapid_pct <= 100))
    throw InputError::field("rapid", fmt::format("{} % is out of range: the rapid override is 1 .. 100 %", *rapid_pct));
  hardware::OperatorInputs asked;
  asked.feed_override_pct = feed_pct.value_or(100.0);
  asked.rapid_override_pct = rapid_pct.value_or(100.0);
  refuse_in_paper_mode(asked);
  const std::lock_guard<std::mutex> lock(op_mutex_);
  if (feed_pct) op_.feed_override_pct = *feed_pct;
  if (rapid_pct) op_.rapid_override_pct = *rapid_pct;
  publish_inputs();
}

void Panel::paused_motion(std::optional<double> mm, std::optional<double> speed) {
  if (mm.has_value() == speed.has_value())
    throw InputError::field("mm", "takes {\"mm\": N} (millimetres along the path, negative: back) or {\"speed\": F} (-1 .. 1)");
  if (mm && !(std::isfinite(*mm) && std::abs(*mm) <= 1000 && *mm != 0))
    throw InputError::field("mm", fmt::format("{} mm: a paused motion moves -1000 .. 1000 mm along the path, not 0", *mm));
  if (speed && !(std::isfinite(*speed) && std::abs(*speed) <= 1))
    throw InputError::field("speed", fmt::format("{}: the paused-motion speed is a fraction -1 .. 1", *speed));
  hardware::OperatorInputs asked;
  asked.paused_motion_mm = mm.value_or(0.0);
  asked.paused_motion_speed = speed.value_or(0.0);
  refuse_in_paper_mode(asked);
  const std::lock_guard<std::mutex> lock(op_mutex_);
  if (mm) op_.paused_motion_mm += *mm;
  if (speed) op_.paused_motion_speed = *speed, paused_speed_time_ = Clock::now();
  publish_inputs();
}

void Panel::set_thc(bool enabled) {
  const std::lock_guard<std::mutex> lock(op_mutex_);
  op_.thc_enabled = enabled;
  publish_inputs();
}

void Panel::set_torch(bool enabled) {
  const std::lock_guard<std::mutex> lock(op_mutex_);
  op_.torch_enabled = enabled;
  publish_inputs();
}

void Panel::jog(double x, double y) {
  if (!(std::isfinite(x) && std::isfinite(y) && std::abs(x) <= 1 && std::abs(y) <= 1))
    throw InputError::field("x", "the jog is two numbers x, y in -1 .. 1");
  const Activity a = activity_.load();
  if (a == Activity::running) throw Busy("a job is running: hold or stop it; the jog moves an idle machine");
  if (estop_.load()) throw Busy("the E-stop is latched: reset it first (POST /api/reset)");
  const bool deflected = std::hypot(x, y) > 0.02;
  if (deflected) last_deflection_ns_ = now_ns();
  if (a == Activity::guarding) {
    hardware::StickState s = hardware::LiveOperator::unpack(stick_.load());
    s.x = x, s.y = y;
    stick_.store(hardware::LiveOperator::pack(s));
  }
  {
    const std::lock_guard<std::mutex> lock(op_mutex_);
    jog_time_ = Clock::now();
    if (a != Activity::guarding) {
      op_.jog = {x, y};
      publish_inputs();
    }
  }
  if (a == Activity::idle && deflected) {
    const std::lock_guard<std::mutex> lock(cmd_mutex_);
    if (activity_.load() == Activity::idle && cmd_ == Command::none) begin(Activity::jogging, Command::jog);
  }
}

void Panel::start_guard(GuardRequest request) {
  request.options.op.kind = guard::OperatorSpec::Kind::panel;
  // A machine by name only: a path would let a request read any YAML file.
  if (request.options.machine.find_first_of("/.") != std::string::npos)
    throw InputError::field("machine", fmt::format("'{}': the panel takes a machine by its name (machplan machines lists them)",
                                                   excerpt(request.options.machine)));
  request.options.validate();
  std::vector<std::string> warnings;
  const std::vector<Contour> profile =
      guard::read_guard_profile(readable_file(request.profile, "profile", FileKind::profile), warnings);
  const ProhibitedRegion region = ProhibitedRegion::build(profile, request.options.region);
  const std::lock_guard<std::mutex> lock(cmd_mutex_);
  if (activity_.load() != Activity::idle || cmd_ != Command::none) throw Busy("the machine is busy");
  if (estop_.load()) throw Busy("the E-stop is latched: reset it first (POST /api/reset)");
  json d;
  d["profile_source"] = request.profile;
  const auto contours = [](const std::vector<Contour>& cs) {
    json a = json::array();
    for (const Contour& c : cs) {
      json pts = json::array();
      for (std::size_t i = 0; i < c.size(); ++i) {
        const Segment s = c.span(i);
        const int n = s.is_arc() ? std::clamp(static_cast<int>(std::abs(s.sweep) * 16), 2, 128) : 1;
        for (int k = 0; k < n; ++k) {
          const double a2 = s.start_angle + s.sweep * k / n;
          const Eigen::Vector2d p = s.is_arc() ? Eigen::Vector2d(s.center + s.radius * Eigen::Vector2d(std::cos(a2), std::sin(a2))) : s.start;
          pts.push_back(p.x());
          pts.push_back(p.y());
        }
      }
      a.push_back(pts);
    }
    return a;
  };
  d["profile"] = contours(profile);
  d["boundary"] = contours(region.boundary());
  d["side"] = to_string(request.options.region.side);
  d["tool_radius_mm"] = request.options.region.tool_radius_mm;
  d["tolerance_mm"] = request.options.guard.tolerance_mm;
  d["finish"] = request.options.finish;
  d["warnings"] = warnings;
  {
    const std::lock_guard<std::mutex> jl(job_mutex_);
    guard_drawing_ = std::make_shared<const std::string>(d.dump(-1, ' ', false, json::error_handler_t::replace));
    guard_request_ = std::move(request);
  }
  stick_.store(hardware::LiveOperator::pack({0.0, 0.0, guard_request_->options.feed_mm_per_s, false}));
  guard_live_valid_ = false;
  begin(Activity::guarding, Command::guard);
}

void Panel::service() {
  const auto now = Clock::now();
  const std::lock_guard<std::mutex> lock(op_mutex_);
  bool changed = false;
  if (op_.feed_hold || op_.cycle_start) {
    // Seen: a run read its inputs twice since the press (a run that started after the press, its
    // own first periods). Until then it stays pressed while a job runs, which may still be
    // planning; with nothing running it is let go after 250 ms.
    const executor::LiveState l = session_->live().read();
    const bool running = activity_.load() == Activity::running;
    const bool seen = running && (l.session != press_session_ ? l.tick >= 2 : l.tick >= press_tick_ + 2);
    if (seen || (!running && now - press_time_ > std::chrono::milliseconds(250))) {
      op_.feed_hold = op_.cycle_start = false;
      changed = true;
    }
  }
  if (op_.paused_motion_speed != 0.0 && now - paused_speed_time_ > std::chrono::duration<double>(o_.jog_deadman_s)) {
    op_.paused_motion_speed = 0.0;
    changed = true;
  }
  if (now - jog_time_ > std::chrono::duration<double>(o_.jog_deadman_s)) {
    if (op_.jog[0] != 0.0 || op_.jog[1] != 0.0) {
      op_.jog = {};
      changed = true;
    }
    hardware::StickState s = hardware::LiveOperator::unpack(stick_.load());
    if (s.x != 0.0 || s.y != 0.0) {
      s.x = s.y = 0.0;
      stick_.store(hardware::LiveOperator::pack(s));
    }
  }
  if (changed) publish_inputs();
}

// ---- what the clients read --------------------------------------------------------------------

json Panel::status() {
  const executor::LiveState l = session_->live().read();
  const Activity a = activity_.load();
  json s;
  s["machine"] = session_->machine().name;
  s["backend"] = o_.session.backend.name;
  std::string state;
  switch (a) {
    case Activity::idle: {
      const std::lock_guard<std::mutex> lock(job_mutex_);
      state = last_end_ == "running" ? "idle" : last_end_;
      break;
    }
    case Activity::running: state = planning_.load() ? "planning" : run_state(l.run); break;
    case Activity::jogging: state = "jogging"; break;
    case Activity::guarding: state = "guarding"; break;
  }
  s["state"] = state;
  s["activity"] = to_string(a);
  s["estop"] = estop_.load();
  {
    const std::lock_guard<std::mutex> lock(job_mutex_);
    s["job_id"] = job_id_;
    s["program"] = job_path_.empty() ? json(nullptr) : json(clean(programmed_.source));
    s["faults"] = last_fault_json_.is_null() ? json::array() : last_fault_json_;
    s["report_available"] = report_ != nullptr;
  }
  if (a == Activity::running && l.fault >= 0)
    s["faults"] = json::array({{{"kind", executor::to_string(static_cast<executor::FaultKind>(l.fault))},
                                {"message", "the run is stopping"},
                                {"line", l.source_line}}});
  s["line"] = l.source_line;
  s["position_mm"] = vec(l.measured_mm);
  s["commanded_mm"] = vec(l.commanded_mm);
  s["feed_mm_per_s"] = l.path_speed_mm_per_s;
  {
    const std::lock_guard<std::mutex> lock(op_mutex_);
    s["overrides"] = {{"feed_pct", op_.feed_override_pct}, {"rapid_pct", op_.rapid_override_pct}};
    s["overrides"]["feed_effective_pct"] = l.feed_effective_pct;  // what the machine makes of it
    s["thc_enabled"] = op_.thc_enabled;
    s["torch_enabled"] = op_.torch_enabled;
  }
  s["torch"] = {{"fire", l.torch_fire},       {"arc_ok", l.arc_ok},     {"height_mm", l.torch_height_mm},
                {"thc_active", l.thc_active}, {"arc_voltage_v", l.arc_voltage_v}, {"laser_on", l.laser_on}};
  // The tick's progress stops short of 1 until the job's end is seen; a job that ended done is
  // all done.
  s["progress"] = a == Activity::idle && state == to_string(Status::done) ? 1.0 : l.progress;
  s["time_left_s"] = l.time_left_s;
  s["holds"] = l.holds;
  s["t_s"] = l.t_s;
  if (guard_live_valid_.load()) {
    const guard::GuardLive g = guard_live_.read();
    s["guard"] = {{"phase", phase_name(g.phase)},         {"position_mm", vec(g.position_mm)},
                  {"distance_mm", g.distance_mm},          {"holding", g.guard_holding},
                  {"strokes", g.strokes},                  {"t_s", g.t_s}};
  }
  return s;
}

std::string Panel::live_frame() {
  const executor::LiveState l = session_->live().read();
  const Activity a = activity_.load();
  const char* state = a == Activity::running ? (planning_.load() ? "planning" : run_state(l.run))
                      : a == Activity::jogging ? "jogging"
                      : a == Activity::guarding ? "guarding"
                                                : "idle";
  std::string out;
  out.reserve(512);
  fmt::format_to(std::back_inserter(out),
                 "{{\"state\":\"{}\",\"activity\":\"{}\",\"estop\":{},\"tick\":{},\"t_s\":{:.3f},\"line\":{},"
                 "\"position_mm\":[{:.4f},{:.4f}],\"commanded_mm\":[{:.4f},{:.4f}],\"feed_mm_per_s\":{:.3f},"
                 "\"feed_pct\":{:.1f},\"feed_effective_pct\":{:.1f},\"rapid_pct\":{:.1f},\"torch\":{},\"arc_ok\":{},\"height_mm\":{:.3f},"
                 "\"thc_active\":{},\"arc_voltage_v\":{:.2f},\"progress\":{:.5f},\"time_left_s\":{:.2f},\"fault\":\"{}\","
                 "\"holds\":{}",
                 state, to_string(a), estop_.load(), l.tick, l.t_s, l.source_line, l.measured_mm.x(), l.measured_mm.y(),
                 l.commanded_mm.x(), l.commanded_mm.y(), l.path_speed_mm_per_s, l.feed_override_pct, l.feed_effective_pct, l.rapid_override_pct,
                 l.torch_fire, l.arc_ok, l.torch_height_mm, l.thc_active, l.arc_voltage_v, l.progress, l.time_left_s,
                 l.fault >= 0 ? executor::to_string(static_cast<executor::FaultKind>(l.fault)) : "", l.holds);
  if (guard_live_valid_.load()) {
    const guard::GuardLive g = guard_live_.read();
    fmt::format_to(std::back_inserter(out),
                   ",\"guard\":{{\"phase\":\"{}\",\"position_mm\":[{:.4f},{:.4f}],\"distance_mm\":{:.4f},\"holding\":{},"
                   "\"strokes\":{}}}",
                   phase_name(g.phase), g.position_mm.x(), g.position_mm.y(), g.distance_mm, g.guard_holding, g.strokes);
  }
  out += '}';
  return out;
}

json Panel::history() const {
  json h;
  h["calibrations"] = json::array();
  h["tunings"] = json::array();
  const std::string path = store_file();
  std::error_code ec;
  h["store"] = path;
  if (!fs::is_regular_file(path, ec)) return h;  // nothing stored yet; never create the store here
  for (const calibration::StoredFit& f : calibration::CalibrationStore(path).history()) h["calibrations"].push_back(cli::to_json(f));
  for (const tuning::StoredTuning& t : tuning::TuningStore(path).history())
    h["tunings"].push_back({{"id", t.id},
                            {"machine", t.machine},
                            {"controller", t.controller},
                            {"who", t.who},
                            {"created_utc", t.created_utc},
                            {"active", t.active},
                            {"gains", t.gains}});
  return h;
}

std::string Panel::store_file() const { return o_.store_path.empty() ? store::default_store_path() : o_.store_path; }

json Panel::statistics() const {
  const std::string path = store_file();
  const std::string& machine = session_->machine().name;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {  // nothing stored yet; never create the store here
    json j = cli::to_json(stats::MachineTotals{machine, {}, {}, std::nullopt, std::nullopt});
    j["jobs"] = json::array();
    return j;
  }
  const stats::StatsStore store(path);
  json j = cli::to_json(store.totals(machine));
  j["jobs"] = json::array();
  for (const stats::JobRecord& r : store.jobs(machine, 10)) j["jobs"].push_back(cli::to_json(r));
  return j;
}

void Panel::consumables_changed(const std::string& who) {
  stats::StatsStore(store_file()).consumables_changed(session_->machine().name, who);
}

void Panel::record_job(const executor::ExecutionResult& result, const std::string& program) {
  try {
    stats::StatsStore(store_file()).record(stats::job_record(result, program, read_text_file(program)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "machplan serve: the job's statistics were not stored: %s\n", e.what());
  }
}

}  // namespace machplan::panel
