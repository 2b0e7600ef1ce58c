// The cut program of one nested sheet: every placed copy's holes and outline as closed cuts,
// with lead-ins, lead-outs, overcut, kerf and the QtPlasmaC words a plasma shop expects.
//
// Direction. A torch with a clockwise swirl leaves its square edge on the right of its travel,
// so by default the part is kept on the right: outlines run clockwise, holes counter-clockwise
// (QtPlasmaC warns about holes cut clockwise). `part_on_right = false` turns both round.
//
// Kerf. With kerf_mm > 0 and compensate_kerf, every outline grows and every hole shrinks by
// half the kerf (engine/geometry/offset.h, exact: arcs stay arcs), so the cut's centre line
// runs in the waste. A hole that vanishes (narrower than the kerf) is cut as drawn and named in
// `warnings`; a hole that falls apart is cut piece by piece. With compensate_kerf false the
// program follows the drawing and the header says so (for `machplan run --kerf`).
//
// Leads. A lead-in starts at the pierce point, on the waste side (inside a hole, outside an
// outline), and meets the contour tangentially (arc: a quarter circle of radius length_mm) or
// square to it (line of length_mm). Its entry point is chosen among the middles of the
// contour's spans (straight spans first, longest first; arcs by length; kept corner_margin_mm
// from the spans' ends), as the first whose whole lead keeps clearance_mm from every other cut
// of the sheet, lies inside the sheet and as far from its own contour as it should (so it
// crosses no part of its own contour). When no entry has room at full length, the lead is
// shortened (to 3/4, 1/2, 3/10 of its length: `shortened`); when none has room even then, the
// entry with the most room is taken at the shortest length (`cramped`). A small hole is entered
// from its middle instead: a round one from its centre (half a circle of half its radius, or a
// line of its radius), another by a line from the middle of its box to the nearest point of its
// edge, when that line has room. After the loop comes
// the overcut (overcut_mm along the contour, torch on), then the lead-out, built like the
// lead-in and leaving into the waste. Full circles are cut as one arc (as QtPlasmaC's hole
// rules need).
//
// The cuts come in the nest's order; solvers/motion/cut_order.h then orders them (inner
// contours first, a part in a hole before that hole, pierce points moved where the travel is
// least) as `machplan order` does, and engine/programs/gcode_writer.h writes the G-code.
//
// QtPlasmaC. material > 0 writes M190 P<material> and the wait for it (M66 P3 L3 Q1) first;
// a feed of kMaterialCutFeed is written F#<_hal[plasmac.cut-feed-rate]> (the material's feed).
// hole_mode 1 .. 4 writes QtPlasmaC's hole rules (#<holes>, #<h_diameter>, #<h_velocity>,
// #<oclength>), which QtPlasmaC and `machplan run` apply to the full circles; THC is held off
// (M62 P2 ... M63 P2) for the cuts of those small holes, whose slowed arc would make it dive.
//
// Errors: SheetProgramOptions::validate() throws InputError::field. Thread safety: pure.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/programs/program.h"
#include "solvers/nesting/certificate.h"
#include "solvers/nesting/part.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

enum class LeadShape { line, arc };
const char* to_string(LeadShape s);
// "line", "arc"; nothing for another name.
std::optional<LeadShape> lead_shape_from(std::string_view name);

struct Lead {
  LeadShape shape = LeadShape::arc;
  // How far the lead's free end (the pierce point of a lead-in) lies from the contour, mm: the
  // arc's radius, the line's length. 0: no lead. In [0, 100].
  double length_mm = 5.0;
};

struct SheetProgramOptions {
  double feed_mm_per_min = 2000.0;  // (0, 100000], or kMaterialCutFeed
  Lead lead_in{LeadShape::arc, 5.0};
  Lead lead_out{LeadShape::line, 0.0};
  double overcut_mm = 0.0;          // [0, 50]
  double kerf_mm = 0.0;             // [0, 20]
  bool compensate_kerf = true;
  double clearance_mm = 2.0;        // leads from other cuts, (0, 100]
  double corner_margin_mm = 3.0;    // entry points from the spans' ends, [0, 100]
  bool part_on_right = true;
  int material = 0;                 // QtPlasmaC material number, [0, 999999]; 0: none selected
  int hole_mode = 0;                // QtPlasmaC #<holes>, [0, 4]; 0: not written
  double hole_diameter_mm = 32.0;   // #<h_diameter>, (0, 1000]
  double hole_velocity_pct = 60.0;  // #<h_velocity>, [1, 100]
  double hole_overcut_mm = 4.0;     // #<oclength>, [0, 50]

  void validate() const;
};

struct SheetProgram {
  Program program;
  int cuts = 0;
  int shortened = 0;  // leads shorter than asked, for want of room
  int cramped = 0;    // leads with less room than clearance_mm even at the shortest
  std::vector<std::string> warnings;  // one line each
  std::string order_summary;          // how solvers/motion/cut_order.h ordered the cuts
};

// The cuts of the copies on sheet `sheet` (placements[i].sheet == sheet, `geometry` its
// size), as a program starting at the sheet's origin and ending there. Torch on and off as
// M3 S1 / M5.
SheetProgram sheet_program(const std::vector<NestPart>& parts, const std::vector<Placement>& placements, int sheet,
                           const Sheet& geometry, const SheetProgramOptions& options = {});

}  // namespace machplan::nesting
