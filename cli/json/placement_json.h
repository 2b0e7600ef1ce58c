// JSON of placement and check results (machplan place --json, machplan check --json), as free
// functions over the solvers' own types: the command line and the web panel share them. Field
// names carry units.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "solvers/placement/check/checker.h"
#include "solvers/placement/search/search.h"

namespace machplan::cli {

nlohmann::json finding_json(const placement::Finding& f);
// A report: placement, free, per kind the smallest clearance and the finding, margins.
nlohmann::json check_report_json(const placement::CheckReport& r);
nlohmann::json counts_json(const placement::CheckCounts& c, std::size_t poses);
nlohmann::json summary_json(const Summary& s);
// The scene as placement read it: machine, workpiece frame, tool tips below the bottom face.
nlohmann::json scene_json(const placement::Scene& scene);
nlohmann::json placement_result_json(const placement::Scene& scene, const placement::PlacementResult& r,
                                     const std::string& strategy);
nlohmann::json check_result_json(const placement::Scene& scene, const placement::CheckResult& r);

}  // namespace machplan::cli
