// The prohibited region of hybrid manual / servo-assisted machining: the set of tool-centre
// points where a tool of radius R would cut into the part, built from the part's closed
// contours and queried in the servo loop.
//
// What the region is. The profile is a set of closed, non-crossing contours; nesting decides
// what is material: a contour inside an even number of others bounds material ("positive"),
// one inside an odd number is a hole. For external machining (side = outside) the tool stays
// outside the part, so the prohibited region is the part grown by R; for internal machining
// (side = inside) the tool stays inside a pocket: the outermost contours bound the pockets,
// contours inside them are islands, and the prohibited region is everything except the
// pockets shrunk by R (islands grown by R).
//
// How it is built.
//   1. Each contour is checked (closed by construction; encloses area; does not cross itself;
//      does not cross or touch another contour) and oriented so that the region the tool must
//      keep to ("positive": the material for outside, the pocket for inside) is on its left.
//   2. Each contour is offset by R to its right, away from the positive region when it bounds
//      it, into it when it is a hole, with one of two methods:
//        robust: offset_contour() of engine/geometry/offset.h: exact offsets, lines stay lines,
//                arcs stay arcs, rounded convex corners, trimmed concave ones, loops removed,
//                narrow features reported;
//        paper:  the method of Franco Garcia and Horikawa ("Manual and servo assisted, hybrid
//                system for position control in machine tools"), see paper_offset.h: vertices
//                whose corner setback R tan(phi/2) exceeds a neighbouring segment are dropped,
//                then every segment is shifted by R and neighbours meet at their mitre point.
//                The paper treats polygons only; arcs are first replaced by chords.
//   3. The offset contours are merged into one clean boundary: all of them are split where
//      they cross each other or themselves, and a piece is kept when the positive region (by
//      winding number > 0 over all offset contours) lies on its left and not on its right. So
//      two parts closer than 2R merge, an island closer than 2R to a pocket wall closes that
//      passage, and the loops of the paper's mitre offset are removed. Where contours merge
//      the region reports it (a gap narrower than the tool) in problems().
//
// What a query answers. query(p) gives the signed distance from a tool-centre point p to the
// boundary (negative inside the prohibited region), the nearest boundary point, the unit
// normal there pointing into the allowed side, and the boundary span. It runs over a
// bounding-volume hierarchy of the boundary spans (span_index.h): O(log n) for points near
// the boundary; it allocates nothing and never throws. The sign comes from the side of the
// nearest span (a vertex: from both spans that meet there), which is exact because the
// boundary is clean (step 3). Measured (bench/results/guard_geometry.txt, one core): about
// 65 ns at 10 spans, 105 ns at 1 000 and 200 ns at 100 000 for a guard's stream of nearby
// points; points jumping at random over a 100 000-span profile miss the caches and take
// about 1-3.5 us. Building the region of a 100 000-span profile takes about 0.5 s.
//
// Errors. Bad input throws InputError naming the contour ("contour 2" or the caller's name for
// it, see build()): an empty profile, a contour that encloses no area, crosses itself, or
// crosses / touches another contour. A tool too big for a corner, an arc or a slot does not
// throw: the feature is lost from the boundary and problems() says where. When nothing is left
// of the allowed region (internal machining with a pocket narrower than 2R everywhere) build()
// throws InputError.
//
// Thread safety: a built region is immutable; query() may run concurrently from any thread.
//
// Example:
//
//     // A 100 x 50 plate machined from outside with a 5 mm tool.
//     Contour plate({{0, 0}, {100, 0}, {100, 50}, {0, 50}}, {0, 0, 0, 0});
//     auto region = ProhibitedRegion::build({plate}, {.side = MachiningSide::outside, .tool_radius_mm = 5});
//     region.query({110, 25}).signed_distance_mm;  // 5: allowed, 5 mm from the limit x = 105
//     region.prohibited({103, 25});                 // true
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/names.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/offset.h"
#include "engine/geometry/span_index.h"

namespace machplan {

// outside: external machining, keep the tool outside the part;
// inside: internal machining, keep the tool inside a pocket.
enum class MachiningSide { outside, inside };
const char* to_string(MachiningSide s);
// "outside" | "inside"; anything else throws InputError::field("side", ...).
Parsed<MachiningSide> parse_machining_side(std::string_view text);

// paper: drop "very close" points, shift each segment by R (paper_offset.h);
// robust: offset_contour() of engine/geometry/offset.h.
enum class OffsetMethod { paper, robust };
const char* to_string(OffsetMethod m);
// "paper" | "robust"; anything else throws InputError::field("method", ...).
Parsed<OffsetMethod> parse_offset_method(std::string_view text);

struct RegionOptions {
  MachiningSide side = MachiningSide::outside;
  // Tool radius R, mm: the boundary lies R from the profile. >= 0, finite, <= 1e6 mm.
  double tool_radius_mm = 0.0;
  OffsetMethod method = OffsetMethod::robust;
  // Geometric tolerance, mm (as OffsetOptions::tolerance_mm): finite, > 0, <= 0.1.
  double tolerance_mm = 1e-6;
  // paper method only: arcs become chords whose sagitta (largest gap to the arc) is at most
  // this, mm. The chords lie inside the arc, so the region can shrink by up to this much at
  // arcs. Finite, > 0, <= 10.
  double paper_chord_tolerance_mm = 0.01;

  // Throws InputError naming the field, its value and the rule it broke.
  void validate() const;
};

// Where a tool-centre point stands relative to the prohibited region.
struct RegionDistance {
  double signed_distance_mm = 0.0;    // > 0: allowed, this far from the region's boundary;
                                      // < 0: inside the prohibited region by |d|
  Eigen::Vector2d nearest_mm{0, 0};   // nearest point of the boundary
  Eigen::Vector2d normal{0, 0};       // unit, at nearest_mm, pointing from the prohibited side into the allowed side
  std::size_t contour = 0, span = 0;  // the nearest feature (boundary contour, span in it)
};

// A problem found while building: a feature the tool cannot reproduce. `contour` is the
// profile contour concerned (for a gap between two contours: the first of them); see
// OffsetProblem for the other fields.
class ProhibitedRegion {
 public:
  ProhibitedRegion() = default;

  // `profile`: the part's closed contours (outer boundary and holes as the DXF reader gives
  // them, any orientation). `contour_names` (optional, same size as `profile` when given)
  // names each contour in messages, for example "contour 2 (entities 1F, 20)"; by default
  // "contour K". Throws InputError for an empty profile, or a contour that encloses no area,
  // crosses itself or meets another contour, naming it; tool too big for a corner, an arc or
  // a slot -> problems() (warnings), or InputError when nothing is left of the allowed region.
  static ProhibitedRegion build(const std::vector<Contour>& profile, const RegionOptions& options,
                                const std::vector<std::string>& contour_names = {});

  // The tool-centre limit: closed, non-crossing contours with the prohibited region on their
  // LEFT for side = outside and on their right for side = inside (so the allowed region is on
  // the left for inside: the pocket is traversed counter-clockwise). Spans shorter than the
  // tolerance are dropped.
  const std::vector<Contour>& boundary() const { return boundary_; }
  // Warnings from the offset (narrow slot, collapsed arc, dropped vertex...), OffsetProblem
  // with `contour` naming the profile contour; `message` names it too.
  const std::vector<OffsetProblem>& problems() const { return problems_; }
  const RegionOptions& options() const { return options_; }

  // Real time: O(log n) for points near the boundary, allocates nothing, never throws.
  // On the boundary itself the distance is 0 (allowed). An empty region (never the case for a
  // built one) answers +infinity.
  RegionDistance query(const Eigen::Vector2d& p_mm) const noexcept;
  // query(p).signed_distance_mm < 0.
  bool prohibited(const Eigen::Vector2d& p_mm) const noexcept;

  // The index over the boundary spans (for the invasion-check comparisons and benches).
  const SpanIndex& index() const { return index_; }

 private:
  RegionOptions options_;
  std::vector<Contour> boundary_;
  std::vector<OffsetProblem> problems_;
  SpanIndex index_;
};

}  // namespace machplan
