// Pictures of a placement: a top view (table, peripherals, the workpiece outline and its tool
// path at the answer, the searched region, the paper search's trail) beside a side view (table,
// pad, workpiece, peripherals, tool path). PNG or SVG by the file's extension.
#pragma once

#include <string>

#include "solvers/placement/search/search.h"

namespace machplan::placement {

// Throws InputError naming the file when it cannot be written or the extension is neither
// .png nor .svg.
void write_placement_plot(const std::string& path, const Scene& scene, const PlacementResult& result);

}  // namespace machplan::placement
