// Contours and regions the geometry tests build their cases from.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/geometry/contour.h"
#include "engine/geometry/region.h"

namespace machplan::test {

// A closed polygon through `v` (straight spans only).
inline Contour polygon(const std::vector<Eigen::Vector2d>& v) {
  return Contour(v, std::vector<double>(v.size(), 0.0));
}

// The axis-aligned rectangle from (x0, y0) to (x1, y1), counter-clockwise.
inline Contour rectangle(double x0, double y0, double x1, double y1) {
  return polygon({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
}

// The options of a prohibited region for a tool of radius `r` machining on `side`.
inline RegionOptions region_options(MachiningSide side, double r, OffsetMethod m = OffsetMethod::robust) {
  RegionOptions o;
  o.side = side;
  o.tool_radius_mm = r;
  o.method = m;
  return o;
}

}  // namespace machplan::test
