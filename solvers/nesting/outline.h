// A part as a polygon for the search's collision tests, approximated from outside: the polygon
// holds the whole material, so parts whose polygons keep apart keep apart on their true lines
// and arcs too. With the contour walked with the material on its left (an outer
// counter-clockwise, a hole clockwise), an arc turning left bulges away from the material: its
// polygon runs on tangents to it (vertices at r / cos(phi / 2), phi the angle of a piece), so
// the arc lies inside; an arc turning right curves into the material's outside: its chords
// lie outside the material already. Each piece deviates from the arc by at most
// `tolerance_mm`, so the polygon lies within that of the true contour.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/geometry/contour.h"

namespace machplan::nesting {

// The vertices of the polygon, in the contour's order. `tolerance_mm` > 0.
std::vector<Eigen::Vector2d> outside_polygon(const Contour& c, double tolerance_mm);

// An outer contour grown by `distance_mm` (exact, engine/geometry/offset.h): the outer boundary
// of the grown region (a void that growing closes off is left out); the contour itself at 0.
Contour grown_outline(const Contour& outer, double distance_mm);

}  // namespace machplan::nesting
