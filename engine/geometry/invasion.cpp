#include "engine/geometry/invasion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/paper_offset.h"

namespace machplan {

using Eigen::Vector2d;

PolygonBoundary::PolygonBoundary(const ProhibitedRegion& region) {
  prohibited_left_ = region.options().side == MachiningSide::outside;
  for (const auto& c : region.boundary()) {
    const auto v = polygonise(c, region.options().paper_chord_tolerance_mm);
    const std::size_t first = edges_.size();
    for (std::size_t i = 0; i < v.size(); ++i) edges_.push_back({v[i], v[(i + 1) % v.size()]});
    polygons_.push_back({first, v.size()});
  }
}

PointMatrixCheck::PointMatrixCheck(const ProhibitedRegion& region, double spacing_mm) {
  if (!std::isfinite(spacing_mm) || !(spacing_mm > 0.0))
    throw InputError::field("spacing_mm", fmt::format("is {}, must be finite and > 0", spacing_mm));
  const PolygonBoundary poly(region);
  prohibited_left_ = poly.prohibited_left();
  const auto& e = poly.edges();
  auto left_normal = [](const Vector2d& a, const Vector2d& b) {
    const Vector2d t = b - a;
    const double n = t.norm();
    return n > 0 ? Vector2d(Vector2d(-t.y(), t.x()) / n) : Vector2d(0, 0);
  };
  for (const auto& [first, count] : poly.polygons()) {
    for (std::size_t k = 0; k < count; ++k) {
      const auto& edge = e[first + k];
      const auto& before = e[first + (k + count - 1) % count];
      const Vector2d n = left_normal(edge.a, edge.b);
      // The vertex, with the bisector of the two edge normals.
      const Vector2d bis = left_normal(before.a, before.b) + n;
      points_.push_back(edge.a);
      left_normals_.push_back(bis.norm() > 0 ? Vector2d(bis.normalized()) : n);
      const double len = (edge.b - edge.a).norm();
      const auto steps = static_cast<std::size_t>(std::ceil(len / spacing_mm));
      for (std::size_t s = 1; s < steps; ++s) {
        points_.push_back(edge.a + (edge.b - edge.a) * (static_cast<double>(s) / static_cast<double>(steps)));
        left_normals_.push_back(n);
      }
    }
  }
}

InvasionAnswer PointMatrixCheck::check(const Vector2d& p) const noexcept {
  double best = std::numeric_limits<double>::infinity();
  std::size_t at = 0;
  for (std::size_t j = 0; j < points_.size(); ++j) {
    const double d2 = (p - points_[j]).squaredNorm();
    if (d2 < best) {
      best = d2;
      at = j;
    }
  }
  if (points_.empty()) return {false, best};
  const bool left = (p - points_[at]).dot(left_normals_[at]) > 0.0;
  return {left == prohibited_left_, std::sqrt(best)};
}

AngleSumCheck::AngleSumCheck(const ProhibitedRegion& region) : poly_(region) {}

InvasionAnswer AngleSumCheck::check(const Vector2d& p) const noexcept {
  double sum = 0.0, best = std::numeric_limits<double>::infinity();
  for (const auto& e : poly_.edges()) {
    const Vector2d a = e.a - p, b = e.b - p;
    sum += std::atan2(cross(a, b), a.dot(b));
    best = std::min(best, point_segment_distance(p, e.a, e.b));
  }
  const int w = static_cast<int>(std::lround(sum / (2.0 * std::numbers::pi)));
  return {poly_.prohibited_for_winding(w), best};
}

IntervalDistanceCheck::IntervalDistanceCheck(const ProhibitedRegion& region) : poly_(region) {
  const auto& e = poly_.edges();
  order_.resize(e.size());
  std::iota(order_.begin(), order_.end(), std::size_t{0});
  std::sort(order_.begin(), order_.end(), [&](std::size_t i, std::size_t j) {
    const double a = std::min(e[i].a.x(), e[i].b.x()), b = std::min(e[j].a.x(), e[j].b.x());
    return a < b || (a == b && i < j);
  });
  for (const std::size_t i : order_) {
    xmin_.push_back(std::min(e[i].a.x(), e[i].b.x()));
    xmax_.push_back(std::max(e[i].a.x(), e[i].b.x()));
  }
}

InvasionAnswer IntervalDistanceCheck::check(const Vector2d& p) const noexcept {
  const auto& e = poly_.edges();
  // Edges whose x interval can hold p.x start at or left of it.
  const auto end = static_cast<std::size_t>(std::upper_bound(xmin_.begin(), xmin_.end(), p.x()) - xmin_.begin());
  int w = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < end; ++k) {
    if (xmax_[k] < p.x()) continue;
    const auto& edge = e[order_[k]];
    best = std::min(best, point_segment_distance(p, edge.a, edge.b));
    // Upward ray from p, half-open in x: an edge running towards -x above p has the positive
    // region (its left) below it, around p: +1.
    const Vector2d& a = edge.a;
    const Vector2d& b = edge.b;
    if (a.x() <= p.x() && p.x() < b.x()) {
      if (cross(b - a, p - a) < 0.0) --w;  // running +x, p on its right (below): p outside its left side
    } else if (b.x() <= p.x() && p.x() < a.x()) {
      if (cross(b - a, p - a) > 0.0) ++w;  // running -x, p on its left (below it)
    }
  }
  return {poly_.prohibited_for_winding(w), best};
}

}  // namespace machplan
