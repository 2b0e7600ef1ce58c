// Reading a cutting profile from a DXF drawing: closed contours in millimetres, nested into
// parts and holes, with every problem in the drawing reported by entity.
//
// What is read. Model-space entities of the ENTITIES section: LINE, ARC, CIRCLE, LWPOLYLINE,
// POLYLINE (2-D with VERTEX bulges and closed flag 1; 3-D, flag 8, when its vertices lie in
// one plane parallel to XY; spline-fit, flag 4, through its fitted vertices), SPLINE, ELLIPSE
// and INSERT. Reading stops at 0/EOF: bytes after it are ignored.
//   * SPLINE: a NURBS given by degree, knots, control points and (rational, flag 4) weights;
//     or, without control points, the C2 cubic through its fit points with chord-length
//     parameters and the end tangents of codes 12/13 when given. ELLIPSE: full or partial,
//     by its parameters 41/42. Both are replaced by biarcs (arcs and lines, tangent-continuous)
//     within half the chain tolerance (engine/geometry/curve_fit.h), so offsets stay exact.
//   * INSERT: the entities of the named block (from the BLOCKS section), placed at code 10/20
//     relative to the block's base point, scaled by 41/42 (negative = mirrored), rotated by
//     50 degrees, repeated in 70 columns and 71 rows spaced 44/45 in the rotated frame, in the
//     INSERT's own object coordinate system. Blocks may insert blocks (up to 32 deep; a block
//     that contains itself is an error). Entities on layer 0 inside a block take the INSERT's
//     layer. An entity seen through inserts is named "INSERT>...>HANDLE" ("INSERT[c,r]>..."
//     for an array copy). An arc under a non-uniform scale is an ellipse, and is fitted.
//   * Object coordinate systems: arcs, circles and polylines are read in the system of their
//     extrusion (210/220/230) and projected onto XY; (0, 0, -1), common in CAM exports,
//     mirrors them. A system tilted off the Z axis by more than `flatten_tolerance_deg` is a
//     not_planar error; within it the entity is projected onto XY with one "flattened"
//     warning for the drawing. Entities in world coordinates (LINE, SPLINE, 3-D POLYLINE)
//     must keep one z within the chain tolerance plus that slope over their extent.
//   * Units: $INSUNITS converts the drawing to mm. A drawing without it (or with 0, unitless)
//     is read with DxfOptions::assumed_mm_per_unit, or as mm when that is 0, and always with
//     a no_units warning. Header variables written after the header's ENDSEC (dxflib 2.0,
//     LibreCAD's writer, leaves some there) are read as the header's.
//   * Binary DXF (AutoCAD's "AutoCAD Binary DXF" files, 1- or 2-byte group codes) is read as
//     the same drawing in ASCII; its line numbers in messages are those of that ASCII form
//     (group code k, from 0, on line 2k + 1).
//
// How contours are formed. Closed entities (CIRCLE, closed polylines, a full-turn ARC or
// ELLIPSE, a polyline or spline whose ends meet) are contours by themselves. The open ones are
// chained (engine/geometry/chaining.h): starting from the first unused piece in file order, the chain's free end is joined
// to the nearest free end of another piece within `chain_tolerance_mm` (a piece is reversed
// when its end, not its start, is the nearer), and the chain closes when its own start is the
// nearest end within tolerance. Join gaps below the tolerance are closed by keeping the
// earlier piece's point. Free ends are kept in a grid of cells one tolerance wide, so
// chaining costs O(n) for n pieces; the checks between contours run only on pairs whose
// bounding boxes meet (sweep and prune), so a drawing of many separate parts costs
// O(n log n) and memory O(n).
//
// Healing. Drawings as exported are not always clean, and three kinds of fault are mended,
// each with a warning naming the entities:
//   * gaps: the chains still open are chained a second time in the same way with
//     `join_tolerance_mm`, so ends closer than it are joined (the earlier point kept, the
//     later end moved onto it); each join is a `joined` warning with both entities, the gap
//     (gap_mm) and the place. What still cannot close is an open_chain error, as before.
//   * overlapping collinear lines and concentric arcs (a LINE or ARC drawn over part of
//     another, or twice): a span lying within another is dropped, a line overlapping another
//     line's end is cut back to the part the other does not cover (`merged_overlap`), so the
//     shared piece is cut once.
//   * an outline drawn twice, the copy split differently (a polyline and the same shape as
//     separate lines): a closed contour every vertex and span middle of which lies within the
//     chain tolerance of an earlier one, and the other way round, is dropped (`duplicate`).
//
// What is reported. Each ProfileProblem names the entities by handle (group code 5 as written
// in the file, or "TYPE#n" for the n-th entity of a type when the file has no handles) and,
// where it has one, a location in mm:
//   severity error:   open_chain (at = one end; gap_mm = the distance between its two ends,
//                     how far it is from closing), self_intersection (at = the crossing),
//                     overlap (two contours cross or touch), zero_area (a closed contour that
//                     encloses nothing), unsupported_entity (3-D solids, meshes, external
//                     references, anything not listed above, named; their geometry is missing
//                     from the profile), missing_block (an INSERT of a block the file lacks),
//                     not_planar (an entity off the XY plane beyond the flatten tolerance),
//                     no_contours.
//   severity warning: duplicate (same geometry drawn twice, entity or closed contour; the later
//                     copy is dropped), joined (a gap closed by healing: gap_mm, at),
//                     merged_overlap (a span over part of another, cut back or dropped),
//                     zero_length (an entity or polyline span shorter than the tolerance;
//                     dropped), annotation_ignored (TEXT, MTEXT, DIMENSION, HATCH, POINT, SOLID,
//                     XLINE, ...), paper_space (an entity on a layout, not in model space;
//                     ignored, unless model space is empty: then the layout's entities are
//                     read, with one paper_space warning saying so), no_units, flattened
//                     (entities projected onto XY),
//                     approximation (a curve the fit could not bring within its tolerance).
// A profile with any error must not be cut; has_errors() says so.
//
// What throws. A file that is not a well-formed DXF throws InputError with
// "FILE:LINE: message": a group code that is not an integer (or, in binary DXF, not a DXF
// group code), a value missing at the end of the file, a number that does not parse or is not
// finite, a missing 0/EOF (truncation), a VERTEX outside a POLYLINE, an LWPOLYLINE whose vertex count disagrees with
// its code 90, a SPLINE whose counts (72-74) disagree with its lists or whose knots, degree
// or weights are invalid, a block that contains itself or nests deeper than 32, a drawing
// that holds more than DxfOptions::max_entities entities (INSERT copies counted) or whose
// curves need more than 250 000 arcs, an unknown $INSUNITS.
//
// Nesting (engine/geometry/nesting.h). For each contour the parent is the smallest contour (by
// |area|) that contains it; depth 0 are outer boundaries of parts, depth 1 their holes, depth 2
// parts inside holes, and so on. Contours keep the orientation they were drawn with. Two
// contours that cross or touch (an overlap error) hold neither the other.
//
// Thread safety: read_dxf_profile may be called from several threads at once.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "engine/geometry/contour.h"

namespace machplan {

struct DxfOptions {
  // Largest gap, mm, between two entity ends that still counts as joined; also the length
  // below which an entity counts as zero-length and the distance within which two entities
  // count as duplicates. Drawings exported by CAD are exact to 1e-6 mm or so; hand-made ones
  // often need 0.01-0.1 mm. Must be finite, > 0 and <= 10.
  double chain_tolerance_mm = 0.01;
  // Healing (see the file comment): chains still open after chaining are joined across gaps up
  // to this, mm, each join reported. 0.5 mm is a third of a plasma kerf and below what a
  // hand-drawn or re-exported outline is usually off by; gaps up to chain_tolerance_mm are
  // never reported. 0 turns healing off. Finite, in [0, 10].
  double join_tolerance_mm = 0.5;
  // Scale of a drawing that does not state its units ($INSUNITS missing or 0), mm per
  // drawing unit (25.4 for inches; see mm_per_drawing_unit()); 0 reads such drawings as mm.
  // Ignored when the drawing states its units. 0 or in (0, 1e4].
  double assumed_mm_per_unit = 0.0;
  // Largest tilt, degrees, of an entity's plane from XY that is still projected onto XY
  // (drawings exported from a slightly rotated 3-D view); beyond it the entity is a
  // not_planar error. 0 accepts only exactly planar entities. Within [0, 5].
  double flatten_tolerance_deg = 0.0;
  // Most entities a drawing may hold, INSERT copies counted (arrays and nested blocks
  // multiply). Reading takes about 1 s and 150 MB per 100 000 entities; a drawing beyond the
  // limit is refused (InputError naming it) instead of running for minutes. In 1 .. 1e7.
  std::size_t max_entities = 250'000;
  // Most arcs the drawing's curves (ellipses, splines, bulged polylines) may be fitted with,
  // all together. A curve far too detailed for the chain tolerance, or too large for the
  // tolerance to be met in double precision (a 1e9 mm ellipse at 0.01 mm), splits until it
  // reaches the limit: the read is refused then (InputError naming it), after about 1 s per
  // 250 000 arcs. In 1 .. 1e7.
  std::size_t max_fitted_spans = 250'000;

  // Throws InputError::field naming the field (the CLI renames it to its flag).
  void validate() const;
};

struct ProfileProblem {
  enum class Severity { warning, error };
  Severity severity = Severity::error;
  std::string kind;                  // see the file comment
  std::vector<std::string> handles;  // the entities involved
  std::string message;               // one line, for people
  std::optional<Eigen::Vector2d> at; // mm, where it applies
  std::optional<double> gap_mm;      // open_chain: distance between the chain's two ends
  // The DxfOptions field that settles the problem, when one does (no_units:
  // "assumed_mm_per_unit", not_planar: "flatten_tolerance_deg"), as InputError::with_option
  // names one: the library knows no flags, a command line renames it to the flag that sets it.
  std::string option;

  // The message, continued with " with OPTION" when an option settles it: "... give that
  // unit with assumed_mm_per_unit".
  std::string text() const;
};
const char* to_string(ProfileProblem::Severity s);

struct ProfileContour {
  Contour contour;                   // mm, as drawn (orientation kept)
  std::vector<std::string> handles;  // entities it is made of, in chain order
  std::string layer;                 // layer of its first entity
  int parent = -1;                   // index of the enclosing contour, -1 at top level
  std::vector<int> children;         // contours directly inside this one
  int depth = 0;                     // 0 outer boundary, 1 hole, 2 part in a hole, ...
  double area_mm2 = 0.0;             // signed_area(contour)
  double perimeter_mm = 0.0;
};

struct ProfileReadResult {
  std::string source;                   // file name, for messages
  double mm_per_unit = 1.0;             // the scale applied ($INSUNITS, else the assumed one)
  double chain_tolerance_mm = 0.0;      // the tolerances the drawing was read with
  double join_tolerance_mm = 0.0;
  bool has_insunits = false;            // the drawing states its units
  std::vector<ProfileContour> contours;
  std::vector<ProfileProblem> problems;

  bool has_errors() const;
  // Readable report: one block per contour, then the problems.
  std::string report() const;
};

// mm per unit for a unit name (mm, cm, dm, m, inch/in, foot/ft, yard/yd, mil, micron/um,
// microinch); 0 for a name it does not know.
double mm_per_drawing_unit(std::string_view name);

// Reads `path`. Throws InputError for unreadable or malformed files (see above); reports
// drawing problems in the result. Options are validated first.
ProfileReadResult read_dxf_profile(const std::string& path, const DxfOptions& options = {});

// The same on text already in memory; `source` names it in messages.
ProfileReadResult read_dxf_profile_text(std::string_view text, const std::string& source,
                                        const DxfOptions& options = {});

}  // namespace machplan
