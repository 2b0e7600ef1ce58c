// The workpiece as the machine models see it, in its own frame (origin on the bottom face, z
// up): its solid, the block its footprint makes with the pad or fixture under it, and the
// support below it that the tool may not reach.
//
// The pad (hexapod) or fixture (trunnion) fills the workpiece's footprint, the rectangle of its
// bounds in x and y, from z = -pad up to the bottom face at z = 0. With a sacrificial
// spoilboard of thickness s (the scene's `workpiece.spoilboard_mm`) the pad's top s mm may be
// cut into, so what the tool must keep the safe distance from is the footprint from z = -pad
// to z = -s, and the table below z = -pad (on machines whose table is under the tool's reach;
// the trunnion's rotary table is one of its own parts instead).
#pragma once

#include <array>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/interference/collision.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

struct Scene;

struct WorkpieceSolid {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
  Eigen::AlignedBox3d bounds;   // workpiece frame
  double spoilboard_mm = 0.0;
  double radius_mm = 0.0;       // farthest a point of the block lies from the frame's z axis
  // The solid's collision shape for the calling thread, a copy of its own: the mesh's
  // bounding-volume tree is built once, when first asked (thread-safe), and shared by copies of
  // this solid.
  interference::Shape mesh() const;

  // The block (footprint from z = -pad to the top) in the table frame: its box shape's half
  // sizes and pose.
  Eigen::Vector3d block_half(double pad_mm) const;
  Eigen::Isometry3d block_pose(const Where& where) const;
  // Axis-aligned bounds of the block in the table frame.
  Eigen::AlignedBox3d block_bounds(const Where& where) const;
  // The footprint's corners in the table frame.
  std::array<Eigen::Vector2d, 4> footprint(const Where& where) const;

 private:
  struct Built {
    std::once_flag once;
    std::optional<interference::Shape> shape;
  };
  std::shared_ptr<Built> built_ = std::make_shared<Built>();
};

// The scene's workpiece (mesh, bounds, spoilboard), its radius that of the footprint's corners.
WorkpieceSolid workpiece_solid(const Scene& scene);

// The tool assembly against the support (see above) at one pose in the workpiece frame with
// the pad `pad_mm`: the smallest distance over the parts, exact below `exact_below` (a lower
// bound above it). `shapes[k]` is the collision shape of parts[k] (a thread's own); `table`
// says whether the table plane at z = -pad counts. On return `*part` (optional) names the
// closest part.
double support_clearance(const std::vector<AxialPart>& parts, const std::vector<interference::Shape>& shapes,
                         const WorkpieceSolid& wp, const PathPose& pose, double pad_mm, bool table, double exact_below,
                         int* part = nullptr);

// Collision shapes of axial parts (capsules or flat cylinders along their own z).
std::vector<interference::Shape> axial_shapes(const std::vector<AxialPart>& parts);

}  // namespace machplan::placement
