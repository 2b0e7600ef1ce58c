// A bounding-volume hierarchy over the spans (lines and arcs) of closed contours: nearest
// span, side of the contours, winding number and box queries, for the offset (to prune and
// chain its pieces in O(n log n)) and for the prohibited region's real-time queries.
//
// Why a BVH and not a uniform grid: profiles mix long and very short spans (a 100 mm edge
// beside 0.05 mm spline-fit arcs) and many profiles leave most of their bounding box empty
// (a thin ring, a sheet of parts). A grid must pick one cell size for all of it: cells sized
// for the short spans are mostly empty and a far query walks many of them; cells sized for the
// long spans put thousands of short spans in one cell. A median-split BVH adapts to the spans'
// sizes and positions, its depth is ceil(log2(n / 4)) whatever the data, so a query can use a
// fixed stack, and its memory is O(n).
//
// Layout: spans are copied into a flat array in tree order, each with what a query needs
// precomputed (unit vectors of an arc's ends, tangents, neighbours), plus a 64-byte copy of
// what a distance needs; nodes (72 bytes: an oriented rectangle and two links) are in
// depth-first order (left child follows its parent), their axis-aligned boxes apart. Leaves
// hold up to 4 spans.
//
// Queries allocate nothing and never throw. nearest() is branch and bound: O(log n) nodes for
// points whose distance to the boundary is small compared with the boundary's curvature (the
// guard's case); a point equidistant from many spans (the centre of a circle drawn as a
// polygon) visits all of them. Build: O(n log n), not real time.
//
// Thread safety: a built index is immutable; queries may run concurrently.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/geometry/contour.h"

namespace machplan {

class SpanIndex {
 public:
  // One indexed span. For an arc, `u_from` and `u_to` are the unit vectors from the centre to
  // the ends of its angular range taken counter-clockwise (start, end for a ccw arc; end,
  // start for a cw one) and `big` says the range exceeds pi.
  struct Item {
    Eigen::Vector2d a{0, 0}, b{0, 0};              // start and end, as in the contour
    Eigen::Vector2d center{0, 0};                  // arc only
    Eigen::Vector2d u_from{0, 0}, u_to{0, 0};      // arc only, see above
    Eigen::Vector2d t_start{0, 0}, t_end{0, 0};    // unit tangents (direction of travel) at a and b
    Eigen::Vector2d arc_mid{0, 0};                 // arc only: the arc's middle point
    double radius = 0.0;             // 0 for a line
    double sweep = 0.0;              // signed, 0 for a line
    bool big = false;
    std::uint32_t contour = 0, span = 0;  // where it came from
    std::uint32_t prev = 0, next = 0;     // items before / after it in its contour
    bool is_arc() const { return radius > 0.0; }
  };

  struct Nearest {
    double distance = std::numeric_limits<double>::infinity();  // mm
    Eigen::Vector2d point{0, 0};
    std::uint32_t item = 0;  // index into items()
    // The nearest point is the span's start / end vertex (not an interior point).
    bool at_start = false, at_end = false;
  };

  SpanIndex() = default;
  // Indexes every span of every contour (spans of zero length are kept: a query never
  // divides by them). Contours must not be empty. O(n log n).
  explicit SpanIndex(const std::vector<Contour>& contours);

  bool empty() const { return items_.empty(); }
  std::size_t size() const { return items_.size(); }
  const Item& item(std::size_t i) const { return items_[i]; }
  Eigen::AlignedBox2d bounds() const;

  // The nearest point of any span. Empty index: distance +infinity.
  Nearest nearest(const Eigen::Vector2d& p) const noexcept;

  // True when p is on the left of the contours, judged at the nearest point `n` (from
  // nearest(p)): the left of that span, or at a vertex the left of the corner formed by the
  // two spans that meet there. Exact when the contours neither cross nor touch and p is not
  // on them.
  bool left_of(const Eigen::Vector2d& p, const Nearest& n) const noexcept;

  // Sum of the winding numbers of all contours about p, by counting signed crossings of the
  // ray from p towards +x (an arc counts as its chord plus one turn when p lies between chord
  // and arc). Points on a span give an unspecified finite answer. Work: the nodes whose box
  // meets the ray.
  int winding(const Eigen::Vector2d& p) const noexcept;

  // The winding number of each contour about p, as (contour, winding) pairs sorted by contour,
  // those with winding 0 left out (out is cleared first). Same rules and work as winding();
  // it allocates only when `out` must grow. For "which of these contours hold p".
  void windings(const Eigen::Vector2d& p, std::vector<std::pair<std::uint32_t, int>>& out) const;

  // Calls f(i) for every item whose bounding box meets `box`.
  template <class F>
  void for_each_in_box(const Eigen::AlignedBox2d& box, F&& f) const {
    if (nodes_.empty()) return;
    std::array<std::uint32_t, kMaxDepth> stack;
    std::size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const std::uint32_t idx = stack[--top];
      const Node& nd = nodes_[idx];
      const Box& nb = node_boxes_[idx];
      if (nb.lo.x() > box.max().x() || nb.lo.y() > box.max().y() || nb.hi.x() < box.min().x() ||
          nb.hi.y() < box.min().y())
        continue;
      if (nd.count > 0) {
        for (std::uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
          const auto& bb = item_boxes_[i];
          if (bb.min().x() <= box.max().x() && bb.min().y() <= box.max().y() && bb.max().x() >= box.min().x() &&
              bb.max().y() >= box.min().y())
            f(static_cast<std::size_t>(i));
        }
      } else {
        stack[top++] = nd.first;  // right child
        stack[top++] = idx + 1;
      }
    }
  }

  // Closest point of one item to p, with the end flags (a helper for the queries above).
  Nearest closest_on(std::uint32_t i, const Eigen::Vector2d& p) const noexcept;

  // The axis-aligned box of item i.
  const Eigen::AlignedBox2d& item_box(std::size_t i) const { return item_boxes_[i]; }

 private:
  static constexpr std::size_t kLeafSize = 4;
  static constexpr std::size_t kMaxDepth = 96;  // stack bound; the tree is far shallower
  // Each node bounds its spans twice: an axis-aligned box (for rays and boxes) and a
  // rectangle oriented along the spans' principal direction (for nearest(): a run of short
  // spans along a smooth curve fits in a rectangle as thin as the curve's sagitta over the
  // run, where an axis-aligned box is as wide as the run itself when the curve runs
  // diagonally; the thin bound prunes everything but the spans next to the nearest point).
  struct Node {
    Eigen::Vector2d origin, axis;  // oriented rectangle: origin + t axis + s perp(axis),
    double t0, t1, s0, s1;         //   t in [t0, t1], s in [s0, s1]; perp(u) = (-u.y, u.x)
    std::uint32_t first = 0;       // leaf: first item; inner: index of the right child
    std::uint32_t count = 0;       // leaf: number of items (> 0); inner: 0
  };
  struct Box {
    Eigen::Vector2d lo, hi;  // the node's axis-aligned box (kept apart: nearest() never reads it)
  };
  // What nearest() reads of a span, in one cache line. Line: p0 = start, p1 = end - start,
  // r = 1 / |p1|^2 (0 for a zero-length line), kind 0. Arc: p0 = centre, p1 and p2 = u_from
  // and u_to, r = radius, kind 1 (range <= pi) or 2 (range > pi).
  struct Hot {
    Eigen::Vector2d p0, p1, p2;
    double r = 0.0;
    double kind = 0.0;
  };
  std::uint32_t build_node(const std::vector<Item>& items, std::vector<std::uint32_t>& order,
                           std::vector<Eigen::Vector2d>& centres, std::size_t lo, std::size_t hi,
                           std::size_t depth);
  // Squared distance from p to the node's oriented rectangle (0 inside).
  static double rect_distance2(const Node& nd, const Eigen::Vector2d& p) noexcept {
    const Eigen::Vector2d v = p - nd.origin;
    const double t = v.dot(nd.axis), s = nd.axis.x() * v.y() - nd.axis.y() * v.x();
    const double dt = t < nd.t0 ? nd.t0 - t : (t > nd.t1 ? t - nd.t1 : 0.0);
    const double ds = s < nd.s0 ? nd.s0 - s : (s > nd.s1 ? s - nd.s1 : 0.0);
    return dt * dt + ds * ds;
  }
  // Calls f(i) for every item whose box meets the ray from p towards +x.
  template <class F>
  void for_each_on_ray(const Eigen::Vector2d& p, F&& f) const {
    const Eigen::AlignedBox2d ray(p, Eigen::Vector2d(std::numeric_limits<double>::infinity(), p.y()));
    for_each_in_box(ray, [&](std::size_t i) { f(static_cast<std::uint32_t>(i)); });
  }
  // Signed crossing of item i with the ray from p towards +x (0 when its box misses the ray).
  int crossing(std::uint32_t i, const Eigen::Vector2d& p) const noexcept;
  // Squared distance from p to item i (no flags; nearest() keeps the best index only).
  double distance2_to(std::uint32_t i, const Eigen::Vector2d& p) const noexcept;

  std::vector<Item> items_;
  std::vector<Eigen::AlignedBox2d> item_boxes_;
  std::vector<Node> nodes_;
  std::vector<Box> node_boxes_;  // parallel to nodes_
  std::vector<Hot> hot_;         // parallel to items_
};

}  // namespace machplan
