// The --json forms of `machplan tune` (solvers/tuning).
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/tuning/acc_tuning.h"
#include "solvers/tuning/evaluate.h"
#include "solvers/tuning/optimizer.h"
#include "solvers/tuning/tune.h"

namespace machplan::cli {

// {"max_contour_error_mm", "rms_contour_error_mm", "itae_mm_s2", "saturation_share",
//  "max_following_error_mm", "step_overshoot", "margin_residual", "faulted",
//  "contours": [{"contour", "samples", "max_contour_error_mm", "max_at": {"t_s", "x_mm",
//  "y_mm", "line"}, "rms_contour_error_mm", "itae_mm_s2", "saturation_share",
//  "max_following_error_mm", "faulted", "fault"}]}; a figure that is not finite is null.
nlohmann::json to_json(const tuning::Evaluation& evaluation);

// {"evaluations", "time_s", "feasible", "stopped", "objective", "global" and "local":
//  {"algorithm", "evaluations", "time_s", "stop_reason"}}
nlohmann::json to_json(const tuning::OptimizerResult& result);

// {"machine", "controller", "objective", "gains": {...}, "start_gains": {...}, "fixed": [...],
//  "start_from", "baseline", "start", "tuned" (each an Evaluation, above), "optimizer",
//  "status" (to_string(Status)), "usable" (the gains may be used: done, or a deadline or budget
//  that left feasible gains), and when checked "fresh": {"first_seed", "baseline", "tuned"}}
// The tuned controller against the baseline on what the baseline completed: no ratio when it
// completed nothing.
nlohmann::json to_json(const tuning::Comparison& comparison);
nlohmann::json to_json(const tuning::TuneResult& result);

// {"law": "fixed_gain" | "variable_gain", "gain_name", "start_gain", "gain", "before" and
//  "after": {"worst_settling_s", "worst_overshoot", "steps": [{"settling_s", "overshoot"}]},
//  "optimizer", "status", "usable"}
nlohmann::json to_json(const tuning::AccTuningResult& result);

// Koren's test and the tunings: {"koren_fixed_kc_0_5": {"settled": [{"t_s", "depth_mm",
//  "feed_mm_per_rev", "force_n"}]}, "tunings": [AccTuningResult above, with "settled"],
//  "status"}
nlohmann::json to_json(const tuning::AccStudy& study);

}  // namespace machplan::cli
