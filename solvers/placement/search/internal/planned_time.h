// The machining time a control's feed planner gives a path, as a function of the workpiece's
// position, and a lower bound of it over a box of positions.
//
// The path as the machine runs it (machines/machine_model.h AxisPath), for the offset o:
//   * affine (a table-tilting machine): pose i puts the linear axes at q_i(o) = M_i o + b_i and
//     the rotary axes at r_i;
//   * rails (a hexapod): pose i puts slider k at s_k(d_ik + o), d_ik its plate joint from the
//     rail's foot, s the strut's closure (models/hexam/hexam.h slider_on_rail).
// The time is that of engine/motion/axis_planner.h on the chain of joint-space moves between the
// poses (each move's path length is the tip's path relative to the workpiece, or the rotary
// angle, or on rails the tool axis's turn: independent of o). Per move the planner caps the
// path speed, its acceleration and, at each corner, the speed through it, by caps that only fall
// when an axis's rate |u_k| (or a corner's rate jump |du_k|) rises.
//
// The bound. The planner never goes faster than the envelope V(s): the largest speed under
// every move's cap, at most the corner cap at each corner, rest at both ends, changing by at
// most each move's acceleration cap (|d(v^2)/ds| <= 2 a). Its time is at least integral ds / V
// (engine/motion/internal/speed_profile.h envelope_time_s). Over a box (centre c, half sizes h)
// the envelope with the caps of each rate's smallest magnitude lies above every point's
// envelope, so its time is a lower bound of the planner's time anywhere in the box:
//   * affine: u = (D o + e) / l on the linear axes, so |u_k| >= max(0, |(D c + e)_k| - (|D| h)_k)
//     / l, and the same for a corner's jump with D and e the two moves' differences; the rotary
//     rates are fixed;
//   * rails: a slider's move over a step from pose a to b is the integral of its rail's gradient
//     g(w) = u - perp(w) / root(w) along w = d_a + o + t (d_b - d_a), t in [0, 1]. perp(w) . delta
//     is affine in w, so over the box swept by the segment it has an exact range; |perp(w)| lies
//     within |perp(w_mid)| +- (|h| + |delta| / 2), which bounds root = sqrt(L^2 - |perp|^2). The
//     move's range follows, and a corner's jump lies between the ranges' differences. At a
//     point (h = 0) the rates are the exact ones.
// At a point the bound is the point's own envelope time: at most the planned time.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/motion/axis_planner.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

class PlannedTime {
 public:
  // Throws InputError (the machine file's line) when the machine gives no accelerations and
  // jerks (path.dynamics_missing). Keeps the path's poses (moved in when the caller is done).
  explicit PlannedTime(AxisPath path);

  // The planner's time at an offset, s.
  double planned_s(const Eigen::Vector3d& offset) const { return plan(offset).duration_s(); }
  motion::JointPlan plan(const Eigen::Vector3d& offset) const;
  // A lower bound of planned_s() over the box centre +- half (see the file comment).
  double lower_bound(const Eigen::Vector3d& centre, const Eigen::Vector3d& half) const;
  // The axes at pose i (mm, rad), the unused entries 0.
  motion::JointVector position(std::size_t i, const Eigen::Vector3d& offset) const;
  std::size_t poses() const { return poses_; }
  const motion::AxisLimits& limits() const { return limits_; }

 private:
  struct Step {
    Eigen::Matrix3d D = Eigen::Matrix3d::Zero();  // affine: linear rate per unit offset, u_lin = D o + e
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    Eigen::Vector2d rotary = Eigen::Vector2d::Zero();  // affine: rotary rate
    double length = 0.0, feed = 0.0;
    bool tip_moves = false;
    std::size_t from = 0, pose = 0;  // the poses it starts and ends at
  };
  struct Range {
    motion::JointVector lo, hi;
  };
  // Per axis, the range of step s's rate over the box (rails; exact at h = 0).
  Range rail_rates(const Step& s, const Eigen::Vector3d& c, const Eigen::Vector3d& h) const;
  // Per axis, the smallest |rate| over the box (affine).
  static motion::JointVector least_rate(const Eigen::Matrix3d& D, const Eigen::Vector3d& e, const Eigen::Vector2d& rotary,
                                        const Eigen::Vector3d& c, const Eigen::Vector3d& h);

  motion::AxisLimits limits_;
  std::vector<Eigen::Matrix3d> M_;
  std::vector<Eigen::Vector3d> b_;
  std::vector<Eigen::Vector2d> rotary_;
  std::vector<hexam::Strut> rails_;
  std::vector<std::array<Eigen::Vector3d, 6>> joints_;
  std::size_t poses_ = 0;
  std::vector<Step> steps_;  // the moves the planner keeps (see axis_planner.cpp)
};

}  // namespace machplan::placement
