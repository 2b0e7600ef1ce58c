#include "engine/geometry/paper_offset.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <numbers>

namespace machplan {

using Eigen::Vector2d;

std::vector<Vector2d> polygonise(const Contour& contour, double chord_tolerance_mm,
                                 std::vector<std::size_t>* source_spans) {
  std::vector<Vector2d> out;
  if (source_spans) source_spans->clear();
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const Segment s = contour.span(i);
    out.push_back(s.start);
    if (source_spans) source_spans->push_back(i);
    if (!s.is_arc()) continue;
    // A chord subtending theta has sagitta r (1 - cos(theta / 2)).
    const double ratio = std::clamp(1.0 - chord_tolerance_mm / s.radius, -1.0, 1.0);
    const double max_theta = std::max(2.0 * std::acos(ratio), 1e-6);
    const auto pieces = static_cast<std::size_t>(std::ceil(std::abs(s.sweep) / max_theta - 1e-9));
    for (std::size_t k = 1; k < pieces; ++k) {
      out.push_back(point_at(s, static_cast<double>(k) / static_cast<double>(pieces)));
      if (source_spans) source_spans->push_back(i);
    }
  }
  return out;
}

PaperOffsetResult paper_offset(const Contour& contour, double d, double chord_tolerance_mm, double tol) {
  PaperOffsetResult result;
  std::vector<std::size_t> src0;
  const std::vector<Vector2d> poly = polygonise(contour, chord_tolerance_mm, &src0);
  // Drop repeated points (spans shorter than the tolerance).
  std::vector<Vector2d> v;
  std::vector<std::size_t> src;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    if (!v.empty() && (poly[i] - v.back()).norm() <= tol) continue;
    v.push_back(poly[i]);
    src.push_back(src0[i]);
  }
  while (v.size() > 1 && (v.back() - v.front()).norm() <= tol) {
    v.pop_back();
    src.pop_back();
  }
  const std::size_t n = v.size();
  if (n < 3) return result;

  // Step 1: a doubly linked ring; a work queue re-examines the neighbours of every removal,
  // so the filter ends in O(n) examinations.
  std::vector<std::size_t> prev(n), next(n);
  std::vector<bool> alive(n, true);
  for (std::size_t i = 0; i < n; ++i) {
    prev[i] = (i + n - 1) % n;
    next[i] = (i + 1) % n;
  }
  std::size_t count = n;
  std::deque<std::size_t> work;
  for (std::size_t i = 0; i < n; ++i) work.push_back(i);
  const double r = std::abs(d);
  auto remove = [&](std::size_t b, double setback, double segment) {
    if (!alive[b]) return;
    alive[b] = false;
    --count;
    next[prev[b]] = next[b];
    prev[next[b]] = prev[b];
    result.dropped.push_back({src[b], v[b], setback, segment});
    work.push_back(prev[b]);
    work.push_back(next[b]);
  };
  while (!work.empty() && count >= 3) {
    const std::size_t b = work.front();
    work.pop_front();
    if (!alive[b]) continue;
    const std::size_t a = prev[b], c = next[b];
    const Vector2d ab = v[b] - v[a], bc = v[c] - v[b];
    const double lab = ab.norm(), lbc = bc.norm();
    const double cosphi = std::clamp(ab.dot(bc) / (lab * lbc), -1.0, 1.0);
    const double phi = std::acos(cosphi);
    // tan(phi / 2) without the pole at phi = pi: sin(phi) / (1 + cos(phi)).
    const double setback = 1.0 + cosphi > 1e-15 ? r * std::sin(phi) / (1.0 + cosphi)
                                                : std::numeric_limits<double>::infinity();
    const bool drop_b = setback > lab, drop_c = setback > lbc;
    if (drop_c && c != b) remove(c, setback, lbc);
    if (drop_b && count >= 3) remove(b, setback, lab);
  }
  if (count < 3) return result;

  // Step 2: mitre points of the shifted segments.
  std::size_t start = 0;
  while (!alive[start]) ++start;
  std::size_t i = start;
  do {
    const std::size_t a = prev[i], c = next[i];
    const Vector2d t1 = (v[i] - v[a]).normalized(), t2 = (v[c] - v[i]).normalized();
    const Vector2d n1(t1.y(), -t1.x()), n2(t2.y(), -t2.x());
    const double den = 1.0 + n1.dot(n2);
    // den -> 0 is a hairpin; step 1 has removed those whose setback exceeds a neighbour, so
    // den is bounded away from 0 unless R is 0.
    const Vector2d mitre = den > 1e-12 ? Vector2d(d * (n1 + n2) / den) : Vector2d(d * n1);
    result.vertices.push_back(v[i] + mitre);
    result.source_spans.push_back(src[i]);
    i = c;
  } while (i != start);
  return result;
}

}  // namespace machplan
