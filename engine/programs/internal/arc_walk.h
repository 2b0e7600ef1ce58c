// Points along a circular or helical move, as the tool-path readers add them (toolpath.h): the
// APT reader's CIRCLE and the G-code job's arcs share one rule for how close they lie.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/programs/toolpath.h"

namespace machplan::toolpath_internal {

// A move about the line through `center` along the unit `axis`, from `start` turning `sweep`
// rad (right-hand rule about the axis; more than a turn for a multi-turn helix) while rising
// linearly along the axis to `end`'s height. Its n steps are at most options.arc_step_rad
// apart, and close enough that each chord stays within options.arc_tolerance_mm of the arc.
struct ArcWalk {
  Eigen::Vector3d center, axis, u, w;  // u: from the axis to the start, w = axis x u
  double r = 0, h0 = 0, h1 = 0, sweep = 0;
  std::size_t n = 1;

  ArcWalk(const Eigen::Vector3d& c, const Eigen::Vector3d& a, const Eigen::Vector3d& start, const Eigen::Vector3d& end,
          double sweep_rad, const ToolPathReadOptions& o)
      : center(c), axis(a), sweep(sweep_rad) {
    const Eigen::Vector3d rs = start - c, v = rs - rs.dot(a) * a;
    r = v.norm();
    u = v / r;
    w = a.cross(u);
    h0 = rs.dot(a);
    h1 = (end - c).dot(a);
    // The chord of angle h stays within r (1 - cos(h / 2)) of the arc.
    const double by_tol = 2 * std::acos(std::max(-1.0, 1 - o.arc_tolerance_mm / r));
    const double step = std::min(o.arc_step_rad, by_tol > 0 ? by_tol : o.arc_step_rad);
    n = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(sweep / step)));
  }
  // The point at step k of n (0: the start; n: the end's place on the arc).
  Eigen::Vector3d at(std::size_t k) const {
    const double f = static_cast<double>(k) / static_cast<double>(n), t = f * sweep;
    return center + r * (std::cos(t) * u + std::sin(t) * w) + (h0 + f * (h1 - h0)) * axis;
  }
};

}  // namespace machplan::toolpath_internal
