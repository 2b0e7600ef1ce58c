// True offsets of closed line/arc contours: the geometry behind kerf compensation and the
// hybrid-machining guard.
//
// The offset of a closed contour C by a distance d is the boundary of the region grown
// (d > 0) or shrunk (d < 0) by |d|: every point of it lies at distance exactly |d| from C,
// on the outside of C when growing and on the inside when shrinking. The sign refers to the
// enclosed region, never to the direction of travel, so a clockwise and a counter-clockwise
// copy of one contour give the same offset (each returned in its input's orientation).
// Lines stay lines and arcs stay arcs: the result is exact, nothing is polygonised.
//
// Algorithm (the "raw offset, then prune" method of CAD kernels):
//
//   1. Orientation. The contour is walked counter-clockwise (a clockwise input is reversed
//      first and the results reversed back), so the enclosed region is on the left and the
//      outward normal n of each span is its tangent turned by -90 degrees. Spans shorter
//      than the tolerance are dropped.
//
//   2. Span offsets. A line moves by d n. An arc keeps its centre and sweep and changes its
//      radius to r' = r + d for a counter-clockwise arc (centre inside) or r - d for a
//      clockwise one (centre outside). When r' <= tolerance the arc collapses: it cannot be
//      offset, it is reported (arc_collapsed) and what stands in for it in the raw offset is
//      its mirror image through the centre (radius |r'|), a piece that always lies closer
//      than |d| to the arc and is removed in step 5.
//
//   3. Corners. At each vertex V the tangent turns by an angle theta in (-pi, pi]. Where
//      d * theta > 0 the offset spans leave a gap (a convex corner when growing, a concave
//      one when shrinking); it is closed by an arc about V of radius |d| and sweep theta, so
//      the offset stays tangent continuous. Otherwise the two offset spans overlap and are
//      trimmed at their intersection nearest to the corner. When they do not meet (one of
//      them is too short, or was itself trimmed away) the corner is closed by the backwards
//      arc about V instead and the resulting loop is left to step 5.
//
//   4. The raw offset, the closed chain of trimmed spans and corner arcs, can cross itself
//      wherever the contour has features narrower than 2|d|. It is split at every
//      self-intersection.
//
//   5. Pruning. A piece of the raw offset is kept when points on it (at 1/4, 1/2, 3/4 of its
//      length) are at distance >= |d| - tolerance from C and on the correct side of it.
//      Every raw point lies within |d| of C, so the kept pieces lie at distance |d| exactly.
//
//   6. The kept pieces are chained end to start into closed contours; pieces of one span cut
//      apart at a crossing that turned out not to matter are merged again, and slivers
//      enclosing no area are dropped.
//
// What the caller gets. Shrinking can split a contour into several or make it vanish;
// growing can close the mouth of a narrow inlet and leave the inlet's inside as a separate
// hole. All surviving contours are returned: those that bound the region keep the input's
// orientation, the holes that growing can create have the opposite one. Problems name the
// original span: an arc that collapsed; a run of spans none of whose offset survives (a slot,
// neck or inlet narrower than 2|d|, or a detail at a concave corner smaller than |d|): the
// feature is too small to be reproduced; a contour that vanished altogether.
//
// Cost: O(n log n + k) for n spans and k crossings of the raw offset: crossings come from a
// sweep over the pieces' bounding boxes, distances and sides from a bounding-volume hierarchy
// over the contour (span_index.h), and chaining looks pieces up by their start point. (It
// was all-pairs, O(n^2), before.) Pure, thread-safe.
//
// Example:
//
//     // A 20 x 10 rectangle grown by 1 mm: 4 lines and 4 quarter circles of radius 1.
//     Contour rect({{0, 0}, {20, 0}, {20, 10}, {0, 10}}, {0, 0, 0, 0});
//     OffsetResult r = offset_contour(rect, 1.0);
//     r.contours.size();            // 1
//     signed_area(r.contours[0]);   // 200 + 60 * 1 + pi * 1^2
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "engine/geometry/contour.h"

namespace machplan {

struct OffsetOptions {
  // Geometric tolerance, mm. Points closer than this are the same point; spans shorter than
  // this are dropped from the input; an arc whose offset radius would be below it collapses;
  // a raw piece is kept when its distance from the contour is at least |d| minus this. The
  // default suits drawings exact to a micrometre; raise it for coarse data. Must be finite,
  // > 0 and <= 0.1 mm.
  double tolerance_mm = 1e-6;

  // Throws InputError naming the field, its value and the rule it broke.
  void validate() const;
};

struct OffsetProblem {
  enum class Kind {
    arc_collapsed,      // the arc's offset radius would be <= 0: the arc is lost
    feature_too_small,  // no part of these spans' offset survives (narrower than 2|d|)
    contour_vanished,   // nothing survives: the contour is narrower than 2|d| everywhere
    vertex_dropped,     // the paper's offset (paper_offset.h) dropped a vertex: the setback
                        // R tan(phi/2) exceeded a neighbouring segment
    gap_too_narrow,     // two contours (or two parts of one) closer than 2|d|: their offsets
                        // cross and merge (merge_positive), the tool cannot pass between them
  };
  static constexpr std::size_t kNoSpan = std::numeric_limits<std::size_t>::max();

  Kind kind = Kind::feature_too_small;
  // Index of the first original span concerned and the number of consecutive spans
  // concerned (counting on cyclically). contour_vanished: span = kNoSpan, span_count = 0.
  std::size_t span = kNoSpan;
  std::size_t span_count = 0;
  std::string message;  // one line, for people
  // Index of the contour concerned when several are offset together (prohibited region);
  // 0 for offset_contour.
  std::size_t contour = 0;
};
const char* to_string(OffsetProblem::Kind k);

struct OffsetResult {
  std::vector<Contour> contours;
  // source_spans[k][j]: the original span whose offset produced span j of contours[k]; for
  // a corner arc, one of the two spans meeting at that corner (the one ending there for a
  // counter-clockwise input, the one starting there for a clockwise input).
  std::vector<std::vector<std::size_t>> source_spans;
  std::vector<OffsetProblem> problems;

  bool vanished() const { return contours.empty(); }
};

// Offsets `contour` by `distance_mm` (> 0 grows the enclosed region, < 0 shrinks it, 0
// returns the contour unchanged). See the file comment.
//
// Throws InputError when the distance is not finite or beyond kMaxCoordinateMm, when the
// contour encloses no area (|signed area| <= tolerance * perimeter), or when it crosses
// itself (the offset of a self-intersecting contour is not defined); when the offset region
// pinches to zero width exactly at the offset distance and its pieces do not close (found by
// tests/fuzz/offset_fuzz.cpp); and when the options are invalid.
OffsetResult offset_contour(const Contour& contour, double distance_mm, const OffsetOptions& options = {});

// The boundary of the region where the summed winding number of `contours` is positive.
//
// The contours may cross themselves and each other (offsets of neighbouring contours that
// came closer than twice the offset distance, a mitre offset with loops). They are split at
// every crossing; a piece is kept when the summed winding number is positive just on its left
// and not positive just on its right; kept pieces are chained into closed contours. So with
// every input contour oriented with its region on the left (outer boundaries
// counter-clockwise, holes clockwise), the result bounds the union of the regions, minus the
// holes, with loops of negative or zero winding removed; contours that cross nothing are kept
// unchanged or dropped whole. Lines stay lines and arcs stay arcs.
//
// Cost: O(n log n + k log n) for n spans and k crossings (a sweep over the span boxes finds the
// crossings, a span index answers the winding numbers). Throws InputError when the kept
// pieces do not close (regions that touch at a single point along a shared curve, within the
// tolerance), naming the place; and when the options are invalid.
struct MergeResult {
  std::vector<Contour> contours;
  struct Crossing {
    std::size_t contour_a = 0, contour_b = 0;  // input contours, a <= b (a == b: crosses itself)
    Eigen::Vector2d at{0, 0};                  // the first crossing found between them
  };
  std::vector<Crossing> crossings;  // one per pair of input contours that cross
};
MergeResult merge_positive(const std::vector<Contour>& contours, const OffsetOptions& options = {});

}  // namespace machplan
