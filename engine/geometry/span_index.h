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
// precomputed (unit vectors of an arc's ends, tangents, neighbours), nodes are 48 bytes in
// depth-first order (left child follows its parent). Leaves hold up to 4 spans.
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
    Eigen::Vector2d a, b;            // start and end, as in the contour
    Eigen::Vector2d center;          // arc only
    Eigen::Vector2d u_from, u_to;    // arc only, see above
    Eigen::Vector2d t_start, t_end;  // unit tangents (direction of travel) at a and b
    Eigen::Vector2d arc_mid;         // arc only: the arc's middle point
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

  // Calls f(i) for every item whose bounding box meets `box`.
  template <class F>
  void for_each_in_box(const Eigen::AlignedBox2d& box, F&& f) const {
    if (nodes_.empty()) return;
    std::array<std::uint32_t, kMaxDepth> stack;
    std::size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& nd = nodes_[stack[--top]];
      if (nd.lo.x() > box.max().x() || nd.lo.y() > box.max().y() || nd.hi.x() < box.min().x() ||
          nd.hi.y() < box.min().y())
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
        stack[top++] = static_cast<std::uint32_t>(&nd - nodes_.data()) + 1;
      }
    }
  }

  // Closest point of one item to p, with the end flags (a helper for the queries above).
  Nearest closest_on(std::uint32_t i, const Eigen::Vector2d& p) const noexcept;

 private:
  static constexpr std::size_t kLeafSize = 4;
  static constexpr std::size_t kMaxDepth = 96;  // stack bound; the tree is far shallower
  struct Node {
    Eigen::Vector2d lo, hi;
    std::uint32_t first = 0;  // leaf: first item; inner: index of the right child
    std::uint32_t count = 0;  // leaf: number of items (> 0); inner: 0
  };
  std::uint32_t build_node(std::vector<std::uint32_t>& order, std::vector<Eigen::Vector2d>& centres,
                           std::size_t lo, std::size_t hi, std::size_t depth);

  std::vector<Item> items_;
  std::vector<Eigen::AlignedBox2d> item_boxes_;
  std::vector<Node> nodes_;
};

}  // namespace machplan
