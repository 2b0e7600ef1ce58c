// Axis travel and machining time of a path as functions of the workpiece's position, for a
// machine whose linear axes are affine in it (machines/machine_model.h AxisPath: a table-tilting
// trunnion, where the rotary angles depend on the tool axis alone).
//
// With q_i(o) = M_i o + b_i the linear axes at pose i for the offset o:
//
//   travel(o) = sum_i sum_k | (M_i - M_i-1) o + (b_i - b_i-1) |_k        (mm)
//   time(o)   = sum_i max( L_i / F_i,  max_k |dq_ik(o)| / v_k,  max_r |dr_ir| / w_r )   (s)
//
// (L_i / F_i the step's tip length over its programmed feed, v_k and w_r the axes' speed
// limits, rapid speeds for rapid steps). On a machine whose feed is the axes' combined speed
// (AxisPath::feed_on_axes) the feed term is |(dq_i(o), dr_i in degrees)| / F_i instead, convex
// too. Both are convex in o, so over a box of offsets with
// centre c and half sizes h the larger of two lower bounds holds:
//
//   per step and axis:   sum over terms of max(0, |term(c)| - |grad term| . h)
//   supporting plane:    f(c) - |g| . h, g a subgradient of f at c
//
// The second is tight near the minimum, where the terms' slopes cancel; the first far from it.
// Rotary travel and the time of rotary moves do not depend on the position.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

class AxisObjective {
 public:
  enum class Kind { travel, time };
  AxisObjective(const AxisPath& path, Kind kind);

  double value(const Eigen::Vector3d& offset) const;
  // A lower bound of value() over the box centre +- half.
  double lower_bound(const Eigen::Vector3d& centre, const Eigen::Vector3d& half) const;

  // Per axis: travel (mm for the linear axes, degrees for the rotary ones) at an offset.
  std::vector<double> travel_per_axis(const Eigen::Vector3d& offset) const;
  double time_s(const Eigen::Vector3d& offset) const;
  double linear_travel_mm(const Eigen::Vector3d& offset) const;

 private:
  double evaluate(const Eigen::Vector3d& offset, Kind kind, Eigen::Vector3d* gradient) const;
  Kind kind_;
  std::vector<Eigen::Matrix3d> D_;   // per step
  std::vector<Eigen::Vector3d> e_;   // per step
  std::vector<double> fixed_s_;      // per step: time that does not depend on the position
  std::vector<Eigen::Vector3d> inv_speed_;  // per step: 1 / speed of each linear axis (feed or rapid)
  std::vector<double> inv_feed_;     // per step, feed on the axes: 1 / F (0 on rapids and otherwise)
  std::vector<double> rotary_deg2_;  // per step, feed on the axes: the rotary step in degrees, squared
  Eigen::Vector2d rotary_travel_rad_ = Eigen::Vector2d::Zero();
};

}  // namespace machplan::placement
