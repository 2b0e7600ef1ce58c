#include "solvers/nesting/outline.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/offset.h"

namespace machplan::nesting {

std::vector<Eigen::Vector2d> outside_polygon(const Contour& c, double tolerance_mm) {
  if (!(tolerance_mm > 0 && std::isfinite(tolerance_mm)))
    throw InputError::field("tolerance_mm", fmt::format("{} must be a distance > 0", tolerance_mm));
  std::vector<Eigen::Vector2d> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    out.push_back(s.start);
    if (!s.is_arc()) continue;
    const double sweep = std::abs(s.sweep), dir = s.sweep > 0 ? 1.0 : -1.0;
    if (s.sweep > 0) {
      // Left turn, away from the material: tangent pieces, each off the arc by at most the
      // tolerance: r (1 / cos(phi / 2) - 1) <= t.
      const double max_phi = 2 * std::acos(std::min(1.0, s.radius / (s.radius + tolerance_mm)));
      const int n = std::max(1, static_cast<int>(std::ceil(sweep / std::max(max_phi, 1e-6))));
      const double phi = sweep / n, reach = s.radius / std::cos(phi / 2);
      // The tangents at the ends of the n pieces meet at their middles' angles, at r / cos(phi / 2).
      for (int k = 0; k < n; ++k) {
        const double a = s.start_angle + dir * (k + 0.5) * phi;
        out.push_back(s.center + reach * Eigen::Vector2d(std::cos(a), std::sin(a)));
      }
    } else {
      // Right turn: chords, each off the arc by at most the tolerance: r (1 - cos(phi / 2)) <= t.
      const double max_phi = 2 * std::acos(std::max(-1.0, 1.0 - tolerance_mm / s.radius));
      const int n = std::max(1, static_cast<int>(std::ceil(sweep / std::max(max_phi, 1e-6))));
      for (int k = 1; k < n; ++k) {
        const double a = s.start_angle + dir * k * sweep / n;
        out.push_back(s.center + s.radius * Eigen::Vector2d(std::cos(a), std::sin(a)));
      }
    }
  }
  return out;
}

Contour grown_outline(const Contour& outer, double distance_mm) {
  if (distance_mm == 0.0) return outer;
  const OffsetResult g = offset_contour(outer, distance_mm);
  return *std::max_element(g.contours.begin(), g.contours.end(), [](const Contour& a, const Contour& b) {
    return std::abs(signed_area(a)) < std::abs(signed_area(b));
  });
}

}  // namespace machplan::nesting
