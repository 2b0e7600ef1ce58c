// A conservative upper envelope of a solid seen from above: for every cell of an xy grid, a
// height that no point of the solid above that cell exceeds. It answers "how high can the
// solid be anywhere inside this rectangle" in constant time through a max-pyramid, which lets
// the placement checker prove in one lookup that a machine part swept over a stretch of tool
// path stays clear of the workpiece. It only ever over-estimates heights, so a proof from it is
// a proof; when it cannot prove, callers fall back to an exact distance query.
#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan::interference {

class HeightField {
 public:
  // Rasterizes the triangles (any solid; vertical columns under the surface count as solid)
  // on cells of `cell_mm`, and also raises the rectangle `floor_rect` to `floor_z` (the pad).
  HeightField(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
              double cell_mm, const Eigen::AlignedBox2d& floor_rect, double floor_z);

  // Highest height over every cell touching [lo, hi]; -infinity where there is no solid.
  double max_height(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const;

 private:
  double cell_;
  Eigen::Vector2d origin_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<double>> levels_;  // level k: cells of 2^k, row-major
  std::vector<int> level_nx_, level_ny_;
};

}  // namespace machplan::interference
