// The invasion checks of Franco Garcia and Horikawa ("Manual and servo assisted, hybrid system
// for position control in machine tools", section 5.2), kept as baselines beside
// ProhibitedRegion::query(). Each is built from a region's boundary and answers, for a
// tool-centre point, whether it is in the prohibited region and how far it is from the
// boundary as that method measures it. They are polygonal, as in the paper: arcs of the
// boundary are replaced by chords (sagitta at most the region's paper_chord_tolerance_mm), so
// near arcs they may disagree with the exact region by up to that much.
//
//   PointMatrixCheck   "simple approach": the boundary is sampled every `spacing_mm` (the
//                      matrix P_rp, vertices included) and the distance to every sample is
//                      computed (the paper's Eq. 1, |d(Pf, P(j))| <= T). Side: the nearest
//                      sample's normal (the bisector at a vertex). Only right when the point is
//                      further from the boundary than about the spacing. O(samples) per query.
//   AngleSumCheck      "angles sum criterion": the angles each boundary edge subtends at the
//                      point sum to 2 pi times the winding number (the paper's beta + Phi +
//                      delta < 360 degrees: outside, generalised from a triangle to a polygon);
//                      the distance is the least point-to-segment distance. O(n) per query,
//                      one atan2 per edge.
//   IntervalDistanceCheck  "x intervals + point-to-segment distance" (the paper's chosen
//                      method, Eq. 2): edges are sorted by the start of their x interval;
//                      a query considers only the edges whose x interval holds the point
//                      (found by binary search on the sorted starts, then a scan of the edges
//                      starting left of it) and measures the point-to-segment distance to each.
//                      Side: the signed crossings of the upward ray from the point with those
//                      same edges (they are exactly the edges the ray can meet). Distance: the
//                      least over those edges only (edges beside the point's x interval are not
//                      seen, as in the paper). O(n) per query in the worst case, about the edges
//                      left of the point on average.
//
// All three: build allocates; queries allocate nothing and never throw. Thread-safe queries.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "engine/geometry/region.h"

namespace machplan {

struct InvasionAnswer {
  bool prohibited = false;
  double distance_mm = 0.0;  // unsigned, as the method measures it
};

// Shared by the three checks: the region's boundary as polygon edges.
class PolygonBoundary {
 public:
  PolygonBoundary() = default;
  explicit PolygonBoundary(const ProhibitedRegion& region);
  struct Edge {
    Eigen::Vector2d a, b;
  };
  const std::vector<Edge>& edges() const { return edges_; }
  // The boundary keeps the positive region (material for outside, pocket for inside) on its
  // left; prohibited(w) maps a winding number to the answer.
  bool prohibited_for_winding(int w) const { return prohibited_left_ ? w > 0 : w <= 0; }
  bool prohibited_left() const { return prohibited_left_; }
  // Edge indices of each closed polygon: polygons()[k] = {first, count}.
  const std::vector<std::pair<std::size_t, std::size_t>>& polygons() const { return polygons_; }

 private:
  std::vector<Edge> edges_;
  std::vector<std::pair<std::size_t, std::size_t>> polygons_;
  bool prohibited_left_ = true;
};

class PointMatrixCheck {
 public:
  // spacing_mm > 0 (InputError otherwise): the separation E of the paper's generated points.
  PointMatrixCheck(const ProhibitedRegion& region, double spacing_mm);
  InvasionAnswer check(const Eigen::Vector2d& p) const noexcept;
  std::size_t samples() const { return points_.size(); }

 private:
  std::vector<Eigen::Vector2d> points_, left_normals_;
  bool prohibited_left_ = true;
};

class AngleSumCheck {
 public:
  explicit AngleSumCheck(const ProhibitedRegion& region);
  InvasionAnswer check(const Eigen::Vector2d& p) const noexcept;

 private:
  PolygonBoundary poly_;
};

class IntervalDistanceCheck {
 public:
  explicit IntervalDistanceCheck(const ProhibitedRegion& region);
  InvasionAnswer check(const Eigen::Vector2d& p) const noexcept;

 private:
  PolygonBoundary poly_;
  // Edges sorted by xmin; xmin and xmax of each in that order.
  std::vector<std::size_t> order_;
  std::vector<double> xmin_, xmax_;
};

}  // namespace machplan
