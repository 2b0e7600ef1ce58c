// Where a part goes on a sheet: the transform the nest's JSON gives for every placed copy, such
// that a point (x, y) of the drawing lands on the sheet at
//     translate + R(rotation) * (mirrored ? (-x, y) : (x, y)),
// R the counter-clockwise rotation. Anyone can check a nest from the drawings and this alone.
#pragma once

#include <cstddef>

#include <Eigen/Core>

#include "engine/geometry/contour.h"

namespace machplan::nesting {

struct Placement {
  std::size_t part = 0;    // index into the nest's parts
  int copy = 0;            // which copy of that part
  int sheet = 0;           // index of the sheet it is on
  double rotation_deg = 0.0;
  bool mirrored = false;
  Eigen::Vector2d translate_mm = Eigen::Vector2d::Zero();

  Eigen::Vector2d apply(const Eigen::Vector2d& p) const;
};

// The contour as placed: exact (arcs stay arcs). A mirrored contour runs the other way round;
// it is reversed back, so that an outer stays counter-clockwise and a hole clockwise.
Contour place(const Contour& c, const Placement& p);

}  // namespace machplan::nesting
