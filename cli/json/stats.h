// The --json forms of job statistics (solvers/session/job_stats.h), shared by
// `machplan consumables` and the web panel.
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/session/job_stats.h"

namespace machplan::cli {

// {"jobs", "pierces", "arc_on_s", "cycle_s", "cut_mm", "rapid_mm", "probes", "probes_skipped", "probe_s",
//  "faults"}
nlohmann::json to_json(const stats::Figures& f);
// {"id", "machine", "program", "program_hash", "started_utc", "status", "fault", "figures"}
nlohmann::json to_json(const stats::JobRecord& job);
// {"machine", "lifetime", "since_change", "last_change": {"utc", "who"} or null}
nlohmann::json to_json(const stats::MachineTotals& totals);

}  // namespace machplan::cli
