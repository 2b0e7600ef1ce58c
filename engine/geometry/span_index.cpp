#include "engine/geometry/span_index.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "engine/common/error.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

// Squared distance from p to a box (0 inside).
inline double box_distance2(const Vector2d& lo, const Vector2d& hi, const Vector2d& p) {
  const double dx = p.x() < lo.x() ? lo.x() - p.x() : (p.x() > hi.x() ? p.x() - hi.x() : 0.0);
  const double dy = p.y() < lo.y() ? lo.y() - p.y() : (p.y() > hi.y() ? p.y() - hi.y() : 0.0);
  return dx * dx + dy * dy;
}

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
  build_node(order, centres, 0, order.size(), 0);
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
}

std::uint32_t SpanIndex::build_node(std::vector<std::uint32_t>& order, std::vector<Vector2d>& centres,
                                    std::size_t lo, std::size_t hi, std::size_t depth) {
  MACHPLAN_ASSERT(depth + 2 < kMaxDepth, "span index deeper than {}", kMaxDepth);
  const auto self = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox2d box, cbox;
  for (std::size_t k = lo; k < hi; ++k) {
    box.extend(item_boxes_[order[k]]);
    cbox.extend(centres[order[k]]);
  }
  nodes_[self].lo = box.min();
  nodes_[self].hi = box.max();
  if (hi - lo <= kLeafSize) {
    nodes_[self].first = static_cast<std::uint32_t>(lo);
    nodes_[self].count = static_cast<std::uint32_t>(hi - lo);
    return self;
  }
  const int axis = cbox.sizes().x() >= cbox.sizes().y() ? 0 : 1;
  const std::size_t mid = lo + (hi - lo) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(lo), order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(hi), [&](std::uint32_t a, std::uint32_t b) {
                     const double ca = centres[a][axis], cb = centres[b][axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  build_node(order, centres, lo, mid, depth + 1);  // left child: self + 1
  const std::uint32_t right = build_node(order, centres, mid, hi, depth + 1);
  nodes_[self].first = right;
  nodes_[self].count = 0;
  return self;
}

Eigen::AlignedBox2d SpanIndex::bounds() const {
  if (nodes_.empty()) return {};
  return {nodes_[0].lo, nodes_[0].hi};
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
  bound[top++] = box_distance2(nodes_[0].lo, nodes_[0].hi, p);
  while (top > 0) {
    --top;
    if (bound[top] >= best2) continue;
    const Node& nd = nodes_[stack[top]];
    if (nd.count > 0) {
      for (std::uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
        const auto& bb = item_boxes_[i];
        if (box_distance2(bb.min(), bb.max(), p) >= best2) continue;
        const Nearest c = closest_on(i, p);
        const double d2 = (p - c.point).squaredNorm();
        if (d2 < best2) {
          best2 = d2;
          best_item = i;
        }
      }
      continue;
    }
    const std::uint32_t l = static_cast<std::uint32_t>(&nd - nodes_.data()) + 1, r = nd.first;
    const double dl = box_distance2(nodes_[l].lo, nodes_[l].hi, p), dr = box_distance2(nodes_[r].lo, nodes_[r].hi, p);
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
  const Item& in = n.at_start ? items_[it.prev] : it;
  const Item& out = n.at_start ? it : items_[it.next];
  const Vector2d v = n.at_start ? it.a : it.b;
  const Vector2d w = p - v;
  const bool l_in = cross(in.t_end, w) > 0.0, l_out = cross(out.t_start, w) > 0.0;
  const double turn = cross(in.t_end, out.t_start);
  if (turn > 0.0) return l_in && l_out;  // convex corner (left turn): inside both half planes
  if (turn < 0.0) return l_in || l_out;  // reflex corner: inside either
  return l_in;                           // straight on: both agree
}

int SpanIndex::winding(const Vector2d& p) const noexcept {
  if (nodes_.empty()) return 0;
  int w = 0;
  std::array<std::uint32_t, kMaxDepth> stack;
  std::size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::uint32_t idx = stack[--top];
    const Node& nd = nodes_[idx];
    if (nd.hi.x() < p.x() || nd.lo.y() > p.y() || nd.hi.y() < p.y()) continue;
    if (nd.count == 0) {
      stack[top++] = nd.first;
      stack[top++] = idx + 1;
      continue;
    }
    for (std::uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
      const auto& bb = item_boxes_[i];
      if (bb.max().x() < p.x() || bb.min().y() > p.y() || bb.max().y() < p.y()) continue;
      const Item& it = items_[i];
      w += ray_crossing(it.a, it.b, p);
      if (it.is_arc() && (p - it.center).squaredNorm() < it.radius * it.radius) {
        // Between chord and arc: the arc passes round p once more than its chord.
        const Vector2d chord = it.b - it.a;
        if (cross(chord, p - it.a) * cross(chord, it.arc_mid - it.a) > 0.0) w += it.sweep > 0 ? 1 : -1;
      }
    }
  }
  return w;
}

}  // namespace machplan
