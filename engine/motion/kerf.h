// Kerf compensation of a cutting Job: each closed cut is moved by half the kerf to the side
// that keeps the part.
//
// A torch (plasma, oxy-fuel) removes a strip of material as wide as its kerf, centred on the
// path. A program written on the part's drawn outline therefore cuts every part too small and
// every hole too large by half the kerf. apply_kerf moves the path:
//
//   * Loops. A cutting Stretch (torch on) is searched for a closed loop: a run of segments
//     P(a) .. P(b) whose end returns to its start (within closure_tolerance_mm) and which
//     encloses area. The segments before it are the lead-in, those after it the overcut
//     (segments lying on the loop, cut a second time past the start) and the lead-out. When
//     several runs close, the shortest is the loop (so a lead-out that returns to the pierce
//     point is not mistaken for part of it).
//
//   * Part or hole. All loops of the job are nested: the depth of a loop is the number of
//     other loops that enclose it. Even depth (0: an outline, 2: a part inside a hole, ...)
//     is a part boundary and grows by kerf/2; odd depth is a hole and shrinks by kerf/2.
//
//   * Offset. The loop becomes a Contour (arcs stay arcs) and is offset exactly by
//     offset_contour (engine/geometry/offset.h). When the offset has several contours (a hole
//     whose neck is narrower than the kerf falls apart; a part whose inlet is narrower
//     closes it off into a separate loop) the one of the loop's orientation nearest to the
//     lead-in's landing point is cut and every other one is reported as not cut. The new loop
//     starts at the point of the offset nearest to where the old start moves (old start +
//     kerf/2 along the outward or inward normal of the first span; at a concave corner this
//     is where the offsets are trimmed).
//
//   * Re-attaching. The lead-in keeps its pierce point and the bulge of its last segment,
//     whose end is re-aimed onto the new loop's start. The overcut is replaced by the same
//     length of the new loop. The lead-out's first segment starts where the new loop (or
//     overcut) ends and keeps its end. When the cut has no lead-in (or no lead-out) its start
//     (end) moves, and the neighbouring non-cutting Stretch (the rapid before or after it in
//     step order) is re-aimed to keep the path continuous; only when that neighbour is itself
//     a cut does apply_kerf add a straight connecting cut inside the Stretch, and reports it.
//     Per-segment feeds and source lines are carried over from the programmed span each new
//     segment comes from.
//
//   * What is left alone, and reported: open cuts (no closed loop: slits, engraving lines),
//     cuts holding more than one closed loop, and loops whose offset vanishes (a hole smaller
//     than the kerf) stay as programmed. Arcs that collapse and features narrower than the
//     kerf are reported with the program line of the span concerned.
//
// Steps are not changed; only Stretch geometry, feeds and source lines are. Not thread-safe
// for one Job; different Jobs may be compensated concurrently.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "engine/geometry/offset.h"
#include "engine/motion/job.h"

namespace machplan::motion {

struct KerfOptions {
  // Largest gap, mm, between the end of a run of segments and its start that still closes a
  // loop; also how near an overcut segment must stay to the loop to count as overcut.
  // Programs written to 3 decimals close to about 1e-3 mm. Must be finite, > 0 and <= 1.
  double closure_tolerance_mm = 1e-3;
  // Each closed cut by the kerf of its material (Job::materials[Step::material].kerf_mm, a
  // QtPlasmaC material's KERF_WIDTH) where its material gives one; cuts with none use the
  // kerf_width_mm passed to apply_kerf (0: left as programmed).
  bool kerf_from_materials = false;
  // Tolerances of the geometric offset.
  OffsetOptions offset;

  // Throws InputError naming the field, its value and the rule it broke.
  void validate() const;
};

struct KerfIssue {
  enum class Kind {
    open_cut,            // a cut without a closed loop: not compensated
    several_loops,       // a cut holding more than one closed loop: not compensated
    contour_vanished,    // the loop is smaller than the kerf everywhere: left as programmed
    arc_collapsed,       // an arc of the loop is smaller than half the kerf: lost
    feature_too_small,   // part of the loop narrower than the kerf: not reproduced
    piece_not_cut,       // the offset fell apart; this piece is not cut
    connector_added,     // a straight cut was added to keep the path continuous
  };
  Kind kind = Kind::open_cut;
  std::size_t stretch = 0;  // index into Job::stretches
  int source_line = 0;      // 1-based program line, 0 when unknown
  std::string message;      // one line, for people
};
const char* to_string(KerfIssue::Kind k);

// One closed loop found in the job.
struct KerfLoop {
  std::size_t stretch = 0;
  int depth = 0;            // nesting depth among all loops: even = part boundary, odd = hole
  double offset_mm = 0.0;   // +kerf/2 (grown) or -kerf/2 (shrunk)
  bool compensated = false; // false: left as programmed (see the issues)
  int source_line = 0;      // line of the loop's first segment
};

struct KerfReport {
  double kerf_width_mm = 0.0;       // the width given (cuts without a material kerf)
  bool kerf_from_materials = false; // each cut's material's kerf where it has one
  std::vector<KerfLoop> loops;
  std::vector<KerfIssue> issues;

  std::size_t compensated_count() const;
  // A few lines: counts, then one "SOURCE:LINE: kind: message" line per issue.
  std::string brief(const std::string& source = "") const;
};

// Compensates every closed cut of `job` for a kerf of `kerf_width_mm` (see the file
// comment), or of its material's kerf (KerfOptions::kerf_from_materials); 0 without materials
// leaves the job unchanged. Throws InputError when the width is not finite,
// negative or over 100 mm, when the options are invalid, and when a closed cut crosses itself
// ("SOURCE:LINE: ..." naming its first line), since its offset is not defined. On a throw the
// job is unchanged.
KerfReport apply_kerf(Job& job, double kerf_width_mm, const KerfOptions& options = {});

}  // namespace machplan::motion
