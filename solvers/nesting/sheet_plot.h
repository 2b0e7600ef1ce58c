// The picture of one nested sheet: the sheet and its usable area, every copy placed (material
// shaded, holes open), and its cut program: the rapids dashed, each pierce marked and numbered
// in cut order, the lead-ins. PNG or SVG (solvers/common/picture.h).
#pragma once

#include <string>
#include <vector>

#include "engine/programs/program.h"
#include "solvers/nesting/certificate.h"
#include "solvers/nesting/part.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

// `title` heads the picture; `cuts` (may be empty) is the sheet's program.
void plot_sheet(const std::string& path, const std::vector<NestPart>& parts, const std::vector<Placement>& placements,
                int sheet, const Sheet& s, const Program& cuts, const std::string& title);

}  // namespace machplan::nesting
