#include "engine/motion/interpolator.h"

#include <algorithm>
#include <cmath>

namespace machplan::motion {

PathPoint interpolate(const Segment& seg, double s_mm) {
  PathPoint p;
  if (!seg.is_arc()) {
    const Eigen::Vector2d d = seg.end - seg.start;
    const double len = d.norm();
    if (len <= 0.0) {
      p.position_mm = seg.start;
      return p;
    }
    const double s = std::clamp(s_mm, 0.0, len);
    p.tangent = d / len;
    p.position_mm = seg.start + s * p.tangent;
    return p;
  }
  const double len = seg.radius * std::abs(seg.sweep);
  const double s = std::clamp(s_mm, 0.0, len);
  const double sign = seg.sweep >= 0.0 ? 1.0 : -1.0;
  const double th = seg.start_angle + sign * s / seg.radius;
  const double c = std::cos(th), sn = std::sin(th);
  p.position_mm = seg.center + seg.radius * Eigen::Vector2d(c, sn);
  p.tangent = sign * Eigen::Vector2d(-sn, c);
  p.curvature_per_mm = sign / seg.radius;
  return p;
}

}  // namespace machplan::motion
