#include "solvers/nesting/internal/shape.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "engine/geometry/offset.h"
#include "solvers/nesting/outline.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

namespace {

// A little more than half the spacing: the certificate counts parts closer than a micrometre
// past the spacing as too close, and so must the searches.
constexpr double kExtraMm = 1e-5;

// From p to the nearest edge of the shape's rings.
double distance_to_boundary(const Eigen::Vector2d& p, const std::vector<std::vector<Eigen::Vector2d>>& rings) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& r : rings)
    for (std::size_t i = 0; i < r.size(); ++i) best = std::min(best, point_segment_distance(p, r[i], r[(i + 1) % r.size()]));
  return best;
}

// The poles of a polygon: see the file comment of internal/shape.h. Found on a grid of about kGrid x
// kGrid points over its box; at most Poles::kLanes.
Poles poles_of(const Shape& s) {
  const Box& box = s.box;
  constexpr int kGrid = 48;
  const double w = box.max_corner().x() - box.min_corner().x(), h = box.max_corner().y() - box.min_corner().y();
  const double step = std::max(w, h) / kGrid;
  std::vector<Eigen::Vector2d> pts;
  std::vector<double> room;
  for (double y = box.min_corner().y() + step / 2; y < box.max_corner().y(); y += step)
    for (double x = box.min_corner().x() + step / 2; x < box.max_corner().x(); x += step) {
      if (!bg::within(Pt(x, y), s.poly)) continue;
      pts.emplace_back(x, y);
      room.push_back(distance_to_boundary(pts.back(), s.rings));
    }
  std::vector<Eigen::Vector2d> centres;
  std::vector<double> radii;
  while (centres.size() < Poles::kLanes && !pts.empty()) {
    const std::size_t best = static_cast<std::size_t>(std::max_element(room.begin(), room.end()) - room.begin());
    const double r = room[best];
    if (r <= 0 || (!radii.empty() && (r < 0.1 * radii.front() || r < step / 2))) break;
    centres.push_back(pts[best]);
    radii.push_back(r);
    for (std::size_t i = 0; i < pts.size(); ++i) room[i] = std::min(room[i], (pts[i] - pts[best]).norm() - r);
  }
  if (centres.empty()) {  // thinner than the grid: one small pole at the box's centre
    centres.emplace_back(box.min_corner().x() + w / 2, box.min_corner().y() + h / 2);
    radii.push_back(1e-3);
  }
  Poles p;
  p.count = centres.size();
  p.x.assign(Poles::kLanes, 1e6f), p.y.assign(Poles::kLanes, 1e6f), p.radius.assign(Poles::kLanes, 0.0f);
  for (std::size_t i = 0; i < centres.size(); ++i)
    p.x[i] = static_cast<float>(centres[i].x()), p.y[i] = static_cast<float>(centres[i].y()), p.radius[i] = static_cast<float>(radii[i]);
  return p;
}

// The poles turned counter-clockwise by `deg` about the reference point.
Poles turned_poles(Poles poles, double deg) {
  const Eigen::Rotation2Dd turn(deg * std::numbers::pi / 180.0);
  for (std::size_t i = 0; i < poles.size(); ++i) {
    const Eigen::Vector2d c = turn * Eigen::Vector2d(poles.x[i], poles.y[i]);
    poles.x[i] = static_cast<float>(c.x()), poles.y[i] = static_cast<float>(c.y());
  }
  return poles;
}

using Edge = std::pair<Eigen::Vector2d, Eigen::Vector2d>;

// Whether two segments meet, touching included. The boxes' test settles the collinear case
// (where every orientation is 0).
bool segments_meet(const Edge& p, const Edge& q) {
  if (std::max(p.first.x(), p.second.x()) < std::min(q.first.x(), q.second.x()) ||
      std::max(q.first.x(), q.second.x()) < std::min(p.first.x(), p.second.x()) ||
      std::max(p.first.y(), p.second.y()) < std::min(q.first.y(), q.second.y()) ||
      std::max(q.first.y(), q.second.y()) < std::min(p.first.y(), p.second.y()))
    return false;
  const Eigen::Vector2d dq = q.second - q.first, dp = p.second - p.first;
  const double d1 = cross(dq, p.first - q.first), d2 = cross(dq, p.second - q.first);
  const double d3 = cross(dp, q.first - p.first), d4 = cross(dp, q.second - p.first);
  return d1 * d2 <= 0 && d3 * d4 <= 0;
}

// The edges of `rings` moved by `o` whose boxes meet `box` (where any crossing must lie).
void edges_in(const std::vector<std::vector<Eigen::Vector2d>>& rings, const Eigen::Vector2d& o, const Eigen::AlignedBox2d& box,
              std::vector<Edge>& out) {
  out.clear();
  for (const auto& r : rings)
    for (std::size_t i = 0; i < r.size(); ++i) {
      const Eigen::Vector2d a = r[i] + o, b = r[(i + 1) % r.size()] + o;
      if (std::max(a.x(), b.x()) < box.min().x() || std::min(a.x(), b.x()) > box.max().x() ||
          std::max(a.y(), b.y()) < box.min().y() || std::min(a.y(), b.y()) > box.max().y())
        continue;
      out.emplace_back(a, b);
    }
}

bool inside_ring(const std::vector<Eigen::Vector2d>& r, const Eigen::Vector2d& p) {
  bool in = false;
  for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++)
    if ((r[i].y() > p.y()) != (r[j].y() > p.y()) &&
        p.x() < (r[j].x() - r[i].x()) * (p.y() - r[i].y()) / (r[j].y() - r[i].y()) + r[i].x())
      in = !in;
  return in;
}

bool in_material(const std::vector<std::vector<Eigen::Vector2d>>& rings, const Eigen::Vector2d& p) {
  if (!inside_ring(rings[0], p)) return false;
  for (std::size_t k = 1; k < rings.size(); ++k)
    if (inside_ring(rings[k], p)) return false;
  return true;
}

// The convex hull of points, counter-clockwise (not closed).
std::vector<Eigen::Vector2d> hull_of(const std::vector<Eigen::Vector2d>& pts) {
  bg::model::multi_point<Pt> mp;
  for (const Eigen::Vector2d& v : pts) mp.push_back(Pt(v.x(), v.y()));
  Poly hull;
  bg::convex_hull(mp, hull);
  std::vector<Eigen::Vector2d> out;
  const auto& r = hull.outer();
  for (std::size_t i = 0; i + 1 < r.size(); ++i) out.emplace_back(r[i].x(), r[i].y());
  std::reverse(out.begin(), out.end());  // Boost's rings run clockwise
  return out;
}

double normalised(double deg) {
  deg = std::fmod(deg, 360.0);
  return deg < 0 ? deg + 360.0 : deg;
}

}  // namespace

std::int64_t& meets_steps() {
  thread_local std::int64_t steps = 0;
  return steps;
}

bool meets(const Shape& a, const Eigen::Vector2d& at_a, const Shape& b, const Eigen::Vector2d& at_b) {
  const Eigen::Vector2d o = at_b - at_a;  // b in a's frame
  const Eigen::AlignedBox2d box_a(Eigen::Vector2d(a.box.min_corner().x(), a.box.min_corner().y()),
                                  Eigen::Vector2d(a.box.max_corner().x(), a.box.max_corner().y()));
  const Eigen::AlignedBox2d box_b(Eigen::Vector2d(b.box.min_corner().x(), b.box.min_corner().y()) + o,
                                  Eigen::Vector2d(b.box.max_corner().x(), b.box.max_corner().y()) + o);
  const Eigen::AlignedBox2d both = box_a.intersection(box_b);
  if (both.isEmpty()) return false;
  thread_local std::vector<Edge> ea, eb;
  std::int64_t& steps = meets_steps();
  steps += a.vertices + b.vertices;
  edges_in(a.rings, Eigen::Vector2d::Zero(), both, ea);
  edges_in(b.rings, o, both, eb);
  for (const Edge& e : ea) {
    steps += static_cast<std::int64_t>(eb.size());
    for (const Edge& f : eb)
      if (segments_meet(e, f)) return true;
  }
  steps += 2 * (a.vertices + b.vertices);
  // No edges meet: one lies in the other's material, or they are apart. Tested at a point deep
  // in each one's material (its largest pole's centre, when that is more than the polygons'
  // tolerance from its edge, turned or not) and at a vertex: a vertex alone may sit
  // on the other's boundary, where edges that lie on one line escape the segment test.
  const auto deep = [](const Shape& s) {
    return s.poles.count > 0 && s.poles.radius[0] >= 0.5f ? Eigen::Vector2d(s.poles.x[0], s.poles.y[0]) : s.rings[0][0];
  };
  return in_material(b.rings, deep(a) - o) || in_material(a.rings, deep(b) + o) || in_material(b.rings, a.rings[0][0] - o) ||
         in_material(a.rings, b.rings[0][0] + o);
}

std::vector<Shape> sheet_obstacles(const Sheet& sheet, double spacing, double tol) {
  if (!sheet.remnant) return {};
  const double grow = 2 * std::max(0.0, sheet.margin_mm - spacing / 2);  // make_shape grows by half its spacing
  const double b = sheet.margin_mm + spacing + 10.0;
  NestPart frame;
  frame.outer = Contour({{-b, -b}, {sheet.width_mm + b, -b}, {sheet.width_mm + b, sheet.height_mm + b}, {-b, sheet.height_mm + b}},
                        {0, 0, 0, 0});
  frame.holes.push_back(sheet.remnant->outer.reversed());
  std::vector<Shape> out{make_shape(frame, 0, false, grow, tol)};
  for (const Contour& cut : sheet.remnant->holes) {
    NestPart c;
    c.outer = cut.reversed();
    out.push_back(make_shape(c, 0, false, grow, tol));
  }
  for (Shape& s : out) s.poles = poles_of(s);
  return out;
}

Shape make_shape(const NestPart& part, double deg, bool mirrored, double spacing, double tol) {
  Placement turn;
  turn.rotation_deg = deg;
  turn.mirrored = mirrored;
  const Contour outer = place(part.outer, turn);
  const Contour grown = grown_outline(outer, spacing / 2 + kExtraMm);
  Shape s;
  s.rotation_deg = deg;
  s.mirrored = mirrored;
  for (const Eigen::Vector2d& v : outside_polygon(grown, tol)) s.poly.outer().push_back(Pt(v.x(), v.y()));
  // Each hole shrunk by as much (where the grown neighbours may lie), kept clockwise: the
  // polygon's hole inside it. A hole too small for that is left out: filled.
  for (const Contour& hole : part.holes) {
    const OffsetResult room = offset_contour(place(hole, turn), -(spacing / 2 + kExtraMm));
    for (const Contour& r : room.contours) {
      Poly::ring_type ring;
      for (const Eigen::Vector2d& v : outside_polygon(r, tol)) ring.push_back(Pt(v.x(), v.y()));
      s.poly.inners().push_back(std::move(ring));
    }
  }
  bg::correct(s.poly);
  s.box = bg::return_envelope<Box>(s.poly);
  s.part_box = bounding_box(outer);
  s.part_hull = hull_of(outside_polygon(outer, tol));
  s.area_mm2 = bg::area(s.poly);
  const auto ring_of = [](const Poly::ring_type& r) {
    std::vector<Eigen::Vector2d> v;
    for (std::size_t i = 0; i + 1 < r.size(); ++i) v.emplace_back(r[i].x(), r[i].y());
    return v;
  };
  s.rings.push_back(ring_of(s.poly.outer()));
  for (const auto& h : s.poly.inners()) s.rings.push_back(ring_of(h));
  for (const auto& r : s.rings) s.vertices += static_cast<std::int64_t>(r.size());
  Poly hull;
  bg::convex_hull(s.poly, hull);
  s.hull_area_mm2 = bg::area(hull);
  s.diameter_mm = bg::distance(s.box.min_corner(), s.box.max_corner());
  return s;
}

std::vector<Shape> make_shapes(const NestPart& part, const std::vector<double>& rotations, bool mirror, double spacing,
                               double tol) {
  std::vector<Shape> out;
  for (const bool mirrored : {false, true}) {
    if (mirrored && !mirror) continue;
    // The poles of the first rotation, turned for the others: a pole may then stand out of a
    // turned polygon by the tolerance, which only makes the search count a collision that is
    // not there (its exact test decides the other way).
    Poles poles;
    for (std::size_t k = 0; k < rotations.size(); ++k) {
      Shape s = make_shape(part, rotations[k], mirrored, spacing, tol);
      if (k == 0) poles = poles_of(s);
      s.poles = turned_poles(poles, rotations[k] - rotations[0]);
      out.push_back(std::move(s));
    }
  }
  return out;
}

Shape turned_shape(const Shape& base, double deg) {
  const Eigen::Rotation2Dd turn((deg - base.rotation_deg) * std::numbers::pi / 180.0);
  Shape s;
  s.rotation_deg = normalised(deg);
  s.mirrored = base.mirrored;
  s.rings = base.rings;
  Eigen::AlignedBox2d box;
  for (auto& r : s.rings)
    for (Eigen::Vector2d& v : r) box.extend(v = turn * v);
  s.box = Box(Pt(box.min().x(), box.min().y()), Pt(box.max().x(), box.max().y()));
  s.part_hull = base.part_hull;
  for (Eigen::Vector2d& v : s.part_hull) s.part_box.extend(v = turn * v);
  s.poles = turned_poles(base.poles, deg - base.rotation_deg);
  s.vertices = base.vertices;
  s.area_mm2 = base.area_mm2;
  s.hull_area_mm2 = base.hull_area_mm2;
  s.diameter_mm = box.diagonal().norm();
  return s;
}

std::vector<double> squaring_rotations(const NestPart& part, double tol) {
  const std::vector<Eigen::Vector2d> hull = hull_of(outside_polygon(part.outer, tol));
  double least = std::numeric_limits<double>::infinity(), best = 0.0;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d e = hull[(i + 1) % hull.size()] - hull[i];
    if (e.norm() < 1e-9) continue;
    const Eigen::Rotation2Dd turn(-std::atan2(e.y(), e.x()));
    Eigen::AlignedBox2d box;
    for (const Eigen::Vector2d& v : hull) box.extend(turn * v);
    if (box.volume() < least * (1 - 1e-9)) least = box.volume(), best = -std::atan2(e.y(), e.x()) * 180.0 / std::numbers::pi;
  }
  std::vector<double> out;
  for (int k = 0; k < 4; ++k) out.push_back(normalised(best + 90.0 * k));
  return out;
}

Box moved(const Box& b, double x, double y) {
  return Box(Pt(b.min_corner().x() + x, b.min_corner().y() + y), Pt(b.max_corner().x() + x, b.max_corner().y() + y));
}

}  // namespace machplan::nesting
