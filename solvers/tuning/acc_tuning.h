// Tuning the adaptive control constraint's gain (engine/control/acc.h) with NLopt on the turning
// model (models/turning/turning_process.h): the
// fastest settling of the cutting force after a depth-of-cut step, without overshoot, over a
// range of depths.
//
// For each base depth a in `base_depths_mm` the loop engages at a and, once settled, meets a
// step to a + `depth_step_mm` (a stepped shaft). Objective: the worst settling time (into
// +-band of F_r) over the steps; a step that never settles counts as twice its window.
// Constraint: the overshoot of every step (models/turning/turning_process.h, acc_step_response) at most
// `max_overshoot` of F_r. The one gain is Kc for the fixed law and L0 for the variable-gain
// law; the optimiser is the two-stage one of solvers/tuning/optimizer.h.
//
// acc_study() is the whole of `machplan tune --acc`: Koren's test (his fixed Kc = 0.5 on the
// paper's depth steps) as the baseline, each law asked for tuned, and the same steps run again
// with each tuned gain, with one report for people.
#pragma once

#include <string>
#include <vector>

#include "engine/control/acc.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "models/turning/turning_process.h"
#include "solvers/tuning/optimizer.h"

namespace machplan::tuning {

struct AccTuningOptions {
  turning::TurningProcess process;
  control::AccOptions acc;               // variable_gain chooses the law; its gain is the start
  std::vector<double> base_depths_mm{1.0, 2.0, 3.0, 4.0, 5.0, 6.0};
  double depth_step_mm = 2.0;
  double settle_before_step_s = 3.0;     // from engagement to the step
  double window_s = 3.0;                 // after the step
  double band = 0.02;                    // settling band, fraction of F_r
  double max_overshoot = 0.02;           // fraction of F_r
  double gain_min = 0.02, gain_max = 4.0;
  OptimizerOptions optimizer;            // defaults below: 150 evaluations
  // Deadline in seconds of work: each evaluation (the same simulated depth steps) is charged
  // kAccWorkPerEvaluation_s, about its cost on the reference PC, so the deadline decides the
  // same way on any computer.
  double max_work_s = 25.0;
  AccTuningOptions() { optimizer.max_evaluations = 150; }
  // Throws InputError naming the field.
  void validate() const;
};

struct AccScore {
  double worst_settling_s = 0.0;
  double worst_overshoot = 0.0;
  std::vector<turning::AccStepResponse> steps;  // one per base depth
};

// The score of one gain (Kc or L0 by options.acc.variable_gain).
AccScore score_acc_gain(const AccTuningOptions& options, double gain);

inline constexpr double kAccWorkPerEvaluation_s = 1.2e-3;

struct AccTuningResult {
  bool variable_gain = false;
  double start_gain = 0.0, gain = 0.0;
  AccScore before, after;
  OptimizerResult optimizer;
  Summary summary;      // done, infeasible, or what ended the search early; reports: report()
  std::string report() const;
};

AccTuningResult tune_acc(const AccTuningOptions& options, Termination& termination);

// Koren's test runs this long: engagement at 1 s, steps at 4 and 7 s, each settled well before
// the next (turning::koren_depth_steps()).
inline constexpr double kKorenTestS = 10.0;

// Which laws acc_study tunes.
enum class AccLaws { fixed, variable, both };

// The settled state of a run before a depth change (and at its end).
struct AccSettled {
  double t_s = 0.0, depth_mm = 0.0, feed_mm_per_rev = 0.0, force_n = 0.0;
};

struct AccStudy {
  std::vector<turning::DepthChange> steps;  // Koren's depth steps
  double duration_s = kKorenTestS;
  double reference_force_n = 0.0;           // F_r
  std::vector<turning::AccSample> koren;    // the steps with the options' fixed gain (Koren's Kc = 0.5)
  std::vector<AccTuningResult> tunings;     // one per law tuned, fixed first
  std::vector<std::vector<turning::AccSample>> tuned_runs;  // the steps with each tuned gain
  // done when every tuning is; else the first tuning's that is not (a usable one stays usable).
  // full: the baseline's settled states, then each tuning's report.
  Summary summary;

  // The settled feed and force 0.1 s before each depth change after the first, and at the end.
  std::vector<AccSettled> settled(const std::vector<turning::AccSample>& run) const;
};

// Runs Koren's test with `base` (its acc gives the baseline's law and gain), tunes the laws
// asked for (each from `base`, with its own deadline and budget, under `termination`) and
// runs the test again with each tuned gain.
AccStudy acc_study(const AccTuningOptions& base, AccLaws laws, Termination& termination);

}  // namespace machplan::tuning
