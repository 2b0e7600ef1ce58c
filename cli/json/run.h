// The --json form of `machplan run` (solvers/motion/run.h).
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/motion/run.h"

namespace machplan::cli {

// The executor run's members (cli/json/executor.h, without the trace), then "controller",
// "max_contour_error_mm", "rms_contour_error_mm", "max_true_contour_error_mm",
// "rms_true_contour_error_mm", "lower_bound_s", "motion_lower_bound_s", "process_time_s",
// "planned_motion_s", "cycle_ratio", "motion_ratio", "motion_optimum_s", "optimum_ratio",
// "origin_mm", "origin_from", "warnings", "notes",
// "rapids": {"count", "re_routed", "blocked_straight", "without_clear_route", "zones_from_cuts",
// "declared_zones", "straight_length_mm", "programmed_length_mm", "planned_length_mm",
// "small_slugs_crossed", "detour_extra_mm", "detours": [{"source_line", "extra_length_mm",
// "reason"}]}, and with kerf compensation "kerf": {"width_mm", "loops", "compensated",
// "issues": [{"kind", "source_line", "message"}]}.
nlohmann::json to_json(const motion::RunOutcome& run);
// A frame's outline and settings (`run --json`'s and the panel's `frame`): x_mm and y_mm as
// [min, max], from_cuts, feed_mm_per_s, margin_mm.
nlohmann::json frame_json(const motion::FramePlan& frame);

}  // namespace machplan::cli
