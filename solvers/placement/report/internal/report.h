// The placement and check reports a process planner reads: how the work ended, the placement
// with the work offset to type into the control, the fixture height, the tightest clearance of
// each kind of interference and where on the path it happens, and for a table-tilting machine
// the travel of each axis and the rotary flips. Written once, by the solvers, into the results'
// Summary (engine/common/summary.h); the command line prints them.
#pragma once

#include <string>

#include "solvers/placement/check/checker.h"
#include "solvers/placement/search/search.h"

namespace machplan::placement {

// What the workpiece's height over the table is called on the scene's machine: "pad" on the
// HexaM (the paper's word), "fixture height" on a table-tilting machine.
const char* height_name(const Scene& scene);

// The message of a check stopped by its budget of exact pose queries.
std::string budget_message(const Scene& scene);

// The per-kind table of a report (one line per kind), as in both reports below.
std::string kinds_table(const Scene& scene, const CheckReport& r);

// Fills result.summary: status (from the result), brief and full report.
void write_check_summary(const Scene& scene, CheckResult& result);
// `rotations_reduced`: the asked rotations were reduced to one because on this machine a
// rotation is the same setup as a position.
void write_place_summary(const Scene& scene, const PlacementOptions& options, bool rotations_reduced,
                         PlacementResult& result);

}  // namespace machplan::placement
