// The --json form of an executor run (engine/executor/executor.h).
#pragma once

#include <nlohmann/json.hpp>

#include "engine/executor/executor.h"

namespace machplan::cli {

// {"source", "machine", "mode", "backend", "status": how the run ended (Summary's: "done", "faulted",
//  "cancelled", "deadline", "budget"), "cycle_time_s",
//  "torch_on_s", "rapid_distance_mm", "steps_completed", "stopped_at_rest", "torch_off_at_end",
//  "truth_available" (false: the backend knows only what it measures, every true figure null),
//  "cuts": [{"stretch", "source_line", "samples", "complete", "max_contour_error_mm",
//  "rms_contour_error_mm", "max_true_contour_error_mm", "rms_true_contour_error_mm"}],
//  "faults": [{"kind", "time_s", "step", "source_line", "axis", "last_known_mm",
//  "commanded_mm", "value", "message"}]}; with `include_trace`, also "trace_columns" and
// "trace" (one array of those columns per servo period). Unknown true errors are null.
nlohmann::json to_json(const executor::ExecutionResult& result, bool include_trace = false);

}  // namespace machplan::cli
