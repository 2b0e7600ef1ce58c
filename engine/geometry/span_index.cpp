#include "engine/geometry/span_index.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "engine/common/error.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

// True when direction v (from the centre) lies in the arc's counter-clockwise range
// u_from -> u_to, without trigonometry.
inline bool in_range(const SpanIndex::Item& it, const Vector2d& v) {
  const double c1 = cross(it.u_from, v), c2 = cross(v, it.u_to);
  if (!it.big) return c1 >= 0.0 && c2 >= 0.0;
  return c1 >= 0.0 || c2 >= 0.0;
}

// Signed crossing of the ray from p towards +x with the straight piece a -> b (half-open in y
// so that a ray through a shared vertex counts once).
inline int ray_crossing(const Vector2d& a, const Vector2d& b, const Vector2d& p) {
  if (a.y() <= p.y()) {
    if (b.y() > p.y() && cross(b - a, p - a) > 0.0) return 1;  // upward, p on its left
  } else if (b.y() <= p.y() && cross(b - a, p - a) < 0.0) {
    return -1;  // downward, p on its right
  }
  return 0;
}

}  // namespace

SpanIndex::SpanIndex(const std::vector<Contour>& contours) {
  std::vector<Item> tmp;
  std::size_t total = 0;
  for (const auto& c : contours) total += c.size();
  MACHPLAN_ASSERT(total < std::numeric_limits<std::uint32_t>::max() / 2, "{} spans are too many to index", total);
  tmp.reserve(total);
  std::vector<Eigen::AlignedBox2d> boxes;
  boxes.reserve(total);
  for (std::size_t k = 0; k < contours.size(); ++k) {
    const Contour& c = contours[k];
    MACHPLAN_ASSERT(!c.empty(), "contour {} is empty", k);
    const std::size_t base = tmp.size(), n = c.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Segment s = c.span(i);
      Item it;
      it.a = s.start;
      it.b = s.end;
      if (s.is_arc()) {
        it.center = s.center;
        it.radius = s.radius;
        it.sweep = s.sweep;
        const Vector2d us = (s.start - s.center) / s.radius, ue = (s.end - s.center) / s.radius;
        it.u_from = s.sweep > 0 ? us : ue;
        it.u_to = s.sweep > 0 ? ue : us;
        it.big = std::abs(s.sweep) > std::numbers::pi;
        it.arc_mid = point_at(s, 0.5);
      }
      const bool zero = length(s) == 0.0;
      it.t_start = zero ? Vector2d(1, 0) : start_tangent(s);
      it.t_end = zero ? Vector2d(1, 0) : end_tangent(s);
      it.contour = static_cast<std::uint32_t>(k);
      it.span = static_cast<std::uint32_t>(i);
      it.prev = static_cast<std::uint32_t>(base + (i + n - 1) % n);
      it.next = static_cast<std::uint32_t>(base + (i + 1) % n);
      tmp.push_back(it);
      boxes.push_back(bounding_box(s));
    }
  }
  if (tmp.empty()) return;
  std::vector<std::uint32_t> order(tmp.size());
  std::iota(order.begin(), order.end(), 0u);
  std::vector<Vector2d> centres(tmp.size());
  for (std::size_t i = 0; i < tmp.size(); ++i) centres[i] = boxes[i].center();
  item_boxes_ = std::move(boxes);  // indexed by original position during the build
  nodes_.reserve(2 * (tmp.size() / kLeafSize + 1));
  node_boxes_.reserve(nodes_.capacity());
  build_node(tmp, order, centres, 0, order.size(), 0);
  // Put items and their boxes in tree order; remap the neighbour links.
  std::vector<std::uint32_t> where(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) where[order[k]] = static_cast<std::uint32_t>(k);
  items_.resize(tmp.size());
  std::vector<Eigen::AlignedBox2d> sorted_boxes(tmp.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    Item it = tmp[order[k]];
    it.prev = where[it.prev];
    it.next = where[it.next];
    items_[k] = it;
    sorted_boxes[k] = item_boxes_[order[k]];
  }
  item_boxes_ = std::move(sorted_boxes);
  hot_.resize(items_.size());
  for (std::size_t k = 0; k < items_.size(); ++k) {
    const Item& it = items_[k];
    Hot& h = hot_[k];
    if (!it.is_arc()) {
      h.p0 = it.a;
      h.p1 = it.b - it.a;
      const double l2 = h.p1.squaredNorm();
      h.r = l2 > 0.0 ? 1.0 / l2 : 0.0;
      h.kind = 0.0;
    } else {
      h.p0 = it.center;
      h.p1 = it.u_from;
      h.p2 = it.u_to;
      h.r = it.radius;
      h.kind = it.big ? 2.0 : 1.0;
    }
  }
}

std::uint32_t SpanIndex::build_node(const std::vector<Item>& items, std::vector<std::uint32_t>& order,
                                    std::vector<Vector2d>& centres, std::size_t lo, std::size_t hi,
                                    std::size_t depth) {
  MACHPLAN_ASSERT(depth + 2 < kMaxDepth, "span index deeper than {}", kMaxDepth);
  const auto self = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox2d box, cbox;
  Vector2d mean = Vector2d::Zero();
  for (std::size_t k = lo; k < hi; ++k) {
    box.extend(item_boxes_[order[k]]);
    cbox.extend(centres[order[k]]);
    mean += items[order[k]].a + items[order[k]].b;
  }
  mean /= 2.0 * static_cast<double>(hi - lo);
  // Principal direction of the span ends.
  double sxx = 0, sxy = 0, syy = 0;
  for (std::size_t k = lo; k < hi; ++k)
    for (const Vector2d& q : {items[order[k]].a, items[order[k]].b}) {
      const Vector2d d = q - mean;
      sxx += d.x() * d.x();
      sxy += d.x() * d.y();
      syy += d.y() * d.y();
    }
  const double angle = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
  Node& nd = nodes_[self];
  node_boxes_.push_back({box.min(), box.max()});
  nd.origin = mean;
  nd.axis = Vector2d(std::cos(angle), std::sin(angle));
  nd.t0 = nd.s0 = std::numeric_limits<double>::infinity();
  nd.t1 = nd.s1 = -std::numeric_limits<double>::infinity();
  auto cover = [&](const Vector2d& q) {
    const Vector2d v = q - nd.origin;
    const double t = v.dot(nd.axis), s = nd.axis.x() * v.y() - nd.axis.y() * v.x();
    nd.t0 = std::min(nd.t0, t);
    nd.t1 = std::max(nd.t1, t);
    nd.s0 = std::min(nd.s0, s);
    nd.s1 = std::max(nd.s1, s);
  };
  for (std::size_t k = lo; k < hi; ++k) {
    const Item& it = items[order[k]];
    if (!it.is_arc()) {  // a line lies in the hull of its ends
      cover(it.a);
      cover(it.b);
    } else {  // an arc in its box (conservative)
      const auto& b = item_boxes_[order[k]];
      for (int c = 0; c < 4; ++c) cover(b.corner(static_cast<Eigen::AlignedBox2d::CornerType>(c)));
    }
  }
  // Rounding: widen by a few ulps of the coordinates so that no span pokes out.
  const double pad = 4 * std::numeric_limits<double>::epsilon() * (1.0 + box.max().cwiseAbs().maxCoeff() +
                                                                   box.min().cwiseAbs().maxCoeff());
  nd.t0 -= pad, nd.s0 -= pad, nd.t1 += pad, nd.s1 += pad;
  if (hi - lo <= kLeafSize) {
    nd.first = static_cast<std::uint32_t>(lo);
    nd.count = static_cast<std::uint32_t>(hi - lo);
    return self;
  }
  const int axis = cbox.sizes().x() >= cbox.sizes().y() ? 0 : 1;
  const std::size_t mid = lo + (hi - lo) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(lo), order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(hi), [&](std::uint32_t a, std::uint32_t b) {
                     const double ca = centres[a][axis], cb = centres[b][axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  build_node(items, order, centres, lo, mid, depth + 1);  // left child: self + 1
  const std::uint32_t right = build_node(items, order, centres, mid, hi, depth + 1);
  nodes_[self].first = right;  // (nodes_ may have grown: no reference held across the calls)
  nodes_[self].count = 0;
  return self;
}

double SpanIndex::distance2_to(std::uint32_t i, const Vector2d& p) const noexcept {
  const Hot& h = hot_[i];
  if (h.kind == 0.0) {
    const double t = std::clamp((p - h.p0).dot(h.p1) * h.r, 0.0, 1.0);
    return (h.p0 + t * h.p1 - p).squaredNorm();
  }
  const Vector2d v = p - h.p0;
  const double c1 = cross(h.p1, v), c2 = cross(v, h.p2);
  if (h.kind == 1.0 ? (c1 >= 0.0 && c2 >= 0.0) : (c1 >= 0.0 || c2 >= 0.0)) {
    const double r = v.norm() - h.r;
    return r * r;
  }
  return std::min((v - h.r * h.p1).squaredNorm(), (v - h.r * h.p2).squaredNorm());
}

Eigen::AlignedBox2d SpanIndex::bounds() const {
  if (nodes_.empty()) return {};
  return {node_boxes_[0].lo, node_boxes_[0].hi};
}

SpanIndex::Nearest SpanIndex::closest_on(std::uint32_t i, const Vector2d& p) const noexcept {
  const Item& it = items_[i];
  Nearest r;
  r.item = i;
  if (!it.is_arc()) {
    const Vector2d d = it.b - it.a;
    const double l2 = d.squaredNorm();
    const double t = l2 > 0.0 ? (p - it.a).dot(d) / l2 : 0.0;
    if (t <= 0.0) {
      r.point = it.a;
      r.at_start = true;
    } else if (t >= 1.0) {
      r.point = it.b;
      r.at_end = true;
    } else {
      r.point = it.a + t * d;
    }
  } else {
    const Vector2d v = p - it.center;
    const double vn = v.norm();
    if (vn > 0.0 && in_range(it, v)) {
      r.point = it.center + (it.radius / vn) * v;
    } else if ((p - it.a).squaredNorm() <= (p - it.b).squaredNorm()) {
      r.point = it.a;
      r.at_start = true;
    } else {
      r.point = it.b;
      r.at_end = true;
    }
  }
  r.distance = (p - r.point).norm();
  return r;
}

SpanIndex::Nearest SpanIndex::nearest(const Vector2d& p) const noexcept {
  Nearest best;
  if (nodes_.empty()) return best;
  double best2 = std::numeric_limits<double>::infinity();
  std::uint32_t best_item = 0;
  // Pending nodes with their squared lower bounds; the nearer child is visited first.
  std::array<std::uint32_t, kMaxDepth> stack;
  std::array<double, kMaxDepth> bound;
  std::size_t top = 0;
  stack[top] = 0;
  bound[top++] = rect_distance2(nodes_[0], p);
  while (top > 0) {
    --top;
    if (bound[top] >= best2) continue;
    const Node& nd = nodes_[stack[top]];
    if (nd.count > 0) {
      for (std::uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
        const double d2 = distance2_to(i, p);
        if (d2 < best2) {
          best2 = d2;
          best_item = i;
        }
      }
      continue;
    }
    const std::uint32_t l = static_cast<std::uint32_t>(&nd - nodes_.data()) + 1, r = nd.first;
    const double dl = rect_distance2(nodes_[l], p), dr = rect_distance2(nodes_[r], p);
    // Push the farther child first so that the nearer one is popped next.
    if (dl <= dr) {
      if (dr < best2) stack[top] = r, bound[top++] = dr;
      if (dl < best2) stack[top] = l, bound[top++] = dl;
    } else {
      if (dl < best2) stack[top] = l, bound[top++] = dl;
      if (dr < best2) stack[top] = r, bound[top++] = dr;
    }
  }
  return closest_on(best_item, p);
}

bool SpanIndex::left_of(const Vector2d& p, const Nearest& n) const noexcept {
  const Item& it = items_[n.item];
  if (!n.at_start && !n.at_end) {
    Vector2d t;
    if (it.is_arc()) {
      const Vector2d r = n.point - it.center;
      t = it.sweep > 0 ? Vector2d(-r.y(), r.x()) : Vector2d(r.y(), -r.x());
    } else {
      t = it.b - it.a;
    }
    return cross(t, p - n.point) > 0.0;
  }
  // At a vertex V: the left side is the angular sector swept counter-clockwise from the
  // outgoing span's direction to the incoming span's (both seen from V). p's nearest point is
  // V, so p lies in V's normal cone and the tangents decide, except at a cusp (tangents
  // exactly opposite, two arcs meeting in a point): there the curvatures decide, so each
  // direction is that of a chord a tiny way along its span: the tangent turned by half the
  // angle the span turns over that length (1e-6 of the smaller radius).
  const Item& in = n.at_start ? items_[it.prev] : it;
  const Item& out = n.at_start ? it : items_[it.next];
  const Vector2d v = n.at_start ? it.a : it.b;
  const Vector2d w = p - v;
  double r_min = std::numeric_limits<double>::infinity();
  if (in.is_arc()) r_min = std::min(r_min, in.radius);
  if (out.is_arc()) r_min = std::min(r_min, out.radius);
  const double eta = std::isfinite(r_min) ? 1e-6 * r_min : 0.0;
  auto turned = [](const Vector2d& t, double angle) {
    const double c = std::cos(angle), sn = std::sin(angle);
    return Vector2d(c * t.x() - sn * t.y(), sn * t.x() + c * t.y());
  };
  // Signed turn per unit length is sweep / (radius |sweep|) = +-1 / radius.
  const double k_out = out.is_arc() ? (out.sweep > 0 ? 1.0 : -1.0) / out.radius : 0.0;
  const double k_in = in.is_arc() ? (in.sweep > 0 ? 1.0 : -1.0) / in.radius : 0.0;
  const Vector2d d_out = turned(out.t_start, 0.5 * eta * k_out);
  const Vector2d d_in = turned(Vector2d(-in.t_end), -0.5 * eta * k_in);
  const double a0 = std::atan2(d_out.y(), d_out.x());
  const double sector = wrap_angle_positive(std::atan2(d_in.y(), d_in.x()) - a0);
  const double rel = wrap_angle_positive(std::atan2(w.y(), w.x()) - a0);
  return rel > 0.0 && rel < sector;
}

int SpanIndex::crossing(std::uint32_t i, const Vector2d& p) const noexcept {
  const auto& bb = item_boxes_[i];
  if (bb.max().x() < p.x() || bb.min().y() > p.y() || bb.max().y() < p.y()) return 0;
  const Item& it = items_[i];
  if (!it.is_arc()) return ray_crossing(it.a, it.b, p);
  // An arc is its chord plus the closed loop (arc, chord back), which winds once round the
  // points between chord and arc; the chord crossing and the segment test must judge p on
  // the same side of the chord.
  const Vector2d chord = it.b - it.a;
  const double m = cross(chord, it.arc_mid - it.a);
  double side = cross(chord, p - it.a);
  // p on the chord's line: the half-open rule above counts an end at p's height as below
  // the ray, as if p sat a little higher; take the side of the chord that p + (0, e)
  // would be on (for a chord that is not horizontal, any side gives the same count).
  if (side == 0.0) side = chord.x() != 0.0 ? chord.x() : -chord.y();
  int w = 0;
  if (it.a.y() <= p.y()) {
    if (it.b.y() > p.y() && side > 0.0) ++w;
  } else if (it.b.y() <= p.y() && side < 0.0) {
    --w;
  }
  if (side * m > 0.0 && (p - it.center).squaredNorm() < it.radius * it.radius) w += it.sweep > 0 ? 1 : -1;
  return w;
}

int SpanIndex::winding(const Vector2d& p) const noexcept {
  int w = 0;
  for_each_on_ray(p, [&](std::uint32_t i) { w += crossing(i, p); });
  return w;
}

void SpanIndex::windings(const Vector2d& p, std::vector<std::pair<std::uint32_t, int>>& out) const {
  out.clear();
  for_each_on_ray(p, [&](std::uint32_t i) {
    const int w = crossing(i, p);
    if (w == 0) return;
    const std::uint32_t c = items_[i].contour;
    const auto it = std::find_if(out.begin(), out.end(), [&](const auto& e) { return e.first == c; });
    if (it == out.end()) out.emplace_back(c, w);
    else it->second += w;
  });
  out.erase(std::remove_if(out.begin(), out.end(), [](const auto& e) { return e.second == 0; }), out.end());
  std::sort(out.begin(), out.end());
}

}  // namespace machplan
