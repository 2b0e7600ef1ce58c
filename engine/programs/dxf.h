// Reading a cutting profile from a DXF drawing: closed contours in millimetres, nested into
// parts and holes, with every problem in the drawing reported by entity.
//
// What is read. Model-space entities of the ENTITIES section: LINE, ARC, CIRCLE, LWPOLYLINE
// and 2-D POLYLINE (VERTEX bulges, closed flag 1). Arcs and polylines are taken in their
// object coordinate system; the mirrored system of extrusion (0, 0, -1), common in CAM
// exports, is honoured. $INSUNITS converts the drawing to mm (0, unitless, is read as mm).
//
// How contours are formed. Closed entities (CIRCLE, closed polylines, a full-turn ARC) are
// contours by themselves. The open ones are chained: starting from the first unused entity in
// file order, the chain's free end is joined to the nearest free end of another entity within
// `chain_tolerance_mm` (an entity is reversed when its end, not its start, is the nearer), and
// the chain closes when its own start is the nearest end within tolerance. Join gaps below the
// tolerance are closed by keeping the earlier entity's point.
//
// What is reported. Each ProfileProblem names the entities by handle (group code 5 as written
// in the file, or "TYPE#n" for the n-th entity when the file has no handles) and, where it
// has one, a location in mm:
//   severity error:   open_chain (at = the gap), self_intersection (at = the crossing),
//                     overlap (two contours cross or touch), zero_area (a closed contour that
//                     encloses nothing), unsupported_entity (SPLINE, ELLIPSE, INSERT, 3-D
//                     entities, ... named; their geometry is missing from the profile),
//                     not_planar (an entity outside the XY plane), no_contours.
//   severity warning: duplicate (same geometry drawn twice; the later copy is dropped),
//                     zero_length (an entity or polyline span shorter than the tolerance;
//                     dropped), annotation_ignored (TEXT, MTEXT, DIMENSION, HATCH, POINT, ...),
//                     paper_space (an entity on a layout, not in model space; ignored).
// A profile with any error must not be cut; has_errors() says so.
//
// What throws. A file that is not a well-formed ASCII DXF throws InputError with
// "FILE:LINE: message": a group code that is not an integer, a value missing at the end of
// the file, a number that does not parse or is not finite, a missing 0/EOF (truncation), a
// binary DXF, a VERTEX outside a POLYLINE, an LWPOLYLINE whose vertex count disagrees with
// its code 90, an unknown $INSUNITS. The reader checks the whole group-code structure itself
// before dxflib sees anything, and hands dxflib only the validated, re-written pairs of the
// entities it reads: dxflib has no error reporting of its own and trusts counts and lengths
// in the file.
//
// Nesting. For each contour the parent is the smallest contour (by |area|) that contains it;
// depth 0 are outer boundaries of parts, depth 1 their holes, depth 2 parts inside holes, and
// so on. Contours keep the orientation they were drawn with.
//
// Thread safety: read_dxf_profile may be called from several threads at once only if the
// installed dxflib is reentrant; dxflib 3.x keeps a static line counter, so callers should
// serialise reads.
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

  // Throws InputError naming the field ("--tolerance" style names are up to the caller).
  void validate() const;
};

struct ProfileProblem {
  enum class Severity { warning, error };
  Severity severity = Severity::error;
  std::string kind;                  // see the file comment
  std::vector<std::string> handles;  // the entities involved
  std::string message;               // one line, for people
  std::optional<Eigen::Vector2d> at; // mm, where it applies
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
  double mm_per_unit = 1.0;             // the $INSUNITS scale applied
  std::vector<ProfileContour> contours;
  std::vector<ProfileProblem> problems;

  bool has_errors() const;
  // Readable report: one block per contour, then the problems.
  std::string report() const;
};

// Reads `path`. Throws InputError for unreadable or malformed files (see above); reports
// drawing problems in the result. Options are validated first.
ProfileReadResult read_dxf_profile(const std::string& path, const DxfOptions& options = {});

// The same on text already in memory; `source` names it in messages.
ProfileReadResult read_dxf_profile_text(std::string_view text, const std::string& source,
                                        const DxfOptions& options = {});

}  // namespace machplan
