// Collision geometry behind machplan's own types. FCL does the work; its types never appear
// outside collision.cpp (the PIMPL pattern Drake uses for its proximity engine).
//
//   Shape head = Shape::cylinder(80.0, 250.0);        // radius, length along local z, centred
//   Shape magazine = Shape::box({300, 200, 400});     // full sizes, centred
//   Proximity p = distance(head, T_table_head, magazine, T_table_magazine);
//   if (p.distance_mm < safe_distance_mm) ...
//
// distance_mm is the Euclidean distance between the two solids; 0 when they touch or overlap
// (FCL's signed distance is not trusted, see DESIGN.md), so callers treat "0" as "deficit at
// least the required clearance". Shapes are immutable; callers that query from several threads
// give each thread its own copy() (the placement checker does), so no collision object is
// shared between threads.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan::interference {

class Shape {
 public:
  static Shape box(const Eigen::Vector3d& size_mm);
  static Shape cylinder(double radius_mm, double length_mm);  // flat ends, axis z, centred
  static Shape capsule(double radius_mm, double length_mm);   // length of the straight part
  static Shape sphere(double radius_mm);
  // A triangle mesh; its own bounding-volume hierarchy is built once here.
  static Shape mesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles);

  enum class Kind { box, cylinder, capsule, sphere, mesh };
  Kind kind() const;
  // Axis-aligned bounds in the shape's own frame.
  Eigen::AlignedBox3d local_bounds() const;
  // A deep copy with collision objects of its own (a mesh's bounding-volume tree included), for
  // a thread that must not share them.
  Shape copy() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  explicit Shape(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

struct Proximity {
  double distance_mm = 0.0;          // >= 0; 0 means touching or overlapping
  Eigen::Vector3d point_a_mm = Eigen::Vector3d::Zero();  // nearest points, world frame
  Eigen::Vector3d point_b_mm = Eigen::Vector3d::Zero();  // (meaningless when overlapping)
};

Proximity distance(const Shape& a, const Eigen::Isometry3d& T_world_a, const Shape& b,
                   const Eigen::Isometry3d& T_world_b);

// Pose of a cylinder or capsule whose axis runs from p0 to p1 (its local z along p1 - p0).
Eigen::Isometry3d segment_pose(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1);

// Distance between two line segments (used for fast strut-to-strut bounds).
double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1);

}  // namespace machplan::interference
