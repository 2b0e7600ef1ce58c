// Scoring a controller and its gains on the simulated machine: the cost function behind
// `machplan tune`.
//
// Each test contour (a line at an angle, a full circle, or a part program) becomes a Job placed
// in the middle of the machine's travel and is planned ONCE (the feed planner of `machplan
// run`). Every evaluation then builds the controller (engine/control/controller_factory.h),
// a fresh simulated backend (models/backends, the plant with Coulomb friction and speed
// noise, same seed every time so that two gain vectors meet the same disturbances, realtime
// pacing off) and an Executor, and runs the job exactly as `machplan run` does
// (solvers/motion/run.h); nothing here simulates the machine itself.
//
// Measures, from the run's trace (every servo period):
//   contour error  distance from the tool (the simulator's true position, or the decoded
//                  encoders with use_true_position = false) to the path of the feed moves:
//                  max, RMS, and ITAE = sum over samples of t |e| T (t from the start of each
//                  move), mm s^2. Rapids and the end hold are not counted. The path is the one
//                  the servo is asked to follow, the planner's executed path: the program with
//                  sharp corners blended within the planner's path tolerance (0.01 mm), which
//                  is the planner's deviation, the same for every controller.
//   saturation     share of the feed-move periods in which a DAC code sat at its limit
//   following      largest |setpoint - measured position| per axis, mm
// and the constraint tests, each a short run of the same executor on the same backend:
//   overshoot      a step of `step_mm` on both axes (a setpoint that jumps, no feed-forward):
//                  the largest travel past the target, as a fraction of the step
//   stability      the same step with the drive's gain multiplied by `margin_gain_factor` (a
//                  gain margin of 20 log10 of it dB): the loop must still settle, i.e. the
//                  peak-to-peak wobble of the error over the last third of the window must be
//                  at most `max_residual` of the step. A loop that is stable only without the
//                  margin, or diverges, fails here.
//
// Determinism: same options and gains, same numbers. Not thread-safe: one Evaluator per
// thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "engine/control/controller_factory.h"
#include "engine/executor/executor.h"
#include "engine/motion/feed_planner.h"
#include "engine/motion/job.h"
#include "models/cutting/machine_config.h"

namespace machplan::tuning {

// One test contour of the command line: line:ANGLE_DEG:FEED_MM_MIN, circle:RADIUS_MM:FEED_MM_MIN,
// corner:TURN_DEG:FEED_MM_MIN (two 25 mm lines, the second turned by TURN_DEG from the first:
// the canonical sharp corner), square:SIDE_MM:FEED_MM_MIN (the square of the usual contouring
// test pieces, counter-clockwise from its lower left corner), program:FILE.ngc.
struct TestContour {
  enum class Kind { line, circle, corner, square, program };
  Kind kind = Kind::circle;
  double angle_deg = 0.0;         // line: direction; corner: turn
  double radius_mm = 20.0;
  double length_mm = 50.0;        // line; corner: both legs together; square: the side
  double feed_mm_per_min = 960.0;
  std::string path;               // program
  std::string spec;               // as written
};
// Throws InputError::field("contours", ...) naming what is wrong.
TestContour parse_contour(const std::string& spec);
// The test contour when none is given: a 20 mm circle at 960 mm/min, the contouring test the
// tuning figures are reported on (both axes reverse, so friction, backlash and the axes'
// mismatch all show in the contour error).
inline constexpr const char* kDefaultTestContour = "circle:20:960";

enum class Objective { max, rms, itae };
const char* to_string(Objective o);
// "max", "rms", "itae"; InputError::field("objective", ...) otherwise.
Parsed<Objective> parse_objective(std::string_view text);

struct EvaluationOptions {
  std::string machine = "xy_table";   // bundled name or machine YAML path
  std::uint64_t seed = 1;             // the simulator's (speed noise)
  // Runs per test contour, each under its own noise (seeds seed .. seed + noise_runs - 1):
  // a contour's maximum is the largest over its runs, its RMS pooled, its ITAE their mean.
  // One run tunes the gains to one draw of the noise, whose worst spike then decides the
  // maximum; a few runs tune them to the machine.
  int noise_runs = 1;
  bool use_true_position = true;      // contour error from the truth (false: from the encoders)
  bool constraints = true;            // run the step tests
  double step_mm = 0.25;               // small enough not to saturate a stiff loop
  double step_window_s = 0.4;
  double margin_gain_factor = 1.5;    // stability margin: 3.5 dB of drive gain
  double max_residual = 0.05;         // of the step, peak to peak, last third of the window
  double max_overshoot = 0.25;        // of the step (damping ratio about 0.4 or more; the machines' hand-tuned P loops overshoot about 19 %)
  double max_saturation_share = 0.02; // of the feed-move periods
  double following_error_limit_mm = 0.0;  // 0: the machine's servo limit
  // Throws InputError naming the field.
  void validate() const;
};

struct ContourScore {
  std::string contour;
  std::size_t samples = 0;
  double max_mm = 0.0, rms_mm = 0.0, itae_mm_s2 = 0.0;
  // Where the maximum happened (of the run that had it): time from the run's start, the
  // tool's position on the machine, and the program line of the nearest segment (1 for the
  // built-in contours).
  double max_at_s = 0.0;
  double max_at_x_mm = 0.0, max_at_y_mm = 0.0;
  int max_at_line = 0;
  double saturation_share = 0.0;
  double max_following_error_mm = 0.0;
  bool faulted = false;
  std::string fault;
};

struct Evaluation {
  std::vector<ContourScore> contours;
  double max_mm = 0.0, rms_mm = 0.0, itae_mm_s2 = 0.0;  // max of maxima, pooled RMS, sum of ITAE
  double saturation_share = 0.0, max_following_error_mm = 0.0;
  double overshoot = 0.0;        // fraction of the step (NaN when constraints are off)
  double margin_residual = 0.0;  // fraction of the step; infinity when the margin run faulted
  bool faulted = false;          // a contour run faulted (following error, ...)
  double machine_s = 0.0;        // machine time simulated for this evaluation, all runs, s
  double value(Objective o) const;
};

class Evaluator {
 public:
  // Loads the machine, builds and plans every contour's job. Throws InputError for a bad
  // machine, program or option, Infeasible when a contour does not fit the machine's travel.
  Evaluator(const EvaluationOptions& options, const std::vector<TestContour>& contours);
  ~Evaluator();

  Evaluation evaluate(const std::string& kind, const control::Gains& gains) const;
  // One contour's run with its trace, for plots.
  executor::ExecutionResult run_contour(std::size_t i, const std::string& kind, const control::Gains& gains) const;
  // The contour error of contour i against time (the measured samples of evaluate()), for plots.
  struct ErrorSeries {
    std::vector<double> t_s, error_mm;
  };
  ErrorSeries error_series(std::size_t i, const std::string& kind, const control::Gains& gains) const;

  const cutting::MachineConfig& machine() const { return machine_; }
  const control::ControllerPlant& plant() const { return plant_; }
  const EvaluationOptions& options() const { return options_; }
  const std::vector<TestContour>& contours() const { return contours_; }
  const motion::Job& job(std::size_t i) const;

 private:
  struct Prepared;
  EvaluationOptions options_;
  std::vector<TestContour> contours_;
  cutting::MachineConfig machine_, margin_machine_;
  executor::MachineSetup setup_;
  control::ControllerPlant plant_;
  std::vector<std::unique_ptr<Prepared>> prepared_;
  std::unique_ptr<Prepared> step_;
  ContourScore score(const Prepared& p, const executor::ExecutionResult& r, ErrorSeries* series) const;
  double following_limit_mm_ = 0.0;
};

}  // namespace machplan::tuning
