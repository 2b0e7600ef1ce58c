// A part to nest on a sheet: one outer contour of a drawing with the holes directly inside it,
// as `machplan profile` reads the drawing (chained, gaps healed within its tolerances).
//
// A drawing is one part unless it is read with `split`: then every outer contour (depth 0, and
// the parts drawn inside another part's hole, depth 2, 4, ...) is a part of its own, with its
// holes. A drawing with an error among its problems (an open chain, crossing contours) is
// refused with the first one's message, as is a drawing without a closed contour.
#pragma once

#include <string>
#include <vector>

#include "engine/geometry/contour.h"
#include "engine/programs/dxf.h"

namespace machplan::nesting {

struct NestPart {
  std::string file;             // the drawing, for messages and the report
  int index = 0;                // which outer contour of the drawing (0 unless split)
  Contour outer;                // counter-clockwise, mm, as drawn
  std::vector<Contour> holes;   // clockwise
  double area_mm2 = 0.0;        // the material: the outer's area less the holes'
};

// InputError (naming the file) for a drawing that cannot be read, holds errors or no closed
// contour, or holds several outer contours without `split` (with their count).
std::vector<NestPart> read_nest_parts(const std::string& path, bool split, const DxfOptions& options = {});

// The same from a profile already read.
std::vector<NestPart> nest_parts(const ProfileReadResult& profile, bool split);

}  // namespace machplan::nesting
