// The executor: runs a Job on a Backend, one servo period at a time, with the torch sequenced
// and every fault ending in torch off and a controlled stop.
//
// One tick (Session::tick), in this order:
//
//   backend.exchange(outputs, inputs)          paced by the backend (engine/hardware/backend.h)
//   FeedbackAdapter: decode counters or take positions      feedback_adapter.h
//   Supervisor: faults from the inputs (E-stop, watchdog, encoder, arc, stop request)
//   step machine: dispatch the job's steps; moves run on the setpoint source, torch steps on
//       the TorchSequencer (torch_sequencer.h), dwells and the end hold on the clock
//   SetpointSource -> Demand                   planned_source.h | blu_vector_source.h | jog_source.h
//   [DemandFilter]                             e.g. the hybrid guard, between source and controller
//   Controller (all axes at once) -> speed command per axis, unless the demand is an open-loop
//       speed (paper modes)                    engine/control/controller.h, pid_ff_controller.h
//   Supervisor: following error, stalled axis, saturated drive off the contour; during a stop,
//       the ramp, settle and disable           supervisor.h
//   FeedbackAdapter: command -> DAC codes or position commands
//   ContourMonitor, trace (TraceRecorder in memory, TraceStream to a CSV file)
//
// Modes (ExecutorOptions::mode) choose the setpoint source when the caller gives none:
//   planned       ours: the feed planner's Trajectory sampled every period, PID + feed-forward
//   paper-open    the thermal-cutting paper's open-loop time control over vectors of `blu_mm`
//   paper-closed  the same vectors re-aimed from the encoders after `paper_compute_s`
//   jog           an operator's joystick through the backend's operator inputs (JogSource);
//                 runs no job: the session lasts until the operator presses cycle start
//
// The operator (OperatorInputs, engine/hardware/backend.h), read at the start of every tick:
//   feed hold (rising edge) the planned motion comes to rest along the path, the shortest stop
//                          the acceleration and jerk limits allow (time_scale.h); in a cut
//                          the torch burns on while the axes brake and goes off just before
//                          they stop; a spindle keeps turning. A hold during a pierce puts the
//                          torch out and the pierce starts over on resume; dwells run on, and
//                          the next move starts held. Each hold is in ExecutionResult::holds.
//   cycle start            resumes a hold once the axes are at rest: a held cut is pierced
//                          again where the machine stands (an oxy-fuel preheat flame was
//                          kept), then the move goes on from rest within the same limits
//   feed override          0 .. 200 % of the plan on feed moves, reached within the limits
//                          (above 100 % only while the plan cruises, within the axes'
//                          speeds); 0 % holds like the button and lets go when it rises
//   rapid override         1 .. 100 % on rapids
//   torch enable (a level) off: the torch_on steps are skipped, the cuts run dry; turned off
//                          while the torch fires (or pierces), it holds the job, and the resume
//                          goes on dry
//   paused motion          while a plasma or oxy-fuel job is held at rest with its torch off:
//                          along the program's path, back or on, across moves and cuts (a
//                          distance, or a speed held), at the machine's paused-motion speed;
//                          the resume pierces where it stands when that is in a cut. Each is
//                          in ExecutionResult::paused_motions
//   stop (rising edge)     the job ends: operator_stop, torch off, controlled stop
// The paper modes' vector sources run at their one speed and take no hold or override.
//
// Faults (FaultKind, supervisor.h): following error, encoder glitch, counter wrap misread,
// E-stop, lost backend, watchdog, arc start failure, arc lost while cutting, torch height
// timeout, axis stalled, drive saturated off the contour, the operator's stop, stop requested (the run's
// Termination ended: a stop request, its deadline in machine time or its budget of periods;
// engine/common/termination.h). On any of them, in the same tick: torch off and retract;
// then the controlled stop of the supervisor; the report keeps the last trusted position.
//
// Time budget: the servo period is 1 ms (the backend's). The executor's own work per tick (two
// counter decodes, a few Trajectory samples, the controller, a handful of comparisons, a
// nearest-segment search over at most 10 segments, one trace store) must stay under 50 us on
// the target PC, leaving the rest of the period to the backend's I/O. bench/executor_bench.cpp
// measures the distribution (bench/results/executor.txt). The tick allocates nothing, takes no
// lock, does no I/O and logs nothing (tests/executor/realtime_test.cpp counts allocations): all
// buffers are filled or reserved and touched before the first tick, and fault messages are
// composed after the run from numbers recorded in the tick.
//
// Threading: run() occupies the calling thread until the job ends. The run's Termination may
// be ended from any thread (its stop request also from a signal handler), and its Progress
// read from any thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/latest.h"
#include "engine/common/progress.h"
#include "engine/common/termination.h"
#include "engine/common/names.h"
#include "engine/common/stop.h"
#include "engine/common/summary.h"
#include "engine/control/controller.h"
#include "engine/control/pid_ff_controller.h"
#include "engine/executor/blu_vector_source.h"
#include "engine/executor/contour_monitor.h"
#include "engine/executor/feedback_adapter.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/live_state.h"
#include "engine/executor/machine_setup.h"
#include "engine/executor/planned_source.h"
#include "engine/executor/setpoint_source.h"
#include "engine/executor/supervisor.h"
#include "engine/executor/torch_sequencer.h"
#include "engine/executor/trace.h"
#include "engine/hardware/backend.h"
#include "engine/motion/job.h"

namespace machplan::executor {

enum class Mode { planned, paper_open, paper_closed, jog };
// "planned", "paper-open", "paper-closed", "jog" (the README's spelling).
const char* to_string(Mode m);
// The inverse of to_string; the old spellings "paper_open" and "paper_closed" are accepted with
// a note. InputError::field("mode", ...) listing the modes otherwise.
Parsed<Mode> parse_mode(std::string_view text);

struct ExecutorOptions {
  Mode mode = Mode::planned;
  // Paper modes: vector length, mm (the paper's BLU; it found 3 to 5 mm best at 4 mm/s).
  double blu_mm = 3.0;
  // Paper modes: commanded speed = calibration_factor x programmed speed. 1 is uncalibrated;
  // 1 / 0.7 undoes the paper's drive gain exactly (the paper's "+30 %" gives 1.3 x 0.7 = 0.91).
  double calibration_factor = 1.0;
  // paper_closed: time from reading the counters at a vector end to sending the re-aimed
  // command (the PC/XT's computation). Reconstructed; see tests/executor/paper_test.cpp.
  double paper_compute_s = 0.2;
  // Paper modes: send a zero speed before the first vector of each stretch (the paper's cure
  // for the start shock).
  bool paper_zero_first = true;
  // Paper modes: time at zero command after the last vector of a stretch before the next step.
  double paper_settle_s = 0.1;
  // Jog mode: the operator's speeds and limits.
  JogOptions jog;
  // Controlled stop and the supervisor's checks.
  SupervisorOptions supervisor;
  // Trace in memory: record every `trace_every_ticks`-th tick (1 = all); false = no trace.
  bool record_trace = true;
  int trace_every_ticks = 1;
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// FaultReport::Kind is the supervisor's FaultKind.
struct FaultReport {
  using Kind = FaultKind;
  Kind kind = Kind::estop;
  double time_s = 0.0;        // since the start of the run
  int step = -1;              // index into Job::steps (-1: before the first step)
  int source_line = 0;        // program line of that step (or of the segment being cut)
  // 0 = X, 1 = Y, 2 = the torch height axis (torch_breakaway: its float switch closed while the
  // torch fired, not the breakaway switch), -1 = not axis-specific
  int axis = -1;
  Eigen::Vector2d last_known_mm = Eigen::Vector2d::Zero();  // last trusted measured position
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();   // setpoint at the fault
  double value = 0.0;         // following error mm, jump counts, timeout s ... per kind
  std::string message;
};

// One feed hold (the operator's button, or a feed override of 0 %): where it came, how the
// machine stopped along the path, and how the job went on.
struct HoldReport {
  double t_s = 0.0;                 // the input, since the start of the run
  int step = -1;
  int source_line = 0;
  bool in_cut = false;              // the torch was cutting at the input
  bool torch_off = false;           // the hold turned it off (just before rest) and the resume pierced again;
                                    // false when the cut reached its end while the machine braked
  bool in_rapid = false;
  bool by_override = false;         // a 0 % feed override, not the button
  bool by_arc_loss = false;         // the arc went out in a cut (machine's on_arc_loss: recover)
  bool by_torch_disable = false;    // the operator switched the torch off while it fired
  // Paused motion: how far the machine moved along the path while held, mm (negative: back
  // along the cut), before the re-pierce; the sum of the hold's PausedMotionReports.
  double recovered_mm = 0.0;
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();  // commanded point at the input
  double speed_mm_per_s = 0.0;      // commanded path speed at the input
  // Limits of the stop along the path at the input (tangential: what the normal acceleration
  // leaves, at most the axes' A and J), for the jerk-limited stopping distance.
  double stop_acceleration_mm_per_s2 = 0.0, stop_jerk_mm_per_s3 = 0.0, acceleration_mm_per_s2 = 0.0;
  bool stopped = false;             // the motion came to rest
  double stop_s = 0.0;              // from the input to rest
  Eigen::Vector2d stop_mm = Eigen::Vector2d::Zero();      // commanded point at rest
  double distance_to_stop_mm = 0.0; // along the path, commanded
  double off_path_mm = 0.0;         // largest distance of the commanded point from the path while stopping
  double off_path_measured_mm = 0.0;// the same for the measured position
  bool torch_off_before_rest = true;// in a cut: the torch was off before the axes came to rest
  double resumed_at_s = std::numeric_limits<double>::quiet_NaN();
  double repierce_s = 0.0;          // the re-pierce before moving on (cuts)
  // The jerk-limited stopping distance from the state at the input (S-curve with the limits
  // above), mm: the shortest stop the limits allow.
  double jerk_limited_stop_mm() const;
};

// One paused motion: while a job was held at rest, the machine moved along the program's path
// with the torch off (the operator's request, or the automatic backing up after a lost arc),
// from its start until it came to rest again.
struct PausedMotionReport {
  double t_s = 0.0, end_s = 0.0;    // its start and its end, since the start of the run
  int from_step = -1, to_step = -1; // the steps of the moves it started and ended on
  int from_line = 0, to_line = 0;   // and their program lines (the segment's)
  Eigen::Vector2d from_mm = Eigen::Vector2d::Zero(), to_mm = Eigen::Vector2d::Zero();  // commanded
  double moved_mm = 0.0;            // along the path, signed (negative: back)
  bool by_arc_loss = false;         // the automatic backing up to where the arc went out
};

// One initial height sense before a pierce (engine/executor/torch_sequencer.h): a probe, or the
// skip rule keeping the last probe's surface.
struct ProbeReport {
  double t_s = 0.0;                 // when the surface was known
  int step = -1, source_line = 0;
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();  // where the surface was found (under the torch or the offset probe)
  const char* sensor = "";          // "ohmic", "float_switch", "offset_probe", or "" when skipped (static text)
  bool skipped = false;
  double surface_mm = 0.0;          // the surface found (or kept), height frame (0: nominal)
  double duration_s = 0.0;          // the probe's own time (0 when skipped)
  // The torch's true height over the plate when it fired, minus the pierce height, mm, when the
  // backend knows the truth (a simulator); NaN otherwise, or when the torch never fired.
  double pierce_height_error_mm = std::numeric_limits<double>::quiet_NaN();
};

// Torch height control over one cut, from the backend's truth (the torch's distance to the
// plate; a simulator knows it). Measured over the periods THC held the height (engine/
// executor/thc.h: armed, once the voltage first came within the threshold of its target),
// whether THC was allowed to act or not: without THC these are the sheet's warp as the torch
// saw it.
struct ThcFigures {
  std::size_t samples = 0;
  double max_mm = std::numeric_limits<double>::quiet_NaN();  // largest |gap - cut height|
  double rms_mm = std::numeric_limits<double>::quiet_NaN();
  double active_share = 0.0;   // of those periods, THC acted (allowed, not locked)
  double target_v = 0.0;       // the voltage it held (sampled, or the material's)
  // Anti-dive: the largest change of the torch height over one velocity lock (corners, small
  // holes) and over one void lock (kerf crossings), mm.
  double velocity_lock_change_mm = 0.0, void_lock_change_mm = 0.0;
  double velocity_locked_s = 0.0, void_locked_s = 0.0;  // how long each lock held the height
};

// Contour error of one cutting stretch: distance from the position to the stretch's
// programmed XY path (its Segments), over the ticks in which the torch burns while that
// stretch is executed.
struct CutError {
  std::size_t stretch = 0;
  int source_line = 0;         // first line of the stretch
  std::size_t samples = 0;
  double max_mm = 0.0, rms_mm = 0.0;            // from the measured (decoded) position
  double max_true_mm = std::numeric_limits<double>::quiet_NaN();  // from the backend's truth
  double rms_true_mm = std::numeric_limits<double>::quiet_NaN();
  bool complete = false;       // the stretch ran to its end
  int material = -1;           // index into Job::materials (-1: the machine's torch settings)
  ThcFigures thc;              // samples 0: no THC figures (no height axis, or never armed)
};

struct ExecutionResult {
  // How the run ended (engine/common/summary.h): done; faulted (a fault stopped it); cancelled
  // (the operator's stop, or a stop request); deadline or budget (the run's Termination ran
  // out). The message is the first fault's; the full report is report().
  Summary summary;
  std::string machine, source, backend;
  Mode mode = Mode::planned;
  double cycle_time_s = 0.0;
  double torch_on_s = 0.0;            // time the torch burned (arc OK / oxygen on)
  int ramp_pierces = 0;               // pierces that moved along their cut (a material's ramp pierce)
  int dry_pierces = 0;                // torch_on steps skipped: the operator's torch switch was off
  double rapid_distance_mm = 0.0;     // programmed length of the rapid stretches completed
  double cut_distance_mm = 0.0;       // programmed length of the cut stretches completed (counted after the run)
  int steps_completed = 0;
  std::vector<CutError> cuts;
  std::vector<FaultReport> faults;    // empty when done; the first one stopped the run
  std::vector<HoldReport> holds;      // every feed hold, in order (at most kMaxHolds are kept)
  std::size_t holds_dropped = 0;
  std::vector<ProbeReport> probes;    // every probe, in order (at most kMaxProbes are kept)
  std::size_t probes_dropped = 0;
  std::vector<PausedMotionReport> paused_motions;  // in order (at most kMaxPausedMotions are kept)
  std::size_t paused_motions_dropped = 0;
  std::vector<TraceSample> trace;
  bool trace_truncated = false;
  std::size_t trace_streamed = 0;     // samples written to a TraceStream
  std::size_t trace_stream_dropped = 0;
  // What the backend had to say after the run that the executor could not know (a simulator:
  // an injected fault that never took effect).
  std::vector<std::string> backend_notes;
  bool stopped_at_rest = true;        // after a fault: the axes were seen at rest (false for lost backend)
  bool torch_off_at_end = true;
  // The backend knew the true position (a simulator). A machine knows only what it measures:
  // without truth, the cuts' true errors are NaN and the reports say the truth is unavailable.
  bool truth_available = false;

  double max_contour_error_mm() const;       // over all cuts, measured
  double max_true_contour_error_mm() const;  // over all cuts, truth (NaN if unknown)
  std::string report() const;                // human-readable summary
  // kTraceCsvHeader's columns (engine/executor/trace.h)
  void write_trace_csv(const std::string& path) const;  // atomically; throws OutputError(path) on failure
};

// What a run is made of beyond the job and the backend; every part is optional.
struct RunParts {
  SetpointSource* source = nullptr;          // default: the one the mode names
  DemandFilter* filter = nullptr;            // between source and controller (the hybrid guard)
  control::Controller* controller = nullptr; // default: PidFfController on the machine's gains
  TraceStream* trace_stream = nullptr;       // streams the trace to CSV during the run
  // When the run ends early: polled once per period; a stop request, a deadline (charged one
  // servo period of machine time per tick) or a budget (one unit per tick) ends the run with a
  // stop_requested fault, torch off and a controlled stop, and the fault's message says which.
  // Null: the run ends only with its job or a fault.
  Termination* termination = nullptr;
  // For a display thread: the share of the job's expected machine time run so far (0 .. 1;
  // 1 once the run is over), reported each period. The expected time is `expected_s` when the
  // caller knows it (the planned motion plus the torch process), else the executor's own
  // estimate, which counts the torch's timeouts and so runs long.
  Progress* progress = nullptr;
  double expected_s = 0.0;
  // For a display: the machine's state, published at the end of every period (engine/
  // executor/live_state.h); null: not published.
  Latest<LiveState>* live = nullptr;
};

inline constexpr std::size_t kMaxHolds = 1024;
inline constexpr std::size_t kMaxProbes = 4096;
inline constexpr std::size_t kMaxPausedMotions = 1024;

class Executor;

// One run, tick by tick, for callers that drive the loop themselves (tests, calibration
// routines); Executor::run() is a Session run to its end.
class Session {
 public:
  // Validates job, backend and parts against the machine and prepares every buffer. Throws
  // InputError (job.source, line; or the machine and backend names) before anything moves.
  Session(Executor& ex, const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend,
          const RunParts& parts = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  // One servo period; false once the run is over. Real time (see the file comment).
  bool tick() noexcept;
  // After the last tick: the result (allocates; composes the fault messages).
  ExecutionResult finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class Executor {
 public:
  // Throws InputError when setup or options do not validate.
  Executor(MachineSetup setup, ExecutorOptions options);

  // Runs the job to its end or to the first fault. `trajectories[i]` is the planned motion of
  // step i when it is a move (null otherwise); the other sources do not use them (pass {}).
  // The machine is assumed to stand at job.start_mm. Throws InputError before moving anything
  // when the job, the trajectories, the backend and the machine disagree (sizes, a missing
  // trajectory, a trajectory that does not start where the previous motion ended, a cutting
  // move without the torch on, a torch step on a machine without torch, a backend whose
  // period or axis signals differ from the machine file's). Never throws once motion started.
  ExecutionResult run(const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend,
                      const RunParts& parts = {});

  const MachineSetup& setup() const { return setup_; }
  const ExecutorOptions& options() const { return options_; }

 private:
  friend class Session;
  MachineSetup setup_;
  ExecutorOptions options_;
};

}  // namespace machplan::executor
