// The cut program of one nested sheet: every placed copy's holes and outline as closed cuts,
// each entered by a straight lead-in from the waste side (inside a hole, outside an outline)
// at the middle of the contour's longest straight span (its first arc's start when it has
// none), the lead-in shortened in a small hole to 0.4 of the hole's smaller size. The cuts come
// in the nest's order; solvers/motion/cut_order.h then orders them (inner contours first, a
// part in a hole before that hole, pierce points moved where the travel is least) as
// `machplan order` does, and engine/programs/gcode_writer.h writes the G-code rs274 reads.
// Not yet: lead-outs and overcut, arc lead-ins, kerf compensation in the program (left to
// `machplan run --kerf`), materials (M190).
#pragma once

#include <vector>

#include "engine/programs/program.h"
#include "solvers/nesting/part.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

struct SheetProgramOptions {
  double feed_mm_per_min = 2000.0;
  double lead_in_mm = 5.0;
};

// The cuts of the copies on `sheet` (placements[i].sheet == sheet), as a program starting at
// the sheet's origin and ending there. Torch on and off as M3 S1 / M5.
Program sheet_program(const std::vector<NestPart>& parts, const std::vector<Placement>& placements, int sheet,
                      const SheetProgramOptions& options = {});

}  // namespace machplan::nesting
