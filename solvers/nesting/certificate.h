// The certificate of a nest: a check of the final placements on the true geometry, independent
// of the search that found them (as placement's certifier is of its search).
//
//   * every part lies inside its sheet's usable area: the sheet's rectangle [0, width] x
//     [0, height] less the margin on every side (the part's exact bounding box, arcs included);
//     on a remnant, also inside its outline shrunk by the margin and at least the margin from
//     each cut-out (a cut-out may lie in a part's hole with the margin from the hole's edge);
//   * every two parts on one sheet are at least `spacing_mm` apart: their material regions,
//     each grown by spacing / 2 (engine/geometry/offset.h: exact, arcs stay arcs), do not meet.
//     A part may lie in another's hole when it keeps the spacing from the hole's edge: its
//     grown outline lies inside the hole shrunk by spacing / 2.
//
// Conservative where growing a part closes off a void (a narrow inlet): a part placed in such a
// void is reported, though it might keep the spacing. Candidate pairs come from the grown
// bounding boxes (sweep and prune), so the check costs about O(n log n) plus the pairs that are
// near each other.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solvers/nesting/part.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

struct Sheet {
  Sheet() = default;
  Sheet(double width, double height, double margin) : width_mm(width), height_mm(height), margin_mm(margin) {}

  double width_mm = 0.0, height_mm = 0.0;  // x along width_mm
  double margin_mm = 0.0;                  // kept clear on every side (and of a remnant's edges)
  // A remnant: the material's outline, with its cut-outs as holes, placed so that the box
  // round it spans [0, width_mm] x [0, height_mm]; `drawn_at` is where that box's lower-left
  // corner lies in the remnant's drawing. Unset: the whole rectangle is material.
  std::optional<NestPart> remnant;
  Eigen::Vector2d drawn_at = Eigen::Vector2d::Zero();
};

struct Certificate {
  bool certified = false;
  std::vector<std::string> violations;  // one line each, naming the copies and where
};

// A remnant's usable region: its outline shrunk by the margin (maybe in pieces) and its cut-outs
// grown by it (counter-clockwise). Empty for a whole sheet.
struct RemnantRoom {
  std::vector<Contour> inside, cutouts;
};
RemnantRoom remnant_room(const Sheet& sheet);

// `placements[i].part` indexes `parts`, `.sheet` indexes `sheets`. Throws InputError for an
// index out of range or a negative spacing.
Certificate certify(const std::vector<NestPart>& parts, const std::vector<Placement>& placements,
                    const std::vector<Sheet>& sheets, double spacing_mm);

}  // namespace machplan::nesting
