// The executor: runs a Job on a Backend, one servo period at a time, with the torch sequenced
// and every fault ending in torch off and a controlled stop.
//
//   Job + one Trajectory per move step --> Executor::run(job, trajectories, backend)
//       per tick:  backend.exchange(outputs, inputs)           (paced by the backend)
//                  decode counters, check faults                (engine/control)
//                  step sequencer: move / torch on / torch off / dwell
//                  setpoint -> per-axis servo -> DAC codes      (planned mode)
//                  or vector timing -> DAC codes                (paper modes)
//                  contour error bookkeeping, trace sample
//
// Modes (ExecutorOptions::mode):
//   planned       ours. The feed planner's Trajectory is sampled every servo period (the
//                 real-time interpolator) and each axis runs the PID + feed-forward loop of
//                 engine/control/servo.h on the decoded encoder position.
//   paper_open    the paper's open-loop time control (section 5.4.1): each stretch is cut
//                 into equal vectors of about `blu_mm`; each vector is run by commanding the
//                 axis speeds F dx/L, F dy/L (times `calibration_factor`) for L/F seconds,
//                 with no position feedback.
//   paper_closed  the paper's closed loop (section 5.4.2): the same vectors, but at the end
//                 of each one the counters are read and the next vector is re-aimed from the
//                 measured position to the next vector end, after a computation time
//                 `paper_compute_s` during which the previous command still runs.
//
// Torch sequence (torch_on step): height axis to pierce height -> fire -> wait for arc OK
// (plasma, at most arc_ok_timeout_s; oxy-fuel: preheat first, no arc signal) -> pierce delay
// (a dwell step right after the torch_on IS the pierce delay, as programmed with G4;
// otherwise the machine's default) -> height axis to cut height. torch_off step: stop firing,
// retract. The torch is also turned off before any non-cutting move that finds it on, at the
// end of the job, at every fault and at every stop; it is never on while the machine is not
// executing a cutting sequence.
//
// Faults (FaultReport::Kind): following error (planned mode), encoder glitch and counter
// wrap misread (a counter reading no axis could produce in one period), E-stop, lost backend,
// arc start failure, arc lost while cutting, torch height timeout, and a stop requested by
// request_stop(). On any of them, in the same tick: torch off, height retract; then the
// commanded speed vector (the last DAC command, in mm/s) is ramped to zero at the machine's
// acceleration limit keeping its direction, then held at zero until the axes are at rest
// (measured, or for `stop_settle_s` when the feedback is no longer trusted), then the drives
// are disabled and the run ends. After the ramp no motion is commanded. A lost backend can
// not be commanded at all: the run ends at once and the backend's own watchdog must stop the
// machine (see engine/hardware/backend.h). The report keeps the last trusted position.
//
// Time budget: the servo period is 1 ms (the backend's). The executor's own work per tick
// (decoding two counters, two PID updates, a few Trajectory::sample calls, a handful of
// comparisons, a bounded nearest-segment search over at most 10 segments for the contour
// error, one trace store) must stay under 50 us on the target PC, leaving the rest of the
// period to the backend's I/O; bench/executor_bench.cpp measures about 0.09 us here
// (bench/results/executor.txt). The tick allocates nothing, takes no lock, does no I/O and
// logs nothing: all buffers (trace, paper-mode vectors) are filled or reserved before the
// first tick, and fault messages are composed after the run from the numbers recorded in the
// tick.
//
// Threading: run() occupies the calling thread until the job ends. request_stop() may be
// called from any thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "engine/executor/machine_setup.h"
#include "engine/hardware/backend.h"
#include "engine/motion/job.h"

namespace machplan::executor {

enum class Mode { planned, paper_open, paper_closed };
const char* to_string(Mode m);
// Parses "planned", "paper_open", "paper_closed"; throws InputError("--mode", ...) otherwise.
Mode mode_from_string(const std::string& s);

struct ExecutorOptions {
  Mode mode = Mode::planned;
  // Paper modes: vector length, mm (the paper's BLU; it found 3 to 5 mm best at 4 mm/s).
  double blu_mm = 3.0;
  // Paper modes: commanded speed = calibration_factor x programmed speed. 1 is uncalibrated;
  // 1 / 0.7 undoes the paper's drive gain exactly (the paper's "+30 %" gives 1.3 x 0.7 = 0.91).
  double calibration_factor = 1.0;
  // Seed and pacing for a simulated backend built by models/sim (simulate()); the executor
  // itself is deterministic and does not use them.
  std::uint64_t seed = 1;
  bool realtime = false;
  // paper_closed: time from reading the counters at a vector end to sending the re-aimed
  // command (the PC/XT's computation). Reconstructed; see tests/executor/paper_test.cpp.
  double paper_compute_s = 0.2;
  // Paper modes: send a zero speed before the first vector of each stretch (the paper's cure
  // for the start shock).
  bool paper_zero_first = true;
  // Paper modes: time at zero command after the last vector of a stretch before the next step.
  double paper_settle_s = 0.1;
  // Controlled stop: the axes count as at rest after their measured positions stay within one
  // count for this long; with untrusted feedback the stop waits `stop_settle_s` instead.
  double rest_window_s = 0.05;
  double stop_settle_s = 0.5;
  // Trace: record every `trace_every_ticks`-th tick (1 = all); false = no trace.
  bool record_trace = true;
  int trace_every_ticks = 1;
  // Throws std::invalid_argument naming field, value and rule.
  void validate() const;
};

struct FaultReport {
  enum class Kind {
    following_error,
    encoder_glitch,
    counter_wrap_misread,
    estop,
    lost_backend,
    arc_start_failed,
    arc_lost,
    torch_height_timeout,
    stop_requested
  };
  Kind kind = Kind::estop;
  double time_s = 0.0;        // since the start of the run
  int step = -1;              // index into Job::steps (-1: before the first step)
  int source_line = 0;        // program line of that step (or of the segment being cut)
  int axis = -1;              // 0 = X, 1 = Y, -1 = not axis-specific
  Eigen::Vector2d last_known_mm = Eigen::Vector2d::Zero();  // last trusted measured position
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();   // setpoint at the fault
  double value = 0.0;         // following error mm, jump counts, timeout s ... per kind
  std::string message;
};
const char* to_string(FaultReport::Kind k);

struct TraceSample {
  double t_s = 0.0;
  int step = -1;
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d measured_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d true_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::int32_t dac_x = 0, dac_y = 0;
  bool drives_enabled = false;
  bool torch_fire = false;
  bool arc_ok = false;
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
};

struct ExecutionResult {
  enum class Status { completed, faulted };
  Status status = Status::completed;
  std::string machine, source;
  Mode mode = Mode::planned;
  double cycle_time_s = 0.0;
  double torch_on_s = 0.0;            // time the torch burned (arc OK / oxygen on)
  double rapid_distance_mm = 0.0;     // programmed length of the rapid stretches completed
  int steps_completed = 0;
  std::vector<CutError> cuts;
  std::vector<FaultReport> faults;    // empty when completed; the first one stopped the run
  std::vector<TraceSample> trace;
  bool trace_truncated = false;
  bool stopped_at_rest = true;        // after a fault: the axes were seen at rest (false for lost backend)
  bool torch_off_at_end = true;

  double max_contour_error_mm() const;       // over all cuts, measured
  double max_true_contour_error_mm() const;  // over all cuts, truth (NaN if unknown)
  std::string report() const;                // human-readable summary
  nlohmann::json to_json(bool include_trace = false) const;
  // t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm,meas_y_mm,true_x_mm,true_y_mm,dac_x,dac_y,enabled,torch_fire,arc_ok
  void write_trace_csv(const std::string& path) const;  // throws InputError(path) on failure
};

using Trajectories = std::vector<std::unique_ptr<motion::Trajectory>>;

class Executor {
 public:
  // Throws std::invalid_argument when setup or options do not validate.
  Executor(MachineSetup setup, ExecutorOptions options);

  // Runs the job to its end or to the first fault. `trajectories[i]` is the planned motion of
  // step i when it is a move (null otherwise); paper modes do not use them (pass {}).
  // The machine is assumed to stand at job.start_mm.
  // Throws InputError (job.source, line) before moving anything when the job and the
  // trajectories disagree: sizes, a missing trajectory, a trajectory that does not start where
  // the previous motion ended or does not end at its stretch's end, a cutting move without
  // the torch on, a torch step on a machine without torch. Never throws once motion started.
  ExecutionResult run(const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend);

  // Asks a running run() to stop (torch off, controlled stop, reported as stop_requested).
  void request_stop() { stop_requested_.store(true, std::memory_order_relaxed); }

  const MachineSetup& setup() const { return setup_; }
  const ExecutorOptions& options() const { return options_; }

 private:
  MachineSetup setup_;
  ExecutorOptions options_;
  std::atomic<bool> stop_requested_{false};
};

}  // namespace machplan::executor
