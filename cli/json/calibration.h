// The JSON form of a stored calibration (solvers/calibration/store.h): one form for
// `machplan calibrate history --json` and the panel's history.
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/calibration/store.h"

namespace machplan::cli {

// {"fit_id", "session_id", "machine", "status", "who", "created_utc", "log_path", "log_hash",
//  "active", "feed_factor": [x, y], "dead_band_mm_per_s": [x, y], "mm_per_count": [x, y],
//  "backlash_mm": [x, y], "fit": the fit as stored (null when the stored text is not JSON)}
nlohmann::json to_json(const calibration::StoredFit& fit);

}  // namespace machplan::cli
