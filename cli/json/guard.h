// The --json form of `machplan guard` (solvers/guard/guard_run.h).
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/guard/guard_run.h"

namespace machplan::cli {

// {"profile", "machine", "side", "tool_radius_mm", "offset_method", "strategy", "tolerance_mm",
//  "latency_s", "feed_mm_per_s", "operator", "seed", "attempts", "strokes", "successes",
//  "invasions", "success_percent", "max_invasion_mm", "mean_undercut_mm", "max_undercut_mm",
//  "time_s", "roughing_time_s", "finishing_time_s", "guard_failsafe_ticks",
//  "guard_emergency_ticks", "warnings",
//  "per_attempt": [{"attempt", "start_mm", "aim_mm", "closest_at_mm", "speed_mm_per_s",
//  "closest_mm", "success", "invasion_mm", "undercut_mm", "time_s"}],
//  "finish": [{"allowance_mm", "completed", "fault", "time_s", "max_deviation_mm",
//  "rms_deviation_mm", "samples"}]}
nlohmann::json to_json(const guard::GuardRunResult& result);

}  // namespace machplan::cli
