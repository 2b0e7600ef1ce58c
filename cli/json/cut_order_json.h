// The cut order's report as JSON (solvers/motion/cut_order.h), for `machplan order --json`
// and the "cut_order" member of `machplan run --json`.
#pragma once

#include <nlohmann/json.hpp>

#include "solvers/motion/cut_order.h"

namespace machplan::cli {

// {"order", "reordered", "status", "cuts", "closed_cuts", "with_lead_in", "moved_pierces",
//  "sequence_lines": [first feed line of each cut, in the order cut], "programmed_travel_mm",
//  "nearest_travel_mm", "travel_mm", "lower_bound_mm", "outer_first": null or
//  {"outer_line", "inner_line"}, "warnings"}
nlohmann::json cut_order_json(const motion::CutOrderReport& r);

}  // namespace machplan::cli
