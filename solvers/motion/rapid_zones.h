// The clearance geometry of rapid planning: the no-go zones of a job (declared zones and the
// closed cuts that become zones once cut) as filled regions, with the exact point and segment
// tests the rapid planner needs (solvers/motion/rapid_planner.h), on one SpanIndex
// (engine/geometry/span_index.h) over all their spans.
//
// A zone is the region a closed Contour encloses (non-zero winding). The distance of a point
// or a straight segment to a zone is 0 when it is inside or meets the boundary, else its
// exact distance to the boundary (segment_distance_mm in rapid_planner.h: never too small,
// never too large). Every query looks only at the spans whose boxes meet the query's box
// grown by the distance that matters (the clearance, or the caller's cap), and at the spans
// the ray from the point towards +x meets for the inside test: work O(log n + k) for k spans
// nearby, where a scan of every zone was O(n).
//
// Zones are switched on and off without rebuilding the index: a job's zones are indexed once,
// a cut part is switched on once it is cut, and a rapid may relax a few zones for itself
// (`skip`). A switched-off or skipped zone takes part in no query.
//
// Thread safety: queries are const and may run concurrently; set_active() may not run beside
// them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/geometry/contour.h"
#include "engine/geometry/span_index.h"

namespace machplan::motion {

// Exact distance between the straight segment a -> b and a span (line or arc), mm: 0 when
// they meet. Computed from the candidates where the minimum can lie (end points, the foot of
// the arc centre on the line, the line's crossings of the circle), each an actual distance
// between two points of the curves, so the value is never too small and, by the argument in
// rapid_zones.cpp, never too large.
double segment_distance_mm(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Segment& span);

// Distance from the segment a -> b to the region of a zone (0 when it enters or touches it).
double region_distance_mm(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Contour& zone);

// Smallest region distance of a polyline to any zone, mm (+infinity with no zones; for a
// single point, the point's distance).
double polyline_clearance_mm(const std::vector<Eigen::Vector2d>& polyline, const std::vector<Contour>& zones);

class ZoneSet {
 public:
  // Indexes `zones` (empty contours are allowed: they hold nothing and are never near). All
  // zones start active. clearance_mm > 0.
  ZoneSet(std::vector<Contour> zones, double clearance_mm);

  std::size_t size() const { return zones_.size(); }
  double clearance() const { return clearance_; }
  const Contour& contour(std::size_t j) const { return zones_[j]; }
  const std::vector<Segment>& spans(std::size_t j) const { return spans_[j]; }
  const Eigen::AlignedBox2d& box(std::size_t j) const { return boxes_[j]; }

  void set_active(std::size_t j, bool on) { active_[j] = on ? 1 : 0; }
  bool active(std::size_t j) const { return active_[j] != 0; }

  // A per-zone mask: skip[j] true leaves zone j out of a query. Empty: none is skipped.
  using Skip = std::vector<char>;

  // Distance from p to the region of zone j (0 inside), whether active or not.
  double point_distance(const Eigen::Vector2d& p, std::size_t j) const;
  // Distance from the segment a -> b to the region of zone j, exact up to `cap`: any value
  // >= cap may be reported as cap.
  double segment_distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, std::size_t j,
                          double cap = std::numeric_limits<double>::infinity()) const;

  // The active zones (not skipped) whose region holds p (winding number non-zero), and the
  // active zones within `radius` of p (region distance < radius), ascending.
  std::vector<std::size_t> holding(const Eigen::Vector2d& p, const Skip& skip = {}) const;
  std::vector<std::size_t> near(const Eigen::Vector2d& p, double radius, const Skip& skip = {}) const;

  // Clear: at least the clearance from every active zone not skipped.
  bool point_clear(const Eigen::Vector2d& p, const Skip& skip = {}) const;
  bool segment_clear(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Skip& skip = {}) const;
  bool polyline_clear(const std::vector<Eigen::Vector2d>& p, const Skip& skip = {}) const;
  // Smallest region distance of a polyline to the active zones (+infinity with none; a single
  // point: its distance).
  double polyline_distance(const std::vector<Eigen::Vector2d>& p, const Skip& skip = {}) const;

  // Whether the polyline goes inside zone j deeper than depth_mm somewhere (not merely
  // touching its boundary or running along it): the polyline is cut where it meets the
  // boundary and the middle of each piece is tested.
  bool enters(const std::vector<Eigen::Vector2d>& p, std::size_t j, double depth_mm) const;

 private:
  bool considered(std::size_t j, const Skip& skip) const {
    return active_[j] && (skip.empty() || !skip[j]);
  }
  // Calls f(zone, span) for the spans whose boxes meet `box`.
  template <class F>
  void for_each_span(const Eigen::AlignedBox2d& box, F&& f) const {
    index_.for_each_in_box(box, [&](std::size_t i) {
      const SpanIndex::Item& it = index_.item(i);
      f(static_cast<std::size_t>(zone_of_[it.contour]), static_cast<std::size_t>(it.span));
    });
  }
  // Smallest segment-to-span distance over the considered zones' spans within `cap`.
  double nearest_span(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double cap, const Skip& skip) const;

  std::vector<Contour> zones_;
  std::vector<std::vector<Segment>> spans_;
  std::vector<Eigen::AlignedBox2d> boxes_;
  std::vector<char> active_;
  std::vector<std::uint32_t> zone_of_;  // index contour -> zone (empty zones are not indexed)
  SpanIndex index_;
  double clearance_;
};

}  // namespace machplan::motion
