// Tuning a controller's gains on test contours: the solver behind `machplan tune`.
//
//     minimise   J(k) / J(baseline)        J = max, RMS or ITAE contour error (evaluate.h)
//     over       k in the kind's gain box (engine/control/controller_factory.h, gain_specs),
//                the feed-forward gains held to their physical range (TuneOptions)
//     subject to g_0 = residual wobble at the gain margin / max_residual - 1   <= 0  (stability)
//                g_1 = step overshoot / max_overshoot - 1                      <= 0
//                g_2 = (saturation share - max share) / max share              <= 0
//                g_3 = largest following error / limit - 1                     <= 0
//                g_4 = +1 when a contour run faulted, else -1                  <= 0
//
// The baseline is the hand-tuned axial P controller (kind "p" with its default gains, i.e.
// the machine file's Kp); the start is the tuned kind's defaults, with the feed-forward gains
// at the drive model's values (TuneOptions::model_start). The optimiser is the two-stage DIRECT-L then COBYLA of optimizer.h, with log-scale gains searched in log space.
// The result says whether a feasible point was found; the gains returned are then feasible
// (never worse than the start when the start is feasible), else the least-violating ones
// with status "infeasible".
#pragma once

#include <string>
#include <vector>

#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "solvers/tuning/evaluate.h"
#include "solvers/tuning/optimizer.h"

namespace machplan::tuning {

struct TuneOptions {
  EvaluationOptions evaluation;
  std::string kind = "ccc";          // the factory's kind, canonically spelled (control::parse_controller_kind)
  Objective objective = Objective::max;
  OptimizerOptions optimizer;
  std::string baseline_kind = "p";   // hand-tuned axial P
  // Physical bounds on the feed-forward gains, narrower than the factory's boxes: velocity_ff
  // at most ff_margin / g (g: the drive's gain; 1/g cancels it exactly), acceleration_ff_s
  // at most ff_margin x (tau + latency periods x T) (what a first-order drive behind its
  // latency needs) and friction_ff_mm_per_s at most ff_margin x the machine file's Coulomb
  // friction (what a calibration measures as the dead band), backlash_ff_mm at most ff_margin x
  // the machine file's backlash. Beyond them a feed-forward stops modelling the drive and starts fitting
  // the test contour's friction: it then leads the setpoint, and cuts the corners of any
  // contour it was not tuned on. false searches the factory's whole boxes.
  bool physical_feed_forward = true;
  double ff_margin = 1.25;
  // With physical_feed_forward: start the feed-forward gains at the drive model's values (1/g,
  // tau, the Coulomb friction, the backlash) instead of the kind's defaults (zero).
  bool model_start = true;
  // Start values replacing the kind's defaults (names the kind does not have are refused).
  control::Gains start;
  // Gains held at the given values and not searched (e.g. feed-forward from a calibration, or
  // a part of the controller switched off: observer_per_s = 0). Not also in `start`.
  control::Gains fixed;
  // After the tuning, the baseline and the tuned gains are run once more under as many noise
  // draws the tuning never saw (the seeds after its own): the figure to expect on the machine,
  // since gains tuned on a few draws partly fit those draws' spikes. false skips it.
  bool fresh_check = true;
  // The tuning's deadline in seconds of work (the CLI's --time): each evaluation is charged the
  // machine time it simulated at kWorkPerMachineSecond, so the deadline decides the same way on
  // any computer (about wall-clock seconds on the 2-core PC the figures were measured on).
  double max_work_s = 25.0;
  // Throws InputError naming the field.
  void validate() const;
};

// Seconds of work charged per second of simulated machine time: one 1 ms period of the
// simulated axes, controller and executor costs about 2.5 us on the reference PC (2 cores,
// 2026; measured from `machplan tune` runs).
inline constexpr double kWorkPerMachineSecond = 2.5e-3;

// The tuned controller against the baseline on what both completed: the contours the baseline
// ran to their end without a fault. A baseline that faulted on a contour (its first long
// rapid beyond the following-error limit, say) has no contour error there to compare with.
struct Comparison {
  std::vector<std::string> contours;   // compared: the baseline and the tuned gains completed them
  std::vector<std::string> faulted;    // left out: the baseline or the tuned gains faulted on them (with why)
  double baseline_max_mm = 0.0, tuned_max_mm = 0.0, baseline_rms_mm = 0.0, tuned_rms_mm = 0.0;
  bool any() const { return !contours.empty(); }
  double max_ratio() const { return tuned_max_mm > 0 ? baseline_max_mm / tuned_max_mm : 0.0; }
  double rms_ratio() const { return tuned_rms_mm > 0 ? baseline_rms_mm / tuned_rms_mm : 0.0; }
};
Comparison compare(const Evaluation& baseline, const Evaluation& tuned);

struct TuneResult {
  std::string machine, kind;
  Objective objective = Objective::max;
  std::vector<control::GainSpec> specs;
  control::Gains start_gains, gains;
  control::Gains fixed;  // TuneOptions::fixed
  std::string start_from;  // "defaults", "drive-model feed-forward", "given gains", ...
  Evaluation baseline, start, tuned;
  // TuneOptions::fresh_check: the same under fresh noise, seeds fresh_seed .. + noise_runs - 1;
  // fresh_seed 0 when not run.
  Evaluation fresh_baseline, fresh_tuned;
  std::uint64_t fresh_seed = 0;
  OptimizerResult optimizer;
  Comparison improvement, fresh_improvement;  // tuned against the baseline (fresh: under fresh noise)
  // done; infeasible (no gains met the constraints: the least violating shown); cancelled,
  // deadline or budget (the search ended early: the best gains so far shown). Its reports are
  // report()'s text.
  Summary summary;
  std::string report() const;
};

// The constraint values g of the file comment for one evaluation.
std::vector<double> constraint_values(const Evaluation& e, const EvaluationOptions& o, double following_limit_mm);

// `termination` ends the search early (a stop request); the tuning's own deadline is
// TuneOptions::max_work_s and its budget the optimizer's max_evaluations. `progress` follows
// the evaluation budget.
TuneResult tune(const Evaluator& evaluator, const TuneOptions& options, Termination& termination,
                Progress* progress = nullptr);

}  // namespace machplan::tuning
