#include "solvers/placement/scene/internal/workpiece.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "solvers/placement/machines/internal/bounds.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

WorkpieceSolid workpiece_solid(const Scene& scene) {
  WorkpieceSolid wp;
  wp.vertices = scene.workpiece_vertices;
  wp.triangles = scene.workpiece_triangles;
  wp.bounds = scene.workpiece_bounds;
  wp.spoilboard_mm = scene.spoilboard_mm;
  // The block fills the footprint, so its farthest point from the z axis is a corner of it.
  for (int k = 0; k < 4; ++k)
    wp.radius_mm = std::max(wp.radius_mm, Eigen::Vector2d(k & 1 ? wp.bounds.max().x() : wp.bounds.min().x(),
                                                          k & 2 ? wp.bounds.max().y() : wp.bounds.min().y())
                                              .norm());
  return wp;
}

interference::Shape WorkpieceSolid::mesh() const {
  std::call_once(built_->once, [this] { built_->shape = interference::Shape::mesh(vertices, triangles); });
  return built_->shape->copy();
}

Eigen::Vector3d WorkpieceSolid::block_half(double pad_mm) const {
  return {bounds.sizes().x() / 2, bounds.sizes().y() / 2, (bounds.max().z() + pad_mm) / 2};
}

Eigen::Isometry3d WorkpieceSolid::block_pose(const Where& where) const {
  const double pad = where.offset.z();
  const Eigen::Vector3d centre_w((bounds.min().x() + bounds.max().x()) / 2, (bounds.min().y() + bounds.max().y()) / 2,
                                 (bounds.max().z() - pad) / 2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = where.R;
  T.translation() = where.R * centre_w + where.offset;
  return T;
}

Eigen::AlignedBox3d WorkpieceSolid::block_bounds(const Where& where) const {
  Eigen::AlignedBox3d b;
  const double pad = where.offset.z();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c(k & 1 ? bounds.max().x() : bounds.min().x(), k & 2 ? bounds.max().y() : bounds.min().y(),
                            k & 4 ? bounds.max().z() : -pad);
    b.extend(where.R * c + where.offset);
  }
  return b;
}

std::array<Eigen::Vector2d, 4> WorkpieceSolid::footprint(const Where& where) const {
  std::array<Eigen::Vector2d, 4> out;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d c(k & 1 ? bounds.max().x() : bounds.min().x(), k & 2 ? bounds.max().y() : bounds.min().y(), 0.0);
    out[k] = (where.R * c + where.offset).head<2>();
  }
  return out;
}

std::vector<interference::Shape> axial_shapes(const std::vector<AxialPart>& parts) {
  std::vector<interference::Shape> out;
  for (const auto& part : parts) {
    const double len = part.to_mm - part.from_mm;
    out.push_back(part.capsule ? interference::Shape::capsule(part.radius_mm, std::max(len - 2 * part.radius_mm, 0.0))
                               : interference::Shape::cylinder(part.radius_mm, len));
  }
  return out;
}

double support_clearance(const std::vector<AxialPart>& parts, const std::vector<interference::Shape>& shapes,
                         const WorkpieceSolid& wp, const PathPose& pose, double pad_mm, bool table, double exact_below,
                         int* closest) {
  double best = std::numeric_limits<double>::infinity();
  const double top = -wp.spoilboard_mm;  // the support's top face under the footprint
  const bool has_block = pad_mm - wp.spoilboard_mm > 1e-9;
  const Eigen::AlignedBox3d block(Eigen::Vector3d(wp.bounds.min().x(), wp.bounds.min().y(), -pad_mm),
                                  Eigen::Vector3d(wp.bounds.max().x(), wp.bounds.max().y(), top));
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const AxialPart& part = parts[k];
    // A ball-end part's capsule lies within from_mm .. to_mm (see axial_shapes()): its axis
    // ends a radius inside, so that the tip is the lowest point of the ball.
    const double inset = part.capsule ? std::min(part.radius_mm, (part.to_mm - part.from_mm) / 2) : 0.0;
    const Eigen::Vector3d a = pose.tip + pose.axis * (part.from_mm + inset), b = pose.tip + pose.axis * (part.to_mm - inset);
    const double low = lowest_z(a, b, part.radius_mm, part.capsule);
    double d = std::numeric_limits<double>::infinity();
    if (table) d = std::max(0.0, low + pad_mm);
    if (has_block) {
      // A lower bound first: the vertical gap to the block's top and the boxes' gap.
      double lb = std::max(low - top, 0.0);
      lb = std::max(lb, aabb_distance(part.capsule ? segment_box(a, b, part.radius_mm) : cylinder_box(a, b, part.radius_mm),
                                      block));
      if (lb < exact_below && lb < d) {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = block.center();
        lb = interference::distance(shapes[k], interference::segment_pose(a, b), interference::Shape::box(block.sizes()), T)
                 .distance_mm;
      }
      d = std::min(d, lb);
    }
    if (d < best) {
      best = d;
      if (closest) *closest = static_cast<int>(k);
    }
  }
  return best;
}

}  // namespace machplan::placement
