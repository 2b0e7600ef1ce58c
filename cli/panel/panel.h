// The shop-floor panel's machine side: the one machine session of `machplan serve`, the job
// runner thread that plans and runs jobs on it, and the operator's inputs the web clients
// give. The HTTP / WebSocket front end (cli/panel/server.h) only calls this class; tests and
// the bench use it directly.
//
//   session      one MachineSession (solvers/session/machine_session.h) for the life of the
//                process: the machine stays where the last job left it. Before a job whose
//                start is elsewhere, the runner moves the tool there with a rapid planned like
//                any other (round the declared no-go zones), as an operator's "go to start".
//   runner       one thread. A job is planned (motion::plan_program, on the calling thread, so
//                that errors answer the request) and run by motion::execute on the runner
//                thread: the same pipeline and the same report as `machplan run`, the
//                simulator paced to the wall clock (SimOptions::realtime) unless asked not to.
//                The runner also runs jog sessions (an idle machine jogged from the panel) and
//                hybrid guard sessions (solvers/guard/guard_run.h, through a GuardLink).
//   operator     the inputs every client shares, written to session.operator_inputs(): hold,
//                resume and stop are buttons pressed until the tick has seen them (two servo
//                periods; service() lets them go), the overrides are levels, the jog is a level
//                with a dead man (it falls back to centred when no jog arrives for
//                jog_deadman_s), the E-stop is a level latched until reset(): the executor
//                faults E-stop in the first period that sees it (torch off in that period,
//                controlled stop), and no job, jog or guard session starts while it is latched.
//
// Threading: every public member may be called from any thread. No member waits for the
// runner or for a tick: the server threads read the session's LiveState (published by the
// tick, engine/common/latest.h) and write the operator channel; they never touch executor
// state. Planning takes a mutex of its own (one plan at a time).
//
// Errors: bad requests throw InputError (the message names the file and line, or the field)
// or Infeasible (the job cannot run on this machine); a request the machine's state refuses
// (a run while a run is under way, a job while the E-stop is latched) throws Busy.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/executor/live_state.h"
#include "engine/hardware/backend.h"
#include "solvers/guard/guard_run.h"
#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"

namespace machplan::panel {

// The machine's state forbids the request now (HTTP 409).
class Busy : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PanelOptions {
  // The machine, its backend and controller. The panel sets executor.record_trace = false
  // (a long job's trace would fill memory; the report does not need it).
  session::MachineSessionOptions session;
  // How jobs are planned (kerf, no-go zones, cut order, limits); its `session` is ignored.
  motion::RunOptions run;
  // Pace the simulator to the wall clock (people watch it move). Off: as fast as it goes.
  bool pace = true;
  // Paced: simulated seconds per wall-clock second (SimOptions::realtime_speed; tests and demos
  // may run faster than the machine would).
  double sim_speed = 1.0;
  // A browser jog falls back to centred when no jog request came for this long, s.
  double jog_deadman_s = 0.3;
  // A jog session of an idle machine ends when the stick has been centred for this long, s.
  double jog_idle_end_s = 2.0;
  // Where calibrations and tunings are read from (read-only) and where each job the panel runs
  // is recorded (machplan consumables); "" for the default store.
  std::string store_path;
  // The job folder: programs, material files and guard profiles named by path are read from
  // here, the bundled datasets (datasets/ beside the machines machplan ships) and the panel's
  // own folder of uploads, nowhere else; "" for the folder `serve` was started in. Requests
  // name a file by a path relative to the server's current folder, or an absolute one.
  std::string job_folder;
  void validate() const;  // InputError::field naming the field
};

// POST /api/job.
struct JobRequest {
  std::string program;       // a path, or the program's text (it has a newline)
  std::string name;          // the text's file name, for messages ("upload.ngc" when empty)
  std::optional<Eigen::Vector2d> origin_mm;
  // A sheet alignment in place of the origin: two points on the sheet's edge, machine mm (the
  // panel takes them where the operator jogged the torch), as `run --align`.
  std::optional<std::pair<Eigen::Vector2d, Eigen::Vector2d>> align_mm;
  // A QtPlasmaC material file: a path, or the file's text (it has a newline), as `run
  // --materials`; empty for none. `material`: the number in force when the program selects
  // none (`run --material`), -1 for the machine file's cut data.
  std::string materials;
  int material = -1;
};

// POST /api/guard: a hybrid session from the panel.
struct GuardRequest {
  std::string profile;                 // a DXF path
  guard::GuardRunOptions options;      // op is set to the panel's stick
};

class Panel {
 public:
  explicit Panel(PanelOptions options);
  ~Panel();  // stops what runs (controlled stop) and joins the runner
  Panel(const Panel&) = delete;
  Panel& operator=(const Panel&) = delete;

  session::MachineSession& session() { return *session_; }

  // Reads and plans a job; it replaces the loaded one. Returns its summary (GET /api/job has
  // the drawing). Busy while a job runs.
  nlohmann::json load_job(const JobRequest& request);
  // The loaded job's drawing (GET /api/job); "" when none.
  std::shared_ptr<const std::string> job_drawing() const;
  // Starts the loaded job (from `from_line` when given). Busy when something runs, no job is
  // loaded or the E-stop is latched; InputError for a line the program does not have.
  void run(std::optional<int> from_line);
  // Frames the loaded job (POST /api/frame): its outline traced with the torch off
  // (solvers/motion/run.h, plan_frame: `feed_mm_per_s` along it, default the machine's rapid
  // speed; the outline grown by `margin_mm`), planned on the calling thread so that errors
  // answer the request, then run by the runner from wherever the machine stands. Returns the
  // outline (cli/json/run.h, frame_json). Busy as run(); InputError::field (feed, margin) for a
  // bad value; Infeasible when the frame leaves the travel or enters a declared no-go zone.
  nlohmann::json frame(std::optional<double> feed_mm_per_s, std::optional<double> margin_mm, bool laser = false);
  // Buttons (HTTP hold, resume, stop).
  // A paper-mode session has no hold, resume, override or recovery: those throw InputError
  // with the rule a run's options give (session::kPaperModesLack).
  void hold();
  void resume();
  void stop();
  // Any client, any time: opens the operator's E-stop (latched), stops planning and guard.
  void estop();
  // Closes the E-stop latch and acknowledges the faults shown. Busy while a run is still
  // stopping.
  void reset();
  // Levels; InputError::field for a value out of range (feed 0 .. 200 %, rapid 1 .. 100 %).
  void set_overrides(std::optional<double> feed_pct, std::optional<double> rapid_pct);
  // Paused motion: while a job is held with its torch off (a lost arc, or a hold), move along
  // the program's path (negative: back over what was cut, across moves and earlier cuts):
  // `mm`, at most 1000 mm a request, or at `speed` (-1 .. 1 of the machine's paused-motion
  // speed; a level with the jog's dead man: it falls back to 0 when no request came for
  // jog_deadman_s). The executor takes it at rest; the resume pierces where the machine
  // stands when that is in a cut.
  void paused_motion(std::optional<double> mm, std::optional<double> speed);
  // The operator's THC switch (plasma): torch height control allowed or not.
  void set_thc(bool enabled);
  // The operator's torch switch (plasma, oxy-fuel): off, the job runs dry, and a cut under way
  // is held with the torch off (the resume goes on dry).
  void set_torch(bool enabled);
  // The stick, each axis -1 .. 1. An idle machine starts a jog session; a hybrid session
  // steers with it. Busy while a job runs.
  void jog(double x, double y);
  // Starts a hybrid guard session. Busy when something runs.
  void start_guard(GuardRequest request);
  // The hybrid session's drawing (profile, boundary, options, finishing passes when done).
  std::shared_ptr<const std::string> guard_drawing() const;

  // GET /api/status's document.
  nlohmann::json status();
  // One frame of the live stream (WS /api/live): compact JSON text.
  std::string live_frame();
  // The last run's report, the JSON of `machplan run --json`; "" before the first run ends.
  std::shared_ptr<const std::string> report() const;
  // Stored calibrations and tunings, read-only (GET /api/history).
  nlohmann::json history() const;
  // The machine's job statistics (GET /api/statistics): `machplan consumables show --json`'s
  // document; zeros before the first job is stored.
  nlohmann::json statistics() const;
  // The operator changed the consumables (POST /api/consumables): the counters since the change
  // start again; the lifetime totals stay.
  void consumables_changed(const std::string& who);

  // Housekeeping, called 30 to 100 times a second by one thread (the live stream's): lets go
  // of buttons the tick has seen and centres a jog whose dead man ran out.
  void service();

  // What runs now.
  enum class Activity { idle, running, jogging, guarding };
  Activity activity() const { return activity_.load(); }
  // Runs finished since the start (tests wait on it).
  int runs_finished() const { return runs_finished_.load(); }
  // `text` without the panel's folder of uploaded programs (messages name the upload's name).
  std::string clean(const std::string& text) const;

 private:
  enum class Command { none, run, frame, jog, guard, quit };
  void runner_loop();
  void run_job(std::optional<int> from_line);
  void run_frame();
  // Runs `plan` from where the machine stands (a rapid to its start first) and keeps its report.
  // `record_program`: the job's program file, whose run joins the machine's statistics in the
  // store; "" for a run that is no job (a frame).
  void run_plan(motion::PlannedRun plan, const motion::RunOptions& options, Termination& t, const nlohmann::json& frame,
                const std::string& record_program = {});
  // Adds a job's run to the store; a store that cannot take it is told on stderr (the run
  // itself is over and reported).
  void record_job(const executor::ExecutionResult& result, const std::string& program);
  std::string store_file() const;
  // Busy unless the machine is idle with no command pending and the E-stop closed; under
  // cmd_mutex_.
  void require_idle() const;
  // The runner takes `c` and the machine is `a` from now; a stop left over from the last
  // activity is dropped. Under cmd_mutex_.
  void begin(Activity a, Command c);
  // While a request plans on its own thread: `t` is what the E-stop and the stop button stop,
  // and the status says planning.
  static std::int64_t now_ns();  // steady clock
  struct PlanningScope {
    Panel& p;
    PlanningScope(Panel& panel, Termination& t);
    ~PlanningScope();
  };
  void run_jog();
  void run_guard_session();
  // The rapid to a job's start; false (the fault recorded) when it did not get there.
  bool move_to(const Eigen::Vector2d& from, const Eigen::Vector2d& target, Termination& t);
  bool quitting();
  void press(bool hardware::OperatorInputs::*button);
  void publish_inputs();  // op_ to the channel; under op_mutex_
  void set_command(Command c);
  // A run ended `ending` (Summary's spelling) with `faults`: the status shows both. Takes
  // job_mutex_.
  void record_end(const std::string& ending, const std::vector<executor::FaultReport>& faults);
  // The paper modes lack what `asked` asks (session::paper_mode_lacks): refused with the rule
  // that refuses it in a run's options.
  void refuse_in_paper_mode(const hardware::OperatorInputs& asked) const;
  // What a request may read (PanelOptions::job_folder): `path`, when it names a regular,
  // readable file of the kind asked for (by its ending) inside one of read_folders_. Any
  // other answer is one and the same InputError::field(`field`): a missing file, an
  // unreadable one, a folder, a FIFO and a file outside those folders are not told apart, and
  // nothing is read from a file of another kind, so no answer quotes it.
  enum class FileKind { program, materials, profile };
  std::string readable_file(const std::string& path, const char* field, FileKind kind) const;
  // The run's options for a job: the panel's, with the job's origin (or alignment), materials
  // (`materials_path`: the request's, stored) and material.
  motion::RunOptions job_options(const JobRequest& request, const std::string& materials_path) const;

  PanelOptions o_;
  std::unique_ptr<session::MachineSession> session_;

  // The operator's inputs (op_mutex_).
  mutable std::mutex op_mutex_;
  hardware::OperatorInputs op_{};
  std::uint32_t press_session_ = 0;  // the live state's session and tick at the last press
  std::uint64_t press_tick_ = 0;
  std::chrono::steady_clock::time_point press_time_{}, jog_time_{}, paused_speed_time_{};
  std::atomic<bool> estop_{false};
  std::atomic<std::uint64_t> stick_{0};  // hardware::LiveOperator::pack()ed, for the guard
  std::atomic<std::int64_t> last_deflection_ns_{0};

  // The job (job_mutex_; planning holds plan_mutex_).
  mutable std::mutex job_mutex_, plan_mutex_;
  std::string job_path_;
  JobRequest job_request_;
  motion::Job programmed_;  // the loaded job before kerf and rapids (run from line trims it)
  std::optional<motion::PlannedRun> plan_;
  std::optional<motion::PlannedRun> frame_plan_;  // frame() to the runner
  nlohmann::json frame_json_;
  std::shared_ptr<const std::string> drawing_, report_, guard_drawing_;
  std::string tmp_dir_;
  std::vector<std::string> read_folders_;  // canonical: the job folder, the datasets, tmp_dir_
  int job_id_ = 0;
  // The faults now in force, [{kind, message, line}]: the last run's (a stop request is its
  // ending, not a fault), or the E-stop pressed since; reset() acknowledges them.
  nlohmann::json last_fault_json_ = nlohmann::json::array();
  // How the last run ended, in Summary's spelling (done, faulted, cancelled, ...); "idle"
  // before the first, "running" while one runs.
  std::string last_end_ = "idle";
  std::optional<GuardRequest> guard_request_;
  Latest<guard::GuardLive> guard_live_;
  std::atomic<bool> guard_live_valid_{false};

  // The runner.
  std::mutex cmd_mutex_;
  std::condition_variable cmd_cv_;
  Command cmd_ = Command::none;
  std::optional<int> cmd_from_line_;
  std::atomic<Activity> activity_{Activity::idle};
  std::atomic<bool> planning_{false};
  std::atomic<int> runs_finished_{0};
  std::atomic<Termination*> current_stop_{nullptr};  // the run's, for E-stop during planning
  std::mutex stop_mutex_;
  std::thread runner_;
};

const char* to_string(Panel::Activity a);

}  // namespace machplan::panel
