#include "solvers/placement/search/internal/planned_time.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/internal/speed_profile.h"

namespace machplan::placement {

namespace {
constexpr double kMinPlannedMove = 1e-9;  // as engine/motion/axis_planner.cpp: shorter moves are dropped
constexpr double kInf = std::numeric_limits<double>::infinity();

// The smallest magnitude in [lo, hi].
double least_abs(double lo, double hi) { return std::max({0.0, lo, -hi}); }
}  // namespace

PlannedTime::PlannedTime(AxisPath path) {
  if (!path.limits)
    throw InputError(path.dynamics_file, path.dynamics_line,
                     fmt::format("{}: the time objective times the path by the feed planner, which needs every axis's "
                                 "acceleration and jerk",
                                 path.dynamics_missing));
  limits_ = *path.limits;
  const bool rails = path.on_rails();
  poses_ = path.feed_mm_per_s.size();
  M_ = std::move(path.M);
  b_ = std::move(path.b);
  rotary_ = std::move(path.rotary_rad);
  rails_ = std::move(path.rails);
  joints_ = std::move(path.joints_mm);
  // The moves the planner keeps: a move shorter than kMinPlannedMove is dropped and the next one
  // starts where the last kept one ended.
  std::size_t from = 0;
  for (std::size_t i = 1; i < poses_; ++i) {
    double tip = 0.0, turn = 0.0;
    for (std::size_t k = from + 1; k <= i; ++k) tip += path.tip_step_mm[k], turn += rails ? path.turn_rad[k] : 0.0;
    motion::JointVector delta = motion::JointVector::Zero();
    if (!rails) delta.segment<2>(3) = rotary_[i] - rotary_[from];
    const double len = motion::joint_move_length(delta, tip, turn, limits_);
    if (!(len > kMinPlannedMove)) continue;
    Step s;
    if (!rails) {
      s.D = (M_[i] - M_[from]) / len;
      s.e = (b_[i] - b_[from]) / len;
      s.rotary = (rotary_[i] - rotary_[from]) / len;
    }
    s.length = len;
    s.feed = path.feed_mm_per_s[i];
    s.tip_moves = tip > kMinPlannedMove;
    s.from = from;
    s.pose = i;
    steps_.push_back(s);
    from = i;
  }
}

motion::JointVector PlannedTime::position(std::size_t i, const Eigen::Vector3d& o) const {
  motion::JointVector q = motion::JointVector::Zero();
  if (rails_.empty()) {
    q.head<3>() = M_[i] * o + b_[i];
    q.segment<2>(3) = rotary_[i];
  } else {
    for (std::size_t k = 0; k < rails_.size(); ++k) q[k] = hexam::slider_on_rail(rails_[k], joints_[i][k] + o).s_mm;
  }
  return q;
}

motion::JointPlan PlannedTime::plan(const Eigen::Vector3d& o) const {
  thread_local std::vector<motion::JointMove> moves;  // reused: the search plans thousands of times
  moves.clear();
  moves.reserve(steps_.size());
  for (const Step& s : steps_) {
    motion::JointMove m;
    m.end = position(s.pose, o);
    m.tip_mm = s.tip_moves ? s.length : 0.0;
    m.turn_rad = s.tip_moves ? 0.0 : s.length;
    m.feed_mm_per_s = s.feed;
    moves.push_back(m);
  }
  return motion::plan_joint_moves(position(0, o), moves, limits_);
}

motion::JointVector PlannedTime::least_rate(const Eigen::Matrix3d& D, const Eigen::Vector3d& e, const Eigen::Vector2d& rotary,
                                            const Eigen::Vector3d& c, const Eigen::Vector3d& h) {
  motion::JointVector u = motion::JointVector::Zero();
  u.head<3>() = ((D * c + e).cwiseAbs() - D.cwiseAbs() * h).cwiseMax(0.0);
  u.segment<2>(3) = rotary.cwiseAbs();
  return u;
}

PlannedTime::Range PlannedTime::rail_rates(const Step& s, const Eigen::Vector3d& c, const Eigen::Vector3d& h) const {
  Range r;
  r.lo.setZero(), r.hi.setZero();
  const bool point = h.isZero(0.0);
  for (std::size_t k = 0; k < rails_.size(); ++k) {
    const hexam::Strut& st = rails_[k];
    const Eigen::Vector3d& a = joints_[s.from][k];
    const Eigen::Vector3d& b = joints_[s.pose][k];
    if (point) {
      const double ds = hexam::slider_on_rail(st, b + c).s_mm - hexam::slider_on_rail(st, a + c).s_mm;
      r.lo[k] = r.hi[k] = ds / s.length;
      continue;
    }
    const Eigen::Vector3d& u = st.rail_direction;
    const Eigen::Vector3d delta = b - a;
    const Eigen::Vector3d pd = delta - u.dot(delta) * u;  // perp(w) . delta = w . pd
    const Eigen::Vector3d mid = 0.5 * (a + b) + c;
    const double n0 = mid.dot(pd), nr = pd.cwiseAbs().dot(h) + 0.5 * std::abs(delta.dot(pd));
    const double p0 = (mid - u.dot(mid) * u).norm(), pr = h.norm() + 0.5 * delta.norm();
    const double L2 = st.length_mm * st.length_mm, pmax = p0 + pr, pmin = std::max(0.0, p0 - pr);
    if (pmax >= st.length_mm) {
      r.lo[k] = -kInf, r.hi[k] = kInf;
      continue;
    }
    const double root_lo = std::sqrt(L2 - pmax * pmax), root_hi = std::sqrt(L2 - pmin * pmin);
    const double nlo = n0 - nr, nhi = n0 + nr;
    // The range of (perp . delta) / root, root in [root_lo, root_hi] > 0.
    const double qlo = nlo >= 0 ? nlo / root_hi : nlo / root_lo;
    const double qhi = nhi >= 0 ? nhi / root_lo : nhi / root_hi;
    r.lo[k] = (u.dot(delta) - qhi) / s.length;
    r.hi[k] = (u.dot(delta) - qlo) / s.length;
  }
  return r;
}

double PlannedTime::lower_bound(const Eigen::Vector3d& c, const Eigen::Vector3d& h) const {
  thread_local std::vector<motion::internal::EnvelopePiece> pieces;  // reused, as in plan()
  pieces.clear();
  pieces.reserve(steps_.size());
  Range prev;
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    const Step& s = steps_[k];
    motion::JointVector least = motion::JointVector::Zero(), jump = motion::JointVector::Zero();
    if (rails_.empty()) {
      least = least_rate(s.D, s.e, s.rotary, c, h);
      if (k > 0) {
        const Step& r = steps_[k - 1];
        jump = least_rate(s.D - r.D, s.e - r.e, s.rotary - r.rotary, c, h);
      }
    } else {
      const Range now = rail_rates(s, c, h);
      for (std::size_t a = 0; a < rails_.size(); ++a) {
        least[a] = least_abs(now.lo[a], now.hi[a]);
        if (k > 0) jump[a] = least_abs(now.lo[a] - prev.hi[a], now.hi[a] - prev.lo[a]);
      }
      prev = now;
    }
    const motion::MoveCaps caps = motion::joint_move_caps(least, s.feed, s.tip_moves, limits_);
    motion::internal::EnvelopePiece p;
    p.length = s.length;
    p.cap = caps.speed;
    p.accel = caps.accel;
    if (k > 0) {
      const double v = motion::junction_speed_cap(jump, std::min(steps_[k - 1].length, s.length), limits_);
      p.node_cap2 = v * v;
    }
    pieces.push_back(p);
  }
  return motion::internal::envelope_time_s(pieces);
}

}  // namespace machplan::placement
