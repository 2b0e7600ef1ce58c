#include "solvers/placement/search/internal/planned_time.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/internal/speed_profile.h"

namespace machplan::placement {

namespace {
constexpr double kMinPlannedMove = 1e-9;  // as engine/motion/axis_planner.cpp: shorter moves are dropped
}

PlannedTime::PlannedTime(const AxisPath& path) {
  if (!path.limits)
    throw InputError(path.dynamics_file, path.dynamics_line,
                     fmt::format("{}: the time objective times the path by the feed planner, which needs every axis's "
                                 "acceleration and jerk",
                                 path.dynamics_missing));
  limits_ = *path.limits;
  M_ = path.M;
  b_ = path.b;
  rotary_ = path.rotary_rad;
  // The moves the planner keeps: a move shorter than kMinPlannedMove is dropped and the next one
  // starts where the last kept one ended.
  std::size_t from = 0;
  for (std::size_t i = 1; i < M_.size(); ++i) {
    const Eigen::Vector2d dr = rotary_[i] - rotary_[from];
    double tip = 0.0;
    for (std::size_t k = from + 1; k <= i; ++k) tip += path.tip_step_mm[k];
    motion::JointVector delta = motion::JointVector::Zero();
    delta.tail<2>() = dr;
    const double len = motion::joint_move_length(delta, tip);
    if (!(len > kMinPlannedMove)) continue;
    Step s;
    s.D = (M_[i] - M_[from]) / len;
    s.e = (b_[i] - b_[from]) / len;
    s.rotary = dr / len;
    s.length = len;
    s.feed = path.feed_mm_per_s[i];
    s.tip_moves = tip > kMinPlannedMove;
    s.pose = i;
    steps_.push_back(s);
    from = i;
  }
}

double PlannedTime::planned_s(const Eigen::Vector3d& o) const {
  motion::JointVector start;
  start << M_[0] * o + b_[0], rotary_[0];
  std::vector<motion::JointMove> moves;
  moves.reserve(steps_.size());
  for (const Step& s : steps_) {
    motion::JointMove m;
    m.end << M_[s.pose] * o + b_[s.pose], rotary_[s.pose];
    m.tip_mm = s.tip_moves ? s.length : 0.0;
    m.feed_mm_per_s = s.feed;
    moves.push_back(m);
  }
  return motion::plan_joint_moves(start, moves, limits_).duration_s();
}

motion::JointVector PlannedTime::least_rate(const Eigen::Matrix3d& D, const Eigen::Vector3d& e, const Eigen::Vector2d& rotary,
                                            const Eigen::Vector3d& c, const Eigen::Vector3d& h) {
  motion::JointVector u;
  u.head<3>() = ((D * c + e).cwiseAbs() - D.cwiseAbs() * h).cwiseMax(0.0);
  u.tail<2>() = rotary.cwiseAbs();
  return u;
}

double PlannedTime::lower_bound(const Eigen::Vector3d& c, const Eigen::Vector3d& h) const {
  std::vector<motion::internal::EnvelopePiece> pieces;
  pieces.reserve(steps_.size());
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    const Step& s = steps_[k];
    const motion::MoveCaps caps = motion::joint_move_caps(least_rate(s.D, s.e, s.rotary, c, h), s.feed, s.tip_moves, limits_);
    motion::internal::EnvelopePiece p;
    p.length = s.length;
    p.cap = caps.speed;
    p.accel = caps.accel;
    if (k > 0) {
      const Step& r = steps_[k - 1];
      const double v = motion::junction_speed_cap(least_rate(s.D - r.D, s.e - r.e, s.rotary - r.rotary, c, h),
                                                  std::min(r.length, s.length), limits_);
      p.node_cap2 = v * v;
    }
    pieces.push_back(p);
  }
  return motion::internal::envelope_time_s(pieces);
}

}  // namespace machplan::placement
