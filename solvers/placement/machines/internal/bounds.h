// Cheap lower bounds of distances between the solids the machine models check, used before an
// exact (FCL) query and instead of it when the bound alone settles the question.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan::placement {

// Both machine models keep a cheap lower bound instead of an exact query when it lies this far
// above what the check needs.
inline constexpr double kSlack_mm = 50.0;

// Distance between two axis-aligned boxes (0 when they overlap).
inline double aabb_distance(const Eigen::AlignedBox3d& a, const Eigen::AlignedBox3d& b) {
  const Eigen::Vector3d gap = (a.min() - b.max()).cwiseMax(b.min() - a.max()).cwiseMax(Eigen::Vector3d::Zero());
  return gap.norm();
}

// Bounds of the capsule of radius r around the segment p0 p1.
inline Eigen::AlignedBox3d segment_box(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double r) {
  Eigen::AlignedBox3d b(p0.cwiseMin(p1), p0.cwiseMax(p1));
  b.min().array() -= r;
  b.max().array() += r;
  return b;
}

// Exact bounds of a flat-ended cylinder from p0 to p1: each rim circle reaches r sqrt(1 - d_k^2)
// along world axis k, d being the unit cylinder axis.
inline Eigen::AlignedBox3d cylinder_box(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double r) {
  const Eigen::Vector3d d = (p1 - p0).normalized();
  const Eigen::Vector3d e = r * (Eigen::Vector3d::Ones() - d.cwiseProduct(d)).cwiseMax(0.0).cwiseSqrt();
  return Eigen::AlignedBox3d(p0.cwiseMin(p1) - e, p0.cwiseMax(p1) + e);
}

// Lowest z of a flat-ended cylinder (or a capsule) of radius r from p0 to p1.
inline double lowest_z(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double r, bool capsule) {
  if (capsule) return std::min(p0.z(), p1.z()) - r;
  const Eigen::Vector3d d = (p1 - p0).normalized();
  return std::min(p0.z(), p1.z()) - r * std::sqrt(std::max(0.0, 1.0 - d.z() * d.z()));
}

// Lower bound of the distance from the capsule (or flat cylinder, which lies inside it) of
// radius r around a b to a box of half sizes `half` centred at the origin of its own frame,
// given a b in that frame: the boxes' gap, or a separating plane along the segment facing the
// box centre, whichever is larger (the plane does better for a long slanted strut beside the
// box).
inline double box_gap(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, const Eigen::Vector3d& half,
                      bool cylinder) {
  const Eigen::AlignedBox3d box(-half, half);
  double lower = aabb_distance(cylinder ? cylinder_box(a, b, r) : segment_box(a, b, r), box);
  const Eigen::Vector3d d = b - a, mid = (a + b) / 2;
  const double len2 = d.squaredNorm();
  const Eigen::Vector3d off = len2 > 1e-12 ? Eigen::Vector3d(mid - d * (mid.dot(d) / len2)) : mid;
  const double dist = off.norm();
  if (dist > 1e-9) {
    const Eigen::Vector3d n = off / dist;
    lower = std::max(lower, dist - half.cwiseProduct(n.cwiseAbs()).sum() - r);
  }
  return lower;
}

// Unit axis a fraction t of the way from a to b along the great circle.
inline Eigen::Vector3d slerp_axis(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double t) {
  const double th = std::atan2(a.cross(b).norm(), a.dot(b));
  if (th < 1e-9) return ((1 - t) * a + t * b).normalized();
  const double s = std::sin(th);
  return (std::sin((1 - t) * th) / s * a + std::sin(t * th) / s * b).normalized();
}

inline double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace machplan::placement

namespace machplan::placement {

// How precisely a report pins the smallest value `best` of a constraint whose limit is
// `limit`: to within `tolerance` near the limit; far above it, to within half its distance to
// the limit (a 40 mm clearance to within 17.5 mm), which keeps a report of flat, distant
// constraints from visiting every pose. Likewise far below it: an interference deeper than
// 10 mm is pinned to within half of its depth beyond that (a clearance of 20 mm under a
// 1000 mm safe distance to within 485 mm). A large safe distance is broken along the whole
// path by nearly the same amount (a tool shank 20 mm above the surface everywhere); without
// this every pose would be an exact query. The verdict is the same either way.
inline double report_margin(double best, double limit, double tolerance) {
  constexpr double kDeepMm = 10.0;
  return std::max(tolerance, best >= limit ? 0.5 * (best - limit) : 0.5 * (limit - best - kDeepMm));
}

}  // namespace machplan::placement

namespace machplan::placement {

// Signed distance from a point to a box of half sizes `half` centred at the origin of its own
// frame (the point given in that frame): negative inside, by the depth below the nearest face.
inline double box_sdf(const Eigen::Vector3d& p, const Eigen::Vector3d& half) {
  const Eigen::Vector3d q = p.cwiseAbs() - half;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// Signed distance from a point to a flat-ended cylinder of radius r along z from -h to h.
inline double cylinder_sdf(const Eigen::Vector3d& p, double r, double h) {
  const Eigen::Vector2d q(p.head<2>().norm() - r, std::abs(p.z()) - h);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// How deep a solid of revolution (a capsule, or a flat cylinder, of radius r about the segment
// a b) reaches into another solid whose signed distance is `sdf`: minus the depth of the
// deepest of a few balls that lie inside the solid, so at most 0 and never above the solids'
// true signed distance (a depth of d needs a move of at least d to separate them). Like a
// distance it changes by at most m when either solid moves by m. Clearances are distances,
// which stop at 0 where solids overlap; this carries them below 0 so that an overlap found
// deep inside proves itself over a whole neighbourhood.
// `ball` (optional) receives the deepest ball's centre and radius (untouched when none reaches
// in).
struct DepthBall {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius_mm = 0.0;
};
template <class Sdf>
double depth_into(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, bool capsule, const Sdf& sdf,
                  DepthBall* ball = nullptr) {
  const Eigen::Vector3d d = b - a;
  const double len = d.norm();
  double best = 0.0;
  auto look = [&](const Eigen::Vector3d& q, double rho) {
    const double v = sdf(q) - rho;
    if (v < best) {
      best = v;
      if (ball) *ball = {q, rho};
    }
  };
  if (capsule) {
    for (int k = 0; k <= 8; ++k) look(a + d * (k / 8.0), r);
    return best;
  }
  // Balls of radius min(r, len / 2) along the axis, and balls of radius len / 2 around the
  // rim's middle circle.
  const double rho = std::min(r, len / 2);
  for (int k = 0; k <= 4; ++k) {
    const double t = len > 2 * rho ? (rho + (len - 2 * rho) * k / 4.0) / len : 0.5;
    look(a + d * t, rho);
  }
  if (r > len / 2 && len > 0) {
    const Eigen::Vector3d n = d / len;
    const Eigen::Vector3d u = (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(n).normalized();
    const Eigen::Vector3d v = n.cross(u), mid = (a + b) / 2;
    // 64 around the rim: between two of them the rim strays less than 0.12 % of its radius.
    for (int k = 0; k < 64; ++k) {
      const double ang = 2 * M_PI * k / 64;
      look(mid + (r - len / 2) * (std::cos(ang) * u + std::sin(ang) * v), len / 2);
    }
  }
  return best;
}

}  // namespace machplan::placement
