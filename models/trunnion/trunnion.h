// A table-tilting 5-axis machine (a trunnion): the spindle moves along three linear axes
// (X, Y, Z) and keeps its direction; the workpiece turns on two rotary axes under it, a tilt
// axis (A about X, or B about Y) carrying a rotary table (C). Described by a YAML kinematic
// chain; the bundled one is datasets/machines/trunnion_ac.yaml.
//
// Frames. The machine frame is fixed to the bed. With every axis at zero the file gives, in it:
// the spindle's direction s (from the tool tip up into the spindle) and its gauge point N0
// (the spindle nose, where the tool holder seats); the tilt axis as a point and a direction;
// the rotary table's axis likewise; the table frame's origin on the rotary table's axis at its
// top face (its z along that axis, its x along the machine's x). A placement puts the workpiece
// in the table frame. With the rotary axes at A and C the table frame is
//
//     T_machine_table(A, C) = Rot(a_point, a_dir, A) Rot(c_point, c_dir, C) T0
//
// (the second rotary axis rides on the first). The spindle nose moves by the linear axes:
// N = N0 + X dX + Y dY + Z dZ, with dX, dY, dZ orthonormal.
//
// Inverse kinematics of a tool pose (tip p, axis a in the table frame) with tool gauge length
// L (tip to nose): the rotary axes must turn a onto s, R_A R_C a = s. Writing z = R_C a =
// R_A^-1 s, z keeps a's component along c_dir and s's component along a_dir, and has unit
// length; that fixes z up to the sign of its third component (the two solutions; Paden and
// Kahan's second subproblem), each giving one (A, C). When a lies along c_dir, C is free (the
// singular pose): any C works with one A. The linear axes follow: N = T(A, C) p + L s.
//
// Limits: each linear axis between its ends; the tilt axis between its ends; the rotary table
// either continuous or between its ends.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan {

class Yaml;

namespace trunnion {

// A solid of the machine: a box (centre, full sizes, turned by yaw about z), a cylinder
// (centre, radius, length along `axis`) or a mesh (STL, placed at `xyz`), in the frame of the
// body it moves with, as that frame lies with every axis at zero (machine coordinates).
struct Solid {
  std::string name;
  enum class Shape { box, cylinder, mesh } shape = Shape::box;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();  // box
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();    // box orientation; cylinder: its z along the axis
  double radius_mm = 0.0, length_mm = 0.0;            // cylinder
  std::vector<Eigen::Vector3d> vertices;              // mesh (machine coordinates at zero)
  std::vector<Eigen::Vector3i> triangles;
};

// A part of the spindle of revolution about its axis: from `from_mm` to `to_mm` above the
// nose along s, with a radius.
struct SpindlePart {
  std::string name;
  double from_mm = 0.0, to_mm = 0.0, radius_mm = 0.0;
};

struct LinearAxis {
  std::string name;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  double min_mm = 0.0, max_mm = 0.0;
  double feed_mm_per_s = 0.0, rapid_mm_per_s = 0.0;  // speed limits: cutting, rapid
  // Acceleration and jerk limits (mm/s^2, mm/s^3; `accel_mm_per_s2`, `jerk_mm_per_s3`), 0 when
  // the file gives none (see Machine::dynamics_missing).
  double accel_mm_per_s2 = 0.0, jerk_mm_per_s3 = 0.0;
};

struct RotaryAxis {
  std::string name;
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // unit; right-hand rule for positive
  bool continuous = false;
  double min_rad = 0.0, max_rad = 0.0;
  double feed_rad_per_s = 0.0, rapid_rad_per_s = 0.0;
  // Acceleration and jerk limits (rad/s^2, rad/s^3; the file's `accel_deg_per_s2`,
  // `jerk_deg_per_s3`), 0 when it gives none.
  double accel_rad_per_s2 = 0.0, jerk_rad_per_s3 = 0.0;
  std::vector<Solid> solids;  // the bodies it carries (not those of the axes after it)
  bool within(double angle_rad) const {
    return continuous || (angle_rad >= min_rad - 1e-12 && angle_rad <= max_rad + 1e-12);
  }
};

struct Machine {
  std::string name;
  std::string source;
  Eigen::Vector3d spindle_direction = Eigen::Vector3d::UnitZ();  // s
  Eigen::Vector3d nose_mm = Eigen::Vector3d::Zero();             // N0
  std::vector<SpindlePart> spindle;
  std::array<LinearAxis, 3> linear;
  RotaryAxis tilt, table;   // A (or B), then C
  Eigen::Vector3d table_origin_mm = Eigen::Vector3d::Zero();  // T0's origin: on the table axis at its top
  double table_radius_mm = 0.0;
  std::vector<Solid> base;  // fixed to the bed (the trunnion's end supports)
  // Accelerations and jerks are optional in the file (an axis gives both or neither): placing
  // and checking need only the geometry and the speeds. Timing the path by the feed planner
  // (`machplan place --objective time`) needs them on every axis; when one lacks them this
  // says which (empty when every axis has them), and the line of that axis in `source`.
  std::string dynamics_missing;
  int dynamics_missing_line = 0;
  // How the control reads a program's feed in a 5-axis block (`feed_mode`): tcp (the default),
  // the tool tip's speed relative to the workpiece (tool centre point control, or inverse-time
  // feed); axes, the combined speed of all the axes with rotary degrees counted as mm (G94
  // without tool centre point control). See engine/motion/axis_planner.h.
  bool feed_on_axes = false;

  // Derived at load time.
  Eigen::Matrix3d table_frame = Eigen::Matrix3d::Identity();  // T0's rotation: z along the table axis
  double axes_offset_mm = 0.0;  // distance from the table frame's origin to the tilt axis line

  // The table frame at rotary angles (a, c), in machine coordinates.
  Eigen::Isometry3d table_pose(double a_rad, double c_rad) const;
  // The tilt body's pose (what the tilt axis carries) at angle a.
  Eigen::Isometry3d tilt_pose(double a_rad) const;
  // Linear axis positions (mm) that put the spindle nose at `nose` (machine coordinates).
  Eigen::Vector3d axes_for_nose(const Eigen::Vector3d& nose) const;
};

// One inverse-kinematics solution: the rotary angles.
struct Angles {
  double a_rad = 0.0, c_rad = 0.0;
};

// Both solutions for a tool axis (table frame), or one for the singular pose (axis along the
// table's axis; its C is free and given as `c_hint`), or none (the axis cannot be turned onto
// the spindle). The rotary limits are not applied here.
std::vector<Angles> solve_angles(const Machine& m, const Eigen::Vector3d& axis, double c_hint = 0.0);
// The tool axis in the table frame that angles (a, c) turn onto the spindle.
Eigen::Vector3d axis_at(const Machine& m, double a_rad, double c_rad);

Machine load_machine(const std::string& path);
Machine machine_from_yaml(const Yaml& root);

}  // namespace trunnion
}  // namespace machplan
