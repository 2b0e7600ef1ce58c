// The machining time a control's feed planner gives a path on a table-tilting machine, as a
// function of the workpiece's position, and a lower bound of it over a box of positions.
//
// The path as the machine runs it (machines/machine_model.h AxisPath): pose i puts the linear
// axes at q_i(o) = M_i o + b_i and the rotary axes at r_i, for the offset o. The time is that of
// engine/motion/axis_planner.h on the chain of joint-space moves between the poses (each move's
// path length is the tip's path relative to the workpiece, or the rotary angle: independent of
// o). Per move the planner caps the path speed, its acceleration and, at each corner, the speed
// through it, by caps that only fall when an axis's rate |u_k| (or a corner's rate jump |du_k|)
// rises. Those rates are affine in o on the linear axes (u = (D o + e) / l) and fixed on the
// rotary ones.
//
// The bound. The planner never goes faster than the envelope V(s): the largest speed under
// every move's cap, at most the corner cap at each corner, rest at both ends, changing by at
// most each move's acceleration cap (|d(v^2)/ds| <= 2 a). Its time is at least integral ds / V
// (engine/motion/internal/speed_profile.h envelope_time_s). Over a box (centre c, half sizes h)
// each |u_k| and |du_k| is at least max(0, |(D c + e)_k| - (|D| h)_k) / l, so the envelope with
// the caps of those smallest rates lies above every point's envelope, and its time is a lower
// bound of the planner's time anywhere in the box. At a point it is the point's own envelope
// time, at least the velocity-only time (search/internal/objective.h) and at most the planned
// time.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/motion/axis_planner.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

class PlannedTime {
 public:
  // Throws InputError (the machine file's line) when the machine gives no accelerations and
  // jerks (path.dynamics_missing).
  explicit PlannedTime(const AxisPath& path);

  // The planner's time at an offset, s.
  double planned_s(const Eigen::Vector3d& offset) const;
  // A lower bound of planned_s() over the box centre +- half (see the file comment).
  double lower_bound(const Eigen::Vector3d& centre, const Eigen::Vector3d& half) const;

 private:
  struct Step {
    Eigen::Matrix3d D;       // linear rate per unit offset: u_lin = D o + e
    Eigen::Vector3d e;
    Eigen::Vector2d rotary;  // rotary rate
    double length = 0.0, feed = 0.0;
    bool tip_moves = false;
    std::size_t pose = 0;    // the pose it ends at
  };
  // Per axis, the smallest |rate| over the box.
  static motion::JointVector least_rate(const Eigen::Matrix3d& D, const Eigen::Vector3d& e, const Eigen::Vector2d& rotary,
                                        const Eigen::Vector3d& c, const Eigen::Vector3d& h);

  motion::AxisLimits limits_;
  std::vector<Eigen::Matrix3d> M_;
  std::vector<Eigen::Vector3d> b_;
  std::vector<Eigen::Vector2d> rotary_;
  std::vector<Step> steps_;  // the moves the planner keeps (see axis_planner.cpp)
};

}  // namespace machplan::placement
