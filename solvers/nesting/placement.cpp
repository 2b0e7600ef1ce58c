#include "solvers/nesting/placement.h"

#include <cmath>
#include <numbers>
#include <vector>

namespace machplan::nesting {

Eigen::Vector2d Placement::apply(const Eigen::Vector2d& p) const {
  const double a = rotation_deg * std::numbers::pi / 180.0;
  const double c = std::cos(a), s = std::sin(a);
  const double x = mirrored ? -p.x() : p.x();
  return translate_mm + Eigen::Vector2d(c * x - s * p.y(), s * x + c * p.y());
}

Contour place(const Contour& c, const Placement& p) {
  std::vector<Eigen::Vector2d> v;
  v.reserve(c.size());
  for (const Eigen::Vector2d& q : c.vertices()) v.push_back(p.apply(q));
  std::vector<double> b = c.bulges();
  if (!p.mirrored) return Contour(std::move(v), std::move(b));
  // A mirror turns every arc the other way: its bulge changes sign, and the contour's sense.
  for (double& x : b) x = -x;
  return Contour(std::move(v), std::move(b)).reversed();
}

}  // namespace machplan::nesting
