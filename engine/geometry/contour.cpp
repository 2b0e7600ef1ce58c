#include "engine/geometry/contour.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

using Eigen::Vector2d;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Bulges smaller than this are straight: the sagitta of a 3e9 mm chord is then below 2 um,
// and 1/|b| in the radius formula stays finite.
constexpr double kStraightBulge = 1e-12;

// True when direction angle `phi` lies on the arc's angular range, widened by tol_rad at
// each end.
bool angle_on_arc(const Segment& s, double phi, double tol_rad) {
  const double span = std::abs(s.sweep);
  const double d = s.sweep >= 0 ? wrap_angle_positive(phi - s.start_angle) : wrap_angle_positive(s.start_angle - phi);
  return d <= span + tol_rad || d >= kTwoPi - tol_rad;
}

// True when point q (assumed on or near the arc's circle) is on the arc within tol_mm.
bool on_arc(const Segment& s, const Vector2d& q, double tol_mm) {
  const Vector2d v = q - s.center;
  if (v.norm() == 0.0) return s.radius <= tol_mm;
  const double tol_rad = s.radius > 0 ? tol_mm / s.radius : kTwoPi;
  return angle_on_arc(s, std::atan2(v.y(), v.x()), tol_rad);
}

// Distance from q to segment s.
double dist(const Segment& s, const Vector2d& q) { return (closest_point(s, q) - q).norm(); }

void add_unique(std::vector<Vector2d>& pts, const Vector2d& p, double tol) {
  for (const auto& q : pts)
    if ((q - p).norm() <= std::max(tol, 1e-12)) return;
  pts.push_back(p);
}

// A zero-length segment is a point: it meets `other` when within tol of it.
Intersection point_vs(const Vector2d& p, const Segment& other, double tol) {
  Intersection r;
  if (dist(other, p) <= tol) r.points.push_back(p);
  return r;
}

Intersection line_line(const Segment& a, const Segment& b, double tol) {
  Intersection r;
  const Vector2d d1 = a.end - a.start, d2 = b.end - b.start;
  const double l1 = d1.norm(), l2 = d2.norm();
  if (l1 == 0.0) return point_vs(a.start, b, tol);
  if (l2 == 0.0) return point_vs(b.start, a, tol);
  const double denom = cross(d1, d2);
  const Vector2d w = b.start - a.start;
  if (std::abs(denom) <= 1e-12 * l1 * l2) {
    // Parallel: do they lie on one line?
    if (std::abs(cross(d1, w)) / l1 > tol) return r;
    const double t0 = w.dot(d1) / (l1 * l1), t1 = (b.end - a.start).dot(d1) / (l1 * l1);
    const double lo = std::max(0.0, std::min(t0, t1)), hi = std::min(1.0, std::max(t0, t1));
    const double tol_t = tol / l1;
    if (hi < lo - tol_t) return r;
    if ((hi - lo) * l1 <= tol) {
      r.points.push_back(a.start + std::clamp(0.5 * (lo + hi), 0.0, 1.0) * d1);
      return r;
    }
    r.overlap = true;
    r.points = {a.start + lo * d1, a.start + hi * d1};
    return r;
  }
  const double t = cross(w, d2) / denom, u = cross(w, d1) / denom;
  if (t < -tol / l1 || t > 1 + tol / l1 || u < -tol / l2 || u > 1 + tol / l2) return r;
  r.points.push_back(a.start + std::clamp(t, 0.0, 1.0) * d1);
  return r;
}

Intersection line_arc(const Segment& line, const Segment& arc, double tol) {
  Intersection r;
  const Vector2d d = line.end - line.start;
  const double l = d.norm();
  if (l == 0.0) return point_vs(line.start, arc, tol);
  const Vector2d f = line.start - arc.center;
  const double t0 = -f.dot(d) / (l * l);  // foot of the perpendicular from the centre
  const double h = std::abs(cross(d, f)) / l;
  if (h > arc.radius + tol) return r;
  const double half = std::sqrt(std::max(0.0, arc.radius * arc.radius - h * h)) / l;
  const double cand[2] = {t0 - half, t0 + half};
  const int count = half * l <= tol ? 1 : 2;
  for (int k = 0; k < count; ++k) {
    const double t = count == 1 ? t0 : cand[k];
    if (t < -tol / l || t > 1 + tol / l) continue;
    const Vector2d q = line.start + std::clamp(t, 0.0, 1.0) * d;
    if (on_arc(arc, q, tol) && dist(arc, q) <= tol + 1e-9 * (1 + arc.radius)) add_unique(r.points, q, tol);
  }
  return r;
}

Intersection arc_arc(const Segment& a, const Segment& b, double tol) {
  Intersection r;
  const Vector2d dc = b.center - a.center;
  const double d = dc.norm();
  if (d <= tol && std::abs(a.radius - b.radius) <= tol) {
    // One circle: shared pieces come from the end points of one lying on the other.
    std::vector<Vector2d> pts;
    for (const auto& p : {a.start, a.end})
      if (on_arc(b, p, tol)) add_unique(pts, p, tol);
    for (const auto& p : {b.start, b.end})
      if (on_arc(a, p, tol)) add_unique(pts, p, tol);
    const Vector2d mid_a = point_at(a, 0.5), mid_b = point_at(b, 0.5);
    bool overlap = on_arc(b, mid_a, -tol) || on_arc(a, mid_b, -tol);
    for (std::size_t i = 0; i < pts.size() && !overlap; ++i)
      for (std::size_t j = i + 1; j < pts.size() && !overlap; ++j) {
        // The middle of the piece of a between two shared points, if a holds it.
        const Vector2d m = 0.5 * (pts[i] + pts[j]) - a.center;
        for (double sgn : {1.0, -1.0}) {
          if (m.norm() == 0.0) continue;
          const Vector2d q = a.center + sgn * a.radius * m.normalized();
          if (on_arc(a, q, -tol) && on_arc(b, q, -tol)) overlap = true;
        }
      }
    r.points = pts;
    r.overlap = overlap;
    return r;
  }
  if (d == 0.0 || d > a.radius + b.radius + tol || d < std::abs(a.radius - b.radius) - tol) return r;
  const double x = (d * d + a.radius * a.radius - b.radius * b.radius) / (2 * d);
  const double h = std::sqrt(std::max(0.0, a.radius * a.radius - x * x));
  const Vector2d u = dc / d, n(-u.y(), u.x());
  const Vector2d base = a.center + x * u;
  const int count = h <= tol ? 1 : 2;
  for (int k = 0; k < count; ++k) {
    const Vector2d q = count == 1 ? base : Vector2d(base + (k == 0 ? h : -h) * n);
    if (on_arc(a, q, tol) && on_arc(b, q, tol)) add_unique(r.points, q, tol);
  }
  return r;
}

}  // namespace

Segment make_segment(const Vector2d& a, const Vector2d& b, double bulge) {
  Segment s;
  s.start = a;
  s.end = b;
  const double c = (b - a).norm();
  if (c == 0.0 || std::abs(bulge) < kStraightBulge) return s;
  s.kind = Segment::Kind::arc;
  const double ab = std::abs(bulge);
  s.radius = 0.25 * c * (ab + 1.0 / ab);
  s.sweep = 4.0 * std::atan(bulge);
  const Vector2d u = (b - a) / c, nl(-u.y(), u.x());
  s.center = 0.5 * (a + b) + nl * (0.25 * c * (1.0 / bulge - bulge));
  s.start_angle = std::atan2(a.y() - s.center.y(), a.x() - s.center.x());
  return s;
}

double length(const Segment& s) {
  return s.is_arc() ? s.radius * std::abs(s.sweep) : (s.end - s.start).norm();
}

Vector2d point_at(const Segment& s, double t) {
  t = std::clamp(t, 0.0, 1.0);
  if (t == 0.0) return s.start;
  if (t == 1.0) return s.end;
  if (!s.is_arc()) return s.start + t * (s.end - s.start);
  const double phi = s.start_angle + t * s.sweep;
  return s.center + s.radius * Vector2d(std::cos(phi), std::sin(phi));
}

Vector2d closest_point(const Segment& s, const Vector2d& p) {
  if (!s.is_arc()) return closest_point_on_segment(s.start, s.end, p);
  const Vector2d v = p - s.center;
  if (v.norm() > 0.0 && angle_on_arc(s, std::atan2(v.y(), v.x()), 0.0))
    return s.center + s.radius * v.normalized();
  return (s.start - p).squaredNorm() <= (s.end - p).squaredNorm() ? s.start : s.end;
}

double wrap_angle_positive(double angle_rad) {
  double w = std::fmod(angle_rad, kTwoPi);
  if (w < 0) w += kTwoPi;
  if (w >= kTwoPi) w = 0.0;
  return w;
}

Vector2d closest_point_on_segment(const Vector2d& a, const Vector2d& b, const Vector2d& p) {
  const Vector2d d = b - a;
  const double l2 = d.squaredNorm();
  if (l2 == 0.0) return a;
  return a + std::clamp((p - a).dot(d) / l2, 0.0, 1.0) * d;
}

double point_segment_distance(const Vector2d& p, const Vector2d& a, const Vector2d& b) {
  return (closest_point_on_segment(a, b, p) - p).norm();
}

double parameter_at(const Segment& s, const Vector2d& p) {
  if (!s.is_arc()) {
    const Vector2d d = s.end - s.start;
    const double l2 = d.squaredNorm();
    return l2 == 0.0 ? 0.0 : std::clamp((p - s.start).dot(d) / l2, 0.0, 1.0);
  }
  const Vector2d v = p - s.center;
  const double a = std::atan2(v.y(), v.x()), span = std::abs(s.sweep);
  const double delta = s.sweep > 0 ? wrap_angle_positive(a - s.start_angle) : wrap_angle_positive(s.start_angle - a);
  if (delta <= span) return span > 0 ? delta / span : 0.0;
  return (delta - span) < (kTwoPi - delta) ? 1.0 : 0.0;
}

namespace {
Vector2d arc_tangent_at_angle(const Segment& s, double phi) {
  const Vector2d t(-std::sin(phi), std::cos(phi));
  return s.sweep > 0 ? t : Vector2d(-t);
}
}  // namespace

Vector2d start_tangent(const Segment& s) {
  if (!s.is_arc()) return (s.end - s.start).normalized();
  return arc_tangent_at_angle(s, s.start_angle);
}

Vector2d end_tangent(const Segment& s) {
  if (!s.is_arc()) return (s.end - s.start).normalized();
  return arc_tangent_at_angle(s, s.end_angle());
}

Vector2d tangent_at(const Segment& s, const Vector2d& q) {
  if (!s.is_arc()) {
    const Vector2d d = s.end - s.start;
    return d.norm() > 0.0 ? Vector2d(d.normalized()) : Vector2d(1.0, 0.0);
  }
  const Vector2d r = q - s.center;
  const Vector2d t(-r.y(), r.x());
  const double n = t.norm();
  if (n == 0.0) return {1.0, 0.0};
  return (s.sweep >= 0 ? 1.0 : -1.0) * t / n;
}

Eigen::AlignedBox2d bounding_box(const Segment& s) {
  Eigen::AlignedBox2d box(s.start);
  box.extend(s.end);
  if (s.is_arc())
    for (int k = 0; k < 4; ++k) {
      const double phi = k * 0.5 * kPi;
      if (angle_on_arc(s, phi, 0.0)) box.extend(Vector2d(s.center + s.radius * Vector2d(std::cos(phi), std::sin(phi))));
    }
  return box;
}

Intersection intersect(const Segment& a, const Segment& b, double tolerance_mm) {
  const double tol = std::max(0.0, tolerance_mm);
  if (!a.is_arc() && !b.is_arc()) return line_line(a, b, tol);
  if (!a.is_arc()) return line_arc(a, b, tol);
  if (!b.is_arc()) return line_arc(b, a, tol);
  return arc_arc(a, b, tol);
}

Contour::Contour(std::vector<Vector2d> vertices, std::vector<double> bulges)
    : vertices_(std::move(vertices)), bulges_(std::move(bulges)) {
  if (vertices_.empty()) throw InputError::field("vertices", "a contour needs at least one vertex");
  if (vertices_.size() != bulges_.size())
    throw InputError::field("bulges", fmt::format("{} vertices but {} bulges", vertices_.size(), bulges_.size()));
  for (std::size_t i = 0; i < vertices_.size(); ++i) {
    const auto& v = vertices_[i];
    if (!std::isfinite(v.x()) || !std::isfinite(v.y()) || std::abs(v.x()) > kMaxCoordinateMm ||
        std::abs(v.y()) > kMaxCoordinateMm)
      throw InputError::field("vertices", fmt::format("vertex {} = ({}, {}) is not finite or beyond {} mm", i, v.x(),
                                                      v.y(), kMaxCoordinateMm));
    if (!std::isfinite(bulges_[i]) || std::abs(bulges_[i]) > kMaxBulge)
      throw InputError::field("bulges", fmt::format("bulge {} = {} is not finite or beyond {}", i, bulges_[i], kMaxBulge));
  }
}

Contour Contour::circle(const Vector2d& center, double r, bool ccw) {
  require_field(r > 0.0 && std::isfinite(r), "r", r, "is not a positive radius");
  const double b = ccw ? 1.0 : -1.0;
  return Contour({center + Vector2d(r, 0), center - Vector2d(r, 0)}, {b, b});
}

Segment Contour::span(std::size_t i) const {
  return make_segment(vertices_[i], vertices_[(i + 1) % vertices_.size()], bulges_[i]);
}

std::vector<Segment> Contour::segments() const {
  std::vector<Segment> out;
  out.reserve(size());
  for (std::size_t i = 0; i < size(); ++i) out.push_back(span(i));
  return out;
}

Contour Contour::reversed() const {
  const std::size_t n = size();
  std::vector<Vector2d> v(n);
  std::vector<double> b(n);
  for (std::size_t k = 0; k < n; ++k) {
    v[k] = vertices_[(n - k) % n];
    b[k] = -bulges_[(2 * n - k - 1) % n];
  }
  return Contour(std::move(v), std::move(b));
}

const char* to_string(Orientation o) {
  switch (o) {
    case Orientation::ccw: return "ccw";
    case Orientation::cw: return "cw";
    case Orientation::degenerate: return "degenerate";
  }
  return "?";
}

double signed_area(const Contour& c) {
  if (c.empty()) return 0.0;
  const Vector2d o = c.vertices().front();  // origin near the data keeps the sum accurate
  double twice = 0.0, arcs = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    twice += cross(s.start - o, s.end - o);
    if (s.is_arc()) arcs += 0.5 * s.radius * s.radius * (s.sweep - std::sin(s.sweep));
  }
  return 0.5 * twice + arcs;
}

Orientation orientation(const Contour& c, double tolerance_mm2) {
  const double a = signed_area(c);
  if (a > tolerance_mm2) return Orientation::ccw;
  if (a < -tolerance_mm2) return Orientation::cw;
  return Orientation::degenerate;
}

double perimeter(const Contour& c) {
  double sum = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) sum += length(c.span(i));
  return sum;
}

Eigen::AlignedBox2d bounding_box(const Contour& c) {
  Eigen::AlignedBox2d box;  // empty
  for (std::size_t i = 0; i < c.size(); ++i) box.extend(bounding_box(c.span(i)));
  return box;
}

Vector2d point_at_length(const Contour& c, double s) {
  if (c.empty()) return Vector2d::Zero();
  const double total = perimeter(c);
  if (!(total > 0.0) || !std::isfinite(s)) return c.vertices().front();
  s = std::fmod(s, total);
  if (s < 0) s += total;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment seg = c.span(i);
    const double l = length(seg);
    if (s <= l && l > 0.0) return point_at(seg, s / l);
    s -= l;
  }
  return c.vertices().front();
}

ContourPoint closest_point(const Contour& c, const Vector2d& p) {
  ContourPoint best;
  best.distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Vector2d q = closest_point(c.span(i), p);
    const double d = (q - p).norm();
    if (d < best.distance) best = {q, i, d};
  }
  return best;
}

double distance(const Contour& c, const Vector2d& p) { return closest_point(c, p).distance; }

int winding_number(const Contour& c, const Vector2d& p) {
  double total = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    const Vector2d a = s.start - p, b = s.end - p;
    const Vector2d chord = s.end - s.start;
    const double side_p = cross(chord, p - s.start);
    if (s.is_arc()) {
      // p on the chord itself, strictly between the ends: the chord's angle is +-pi with an
      // undetermined sign, but the arc turns half way round p in its own sense.
      const double c2 = chord.squaredNorm();
      const double t = (p - s.start).dot(chord) / c2;
      if (std::abs(side_p) <= 1e-12 * c2 && t > 0 && t < 1) {
        total += s.sweep > 0 ? kPi : -kPi;
        continue;
      }
    }
    total += std::atan2(cross(a, b), a.dot(b));
    if (s.is_arc() && (p - s.center).norm() < s.radius) {
      // Inside the circular segment between chord and arc: the arc goes once more around p.
      const double side_m = cross(chord, point_at(s, 0.5) - s.start);
      if (side_p * side_m > 0) total += s.sweep > 0 ? kTwoPi : -kTwoPi;
    }
  }
  return static_cast<int>(std::lround(total / kTwoPi));
}

bool contains(const Contour& c, const Vector2d& p) { return winding_number(c, p) != 0; }

void for_each_intersecting_pair(const std::vector<Eigen::AlignedBox2d>& boxes,
                                const std::function<void(std::size_t, std::size_t)>& f) {
  // Sweep along the axis where the boxes are thinner compared with how far they spread.
  Eigen::AlignedBox2d all;
  Vector2d summed = Vector2d::Zero();
  std::vector<std::size_t> order;
  order.reserve(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (boxes[i].isEmpty()) continue;
    order.push_back(i);
    all.extend(boxes[i]);
    summed += boxes[i].sizes();
  }
  if (order.size() < 2) return;
  const Vector2d spread = all.sizes();
  const int ax = summed.x() * spread.y() <= summed.y() * spread.x() ? 0 : 1, other = 1 - ax;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return boxes[a].min()[ax] < boxes[b].min()[ax] || (boxes[a].min()[ax] == boxes[b].min()[ax] && a < b);
  });
  std::vector<std::size_t> active;
  for (const std::size_t i : order) {
    const auto& bi = boxes[i];
    std::size_t kept = 0;
    for (const std::size_t j : active) {
      if (boxes[j].max()[ax] < bi.min()[ax]) continue;  // closed before this one opens
      active[kept++] = j;
      if (boxes[j].min()[other] <= bi.max()[other] && bi.min()[other] <= boxes[j].max()[other]) f(j, i);
    }
    active.resize(kept);
    active.push_back(i);
  }
}

std::vector<SelfIntersection> self_intersections(const Contour& c, double tolerance_mm) {
  const double tol = std::max(0.0, tolerance_mm);
  std::vector<SelfIntersection> out;
  const auto segs = c.segments();
  std::vector<std::size_t> live;  // spans long enough to matter
  for (std::size_t i = 0; i < segs.size(); ++i)
    if (length(segs[i]) > tol) live.push_back(i);
  const std::size_t m = live.size();
  std::vector<Eigen::AlignedBox2d> boxes;
  for (auto i : live) {
    auto box = bounding_box(segs[i]);
    boxes.push_back(Eigen::AlignedBox2d(box.min() - Vector2d::Constant(tol), box.max() + Vector2d::Constant(tol)));
  }
  for_each_intersecting_pair(boxes, [&](std::size_t x, std::size_t y) {
    if (x > y) std::swap(x, y);
    const Segment& a = segs[live[x]];
    const Segment& b = segs[live[y]];
    // Vertices the two spans legitimately share: consecutive live spans meet at one. A
    // shared piece of curve shows up as end points away from these and is reported.
    std::vector<Vector2d> shared;
    if (y == x + 1) shared.push_back(a.end);
    if (x == 0 && y == m - 1) shared.push_back(b.end);
    const Intersection hit = intersect(a, b, tol);
    for (const auto& p : hit.points) {
      bool at_shared = false;
      for (const auto& v : shared) at_shared = at_shared || (p - v).norm() <= 2 * tol + 1e-9;
      if (!at_shared) out.push_back({live[x], live[y], p});
    }
  });
  std::stable_sort(out.begin(), out.end(), [](const SelfIntersection& p, const SelfIntersection& q) {
    return p.span_a < q.span_a || (p.span_a == q.span_a && p.span_b < q.span_b);
  });
  return out;
}

std::vector<Vector2d> contour_intersections(const Contour& a, const Contour& b, double tolerance_mm) {
  const double tol = std::max(0.0, tolerance_mm);
  const auto sa = a.segments(), sb = b.segments();
  std::vector<Eigen::AlignedBox2d> boxes;  // a's spans grown by the tolerance, then b's
  for (const auto& s : sa) {
    const auto box = bounding_box(s);
    boxes.emplace_back(box.min() - Vector2d::Constant(tol), box.max() + Vector2d::Constant(tol));
  }
  for (const auto& s : sb) boxes.push_back(bounding_box(s));
  struct Hit { std::size_t i, j; Vector2d p; };
  std::vector<Hit> hits;
  for_each_intersecting_pair(boxes, [&](std::size_t x, std::size_t y) {
    if (x > y) std::swap(x, y);
    if (x >= sa.size() || y < sa.size()) return;  // both spans from the same contour
    for (const auto& p : intersect(sa[x], sb[y - sa.size()], tol).points) hits.push_back({x, y, p});
  });
  std::stable_sort(hits.begin(), hits.end(), [](const Hit& p, const Hit& q) { return p.i < q.i || (p.i == q.i && p.j < q.j); });
  std::vector<Vector2d> out;
  for (const auto& h : hits) add_unique(out, h.p, tol);
  return out;
}

}  // namespace machplan
