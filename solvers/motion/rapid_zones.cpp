#include "solvers/motion/rapid_zones.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

Eigen::AlignedBox2d grown(const Vector2d& a, const Vector2d& b, double by) {
  Eigen::AlignedBox2d box(a);
  box.extend(b);
  box.min().array() -= by;
  box.max().array() += by;
  return box;
}

}  // namespace

// Completeness of the candidates for a line L = [a, b] and an arc A (centre c, radius r):
// d(q, A) for a point q is the least of |q - A.start|, |q - A.end| and, when the direction
// of q - c lies in A's angular range, ||q - c| - r|. Minimising the first two over L gives the
// distances of A's end points to L. For the third, the part of L inside the angular wedge is
// a union of intervals; on each, ||q - c| - r| is either 0 where L crosses the circle (a
// crossing candidate), or convex with its minimum at the foot of c on L (the foot
// candidate), or concave with its minimum at an interval end. Interval ends are end points
// of L (candidates) or points on the wedge's boundary rays, where the value equals the
// distance to an end point of A (covered). Every candidate is d(q, A) for an actual q on L,
// so none is too small.
double segment_distance_mm(const Vector2d& a, const Vector2d& b, const Segment& span) {
  if (!span.is_arc()) {
    const Vector2d &c = span.start, &d = span.end;
    const double o1 = cross(b - a, c - a), o2 = cross(b - a, d - a);
    const double o3 = cross(d - c, a - c), o4 = cross(d - c, b - c);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return 0.0;
    return std::min({point_segment_distance(c, a, b), point_segment_distance(d, a, b), point_segment_distance(a, c, d),
                     point_segment_distance(b, c, d)});
  }
  const auto to_arc = [&](const Vector2d& q) { return (closest_point(span, q) - q).norm(); };
  double best = std::min({to_arc(a), to_arc(b), point_segment_distance(span.start, a, b),
                          point_segment_distance(span.end, a, b)});
  const Vector2d d = b - a;
  const double l2 = d.squaredNorm();
  if (l2 > 0.0) {
    const Vector2d f = a - span.center;
    const double t_foot = std::clamp(-f.dot(d) / l2, 0.0, 1.0);
    best = std::min(best, to_arc(a + t_foot * d));
    // |a + t d - c|^2 = r^2  ->  l2 t^2 + 2 B t + C = 0
    const double B = f.dot(d), C = f.squaredNorm() - span.radius * span.radius;
    const double disc = B * B - l2 * C;
    if (disc >= 0.0) {
      const double root = std::sqrt(disc);
      for (double t : {(-B - root) / l2, (-B + root) / l2})
        if (t >= 0.0 && t <= 1.0) best = std::min(best, to_arc(a + t * d));
    }
  }
  return best;
}

double region_distance_mm(const Vector2d& a, const Vector2d& b, const Contour& zone) {
  if (zone.empty()) return kInf;
  double best = kInf;
  for (const Segment& s : zone.segments()) best = std::min(best, segment_distance_mm(a, b, s));
  if (best > 0.0 && contains(zone, a)) return 0.0;
  return best;
}

double polyline_clearance_mm(const std::vector<Vector2d>& polyline, const std::vector<Contour>& zones) {
  if (zones.empty() || polyline.empty()) return kInf;
  return ZoneSet(zones, 1.0).polyline_distance(polyline);
}

// ---------------------------------------------------------------------------------------

ZoneSet::ZoneSet(std::vector<Contour> zones, double clearance_mm) : zones_(std::move(zones)), clearance_(clearance_mm) {
  std::vector<Contour> indexed;
  for (std::size_t j = 0; j < zones_.size(); ++j) {
    spans_.push_back(zones_[j].empty() ? std::vector<Segment>{} : zones_[j].segments());
    boxes_.push_back(zones_[j].empty() ? Eigen::AlignedBox2d() : bounding_box(zones_[j]));
    if (zones_[j].empty()) continue;
    zone_of_.push_back(static_cast<std::uint32_t>(j));
    indexed.push_back(zones_[j]);
  }
  active_.assign(zones_.size(), 1);
  if (!indexed.empty()) index_ = SpanIndex(indexed);
}

double ZoneSet::point_distance(const Vector2d& p, std::size_t j) const {
  if (spans_[j].empty()) return kInf;
  if (contains(zones_[j], p)) return 0.0;
  return distance(zones_[j], p);
}

double ZoneSet::segment_distance(const Vector2d& a, const Vector2d& b, std::size_t j, double cap) const {
  if (spans_[j].empty()) return kInf;
  double best = cap;
  if (grown(a, b, 0.0).exteriorDistance(boxes_[j]) >= best) return best;
  const auto consider = [&](std::size_t k) { best = std::min(best, segment_distance_mm(a, b, spans_[j][k])); };
  if (std::isfinite(cap)) {
    for_each_span(grown(a, b, cap), [&](std::size_t zone, std::size_t k) {
      if (zone == j && best > 0.0) consider(k);
    });
  } else {
    for (std::size_t k = 0; k < spans_[j].size() && best > 0.0; ++k) consider(k);
  }
  // Apart from the boundary: the segment is wholly inside or wholly outside.
  if (best > 0.0 && contains(zones_[j], a)) return 0.0;
  return best;
}

std::vector<std::size_t> ZoneSet::holding(const Vector2d& p, const Skip& skip) const {
  std::vector<std::pair<std::uint32_t, int>> w;
  index_.windings(p, w);
  std::vector<std::size_t> out;
  for (const auto& [c, n] : w)
    if (considered(zone_of_[c], skip)) out.push_back(zone_of_[c]);
  return out;
}

std::vector<std::size_t> ZoneSet::near(const Vector2d& p, double radius, const Skip& skip) const {
  std::vector<std::size_t> out = holding(p, skip);
  for_each_span(grown(p, p, radius), [&](std::size_t j, std::size_t k) {
    if (!considered(j, skip) || std::find(out.begin(), out.end(), j) != out.end()) return;
    if ((closest_point(spans_[j][k], p) - p).norm() < radius) out.push_back(j);
  });
  std::sort(out.begin(), out.end());
  return out;
}

double ZoneSet::nearest_span(const Vector2d& a, const Vector2d& b, double cap, const Skip& skip) const {
  double best = cap;
  for_each_span(grown(a, b, cap), [&](std::size_t j, std::size_t k) {
    if (best > 0.0 && considered(j, skip)) best = std::min(best, segment_distance_mm(a, b, spans_[j][k]));
  });
  return best;
}

bool ZoneSet::point_clear(const Vector2d& p, const Skip& skip) const {
  return nearest_span(p, p, clearance_, skip) >= clearance_ && holding(p, skip).empty();
}

bool ZoneSet::segment_clear(const Vector2d& a, const Vector2d& b, const Skip& skip) const {
  // No span within the clearance means the segment cannot cross a boundary: it is inside a
  // zone everywhere or nowhere, so its start decides.
  return nearest_span(a, b, clearance_, skip) >= clearance_ && holding(a, skip).empty();
}

bool ZoneSet::polyline_clear(const std::vector<Vector2d>& p, const Skip& skip) const {
  if (p.size() == 1) return point_clear(p[0], skip);
  for (std::size_t i = 1; i < p.size(); ++i)
    if (!segment_clear(p[i - 1], p[i], skip)) return false;
  return true;
}

double ZoneSet::polyline_distance(const std::vector<Vector2d>& p, const Skip& skip) const {
  if (p.empty() || index_.empty()) return kInf;
  if (!holding(p.front(), skip).empty()) return 0.0;
  // Each piece: a box search grown until it finds a span nearer than its own margin (spans
  // outside the box are at least the margin away) or covers every span.
  const Eigen::AlignedBox2d all = index_.bounds();
  const auto piece = [&](const Vector2d& a, const Vector2d& b) {
    for (double cap = std::max(clearance_, 1.0);; cap *= 4.0) {
      if (grown(a, b, cap).contains(all)) return nearest_span(a, b, kInf, skip);
      const double d = nearest_span(a, b, cap, skip);
      if (d < cap) return d;
    }
  };
  if (p.size() == 1) return piece(p[0], p[0]);
  double best = kInf;
  for (std::size_t i = 1; i < p.size(); ++i) best = std::min(best, piece(p[i - 1], p[i]));
  return best;
}

bool ZoneSet::enters(const std::vector<Vector2d>& p, std::size_t j, double depth_mm) const {
  if (spans_[j].empty()) return false;
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const Vector2d a = p[i], b = p[i + 1];
    if (grown(a, b, 0.0).exteriorDistance(boxes_[j]) > 0.0) continue;
    // Parameters along a -> b where it meets the boundary.
    std::vector<double> ts = {0.0, 1.0};
    const Segment piece = make_segment(a, b, 0.0);
    for (const Segment& s : spans_[j])
      for (const Vector2d& q : intersect(piece, s, 1e-9).points) ts.push_back(parameter_at(piece, q));
    std::sort(ts.begin(), ts.end());
    for (std::size_t k = 0; k + 1 < ts.size(); ++k) {
      if (ts[k + 1] - ts[k] <= 1e-12) continue;
      const Vector2d mid = a + 0.5 * (ts[k] + ts[k + 1]) * (b - a);
      if (contains(zones_[j], mid) && distance(zones_[j], mid) > depth_mm) return true;
    }
  }
  return false;
}

}  // namespace machplan::motion
