// The tool-radius offset of Franco Garcia and Horikawa ("Manual and servo assisted, hybrid
// system for position control in machine tools"), kept as the baseline beside the exact
// offset of offset.h. What is implemented, step by step:
//
//   0. Polygon. The paper treats polygonal profiles only. Arcs are replaced by chords whose
//      sagitta is at most `chord_tolerance_mm` (the chords lie on the concave side of the arc,
//      so a grown region loses up to that much at a convex arc). Spans shorter than the
//      tolerance are dropped.
//
//   1. "Very close" points. At each vertex B between A and C the direction turns by
//      phi = arccos(V_AB . V_BC / (|V_AB| |V_BC|)) (0 straight on, pi a hairpin), and the two
//      offset lines meet d = R tan(phi/2) from B along each segment (the paper's Eq. 3-4). If
//      d > |V_AB| then B is removed, and if d > |V_BC| then C is removed: literally the paper's
//      rule, applied at convex and concave corners alike, and repeated (each removal makes new
//      neighbours, which are examined again) until no vertex is removed. A contour left with
//      fewer than 3 vertices vanishes.
//
//   2. Shift. Each remaining segment is moved by R along its normal to the offset side (the
//      paper decides the side per vertex, "B above or below AC", Eq. 5; for a contour of known
//      orientation that is the same as the right-hand normal below), and consecutive shifted
//      segments meet at the intersection of their lines (the paper's B' of Eq. 11 and 13, a
//      mitre: B + d-step along AB from the shifted A'):
//          B' = B + R (n1 + n2) / (1 + n1 . n2),  n1, n2 the unit normals of AB and BC.
//      Convex corners therefore get a sharp mitre (further than R from B: over-protective)
//      instead of an arc; where step 1 dropped a vertex the shifted line cuts across the
//      corner, closer than R to the dropped vertex (under-protective: the paper's method can
//      let the tool into the part there).
//
// The result is one closed polygon that may cross itself where the profile has features
// narrower than 2R; loops are NOT removed here (the paper has no such step): the caller
// decides what the crossings mean (the prohibited region merges them by winding number).
#pragma once

#include <cstddef>
#include <vector>

#include "engine/geometry/contour.h"

namespace machplan {

struct PaperOffsetResult {
  // The shifted polygon (bulges all 0); empty when fewer than 3 vertices survive step 1.
  std::vector<Eigen::Vector2d> vertices;
  // Original span whose start produced each vertex (for messages).
  std::vector<std::size_t> source_spans;
  struct Dropped {
    std::size_t span = 0;          // original span starting at the dropped vertex
    Eigen::Vector2d at{0, 0};      // the dropped vertex, mm
    double setback_mm = 0.0;       // R tan(phi/2) at the corner that dropped it
    double segment_mm = 0.0;       // the neighbouring segment it exceeded
  };
  std::vector<Dropped> dropped;
  bool vanished() const { return vertices.size() < 3; }
};

// Offsets `contour` by `distance_mm` to the RIGHT of its direction of travel (a
// counter-clockwise contour grows for distance_mm > 0; a negative distance moves to the left).
// Preconditions: finite distance, chord_tolerance_mm > 0, tolerance_mm > 0 (not checked).
// O(n) for n polygon vertices.
PaperOffsetResult paper_offset(const Contour& contour, double distance_mm, double chord_tolerance_mm,
                               double tolerance_mm);

// The polygon that stands in for `contour` in step 0 (arcs as chords, sagitta at most
// chord_tolerance_mm), with the original span of each vertex. Also used by the paper's
// invasion checks, which are polygonal too.
std::vector<Eigen::Vector2d> polygonise(const Contour& contour, double chord_tolerance_mm,
                                        std::vector<std::size_t>* source_spans = nullptr);

}  // namespace machplan
