// The order in which a part program's cuts are made, and where each is pierced: the step of
// `machplan run --order` and `machplan order`, on the interpreted Program before the Job is
// made.
//
// Why. Plasma and laser practice: inner features are cut before the outer contour of their
// part (a part freed from the sheet can tip or shift, and its holes would then be cut in the
// wrong place), and the torch travels as little as it can between cuts. Programs written by
// hand or by naive CAM cut in drawing order, outline first.
//
// The cuts. A cut is a torch_on ... torch_off run of the program (with its pierce dwell, its
// lead-in, its loop and any lead-out or overcut); the rapids between cuts are travel, and are
// rebuilt for the new order (one straight G0 to the next pierce point; the run's rapid
// planner then routes it). A cut is closed when its path returns to an earlier point of
// itself (the loop of solvers/motion/rapids.h: closed_loop); what comes before the loop is its
// lead-in, what follows its lead-out. Nesting comes from the loops (engine/geometry/
// nesting.h): a cut whose loop (or, for an open cut, whose pierce point) lies inside a loop
// must be cut before that loop.
//
// Orders (CutOrderOptions::order):
//   program   as written. When an outer contour is cut before a cut inside it, one warning
//             names the first such pair.
//   nearest   nearest neighbour: from where the torch is, the nearest pierce point among the
//             cuts whose inner cuts are all done; pierce points as programmed.
//   optimise  inner before enclosing, pierce points chosen, travel minimised (the algorithm
//             of solvers/motion/cut_sequence.h: nearest neighbour over every candidate, then
//             or-opt and part-level 2-opt alternating with an exact choice of the pierce
//             points), with a lower bound on the travel of any order (CutOrderReport).
//
// Pierce points. A closed cut with a lead-in may be pierced elsewhere on its loop: the
// lead-in (and a lead-out that leaves the loop) moves with the entry point as one rigid piece,
// turned with the loop's tangent, so it meets the loop at the same angle from the same (waste)
// side; a lead-out that runs along the loop (an overcut) is walked along the loop again for
// its length. Candidates: `entry_candidates` points spread evenly along the loop (kept
// `corner_margin_mm` from the ends of its spans, where corners are) besides the programmed
// one. A candidate is taken only if its pierce point lies in the same region as the
// programmed one (inside the same contours), keeps `edge_clearance_mm` from every other cut
// and at least as far from its own loop as the programmed pierce (or edge_clearance_mm), and
// its lead-in and lead-out meet the loop only where they join it: never a pierce on a part's
// edge. A cut with no lead-in (pierced on its own edge) keeps its pierce point: moving it
// would pierce the edge of the part.
//
// A cut is a torch_on ... torch_off run; dwells right after its torch_off (a pause to let the
// arc die, as some posts write) go with it.
//
// What is kept. Every cut's geometry (the loop is the same closed path, started elsewhere),
// feeds, path modes, torch words, dwells and source lines; the program's preamble (moves
// before the first cut's approach) and its postamble (from the last cut's end on); events,
// with the cut they came with (those before a cut's torch_on, with its approach). A program
// that cannot be reordered is left as written with a warning naming the line: Z that moves,
// a rapid with the torch on, feed moves or dwells between cuts with the torch off, an arc
// outside the XY plane or of several turns in a cut.
//
// Errors: CutOrderOptions::validate() throws InputError::field. Thread safety: pure.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/common/summary.h"
#include "engine/programs/program.h"

namespace machplan::motion {

enum class CutOrder { program, nearest, optimise };
// "program", "nearest", "optimise".
const char* to_string(CutOrder o);
// The same names, and "optimize"; nothing for another.
std::optional<CutOrder> cut_order_from(std::string_view name);

struct CutOrderOptions {
  CutOrder order = CutOrder::optimise;
  // Pierce points tried on each closed cut with a lead-in, besides the programmed one
  // (0: the programmed ones only). In [0, 64].
  int entry_candidates = 12;
  // How far a moved pierce point and its lead-in keep from every other cut, mm. In (0, 100].
  double edge_clearance_mm = 2.0;
  // How far a moved entry point keeps from the ends of the loop's spans (corners), mm; a span
  // shorter than twice this is entered at its middle. In [0, 1000].
  double corner_margin_mm = 3.0;
  // Rounds of the local search (cut_sequence.h) at most. In [1, 1000].
  int max_rounds = 50;

  void validate() const;
};

struct CutOrderReport {
  CutOrder order = CutOrder::program;
  bool reordered = false;        // the moves were rebuilt (false: the program as written)
  std::size_t cuts = 0, closed_cuts = 0, with_lead_in = 0, moved_pierces = 0;
  std::vector<int> cut_lines;    // each cut's first feed line, in the program's order
  std::vector<int> sequence;     // the cuts (indices into cut_lines) in the order cut
  // Straight rapid travel from the program's start through the cuts (and to the postamble's
  // first rapid, when there is one), mm: as programmed, in nearest-neighbour order, in the
  // order chosen; and the lower bound of solvers/motion/cut_sequence.h (no order with these
  // pierce candidates travels less). 0 when the program was not reordered.
  double programmed_travel_mm = 0.0, nearest_travel_mm = 0.0, travel_mm = 0.0, lower_bound_mm = 0.0;
  // The first outer contour the program cuts before a cut inside it: (its line, the inner
  // cut's line); unset when the program's order keeps inner cuts first.
  std::optional<std::pair<int, int>> outer_first;
  std::vector<std::string> warnings;  // one line each, "FILE:LINE: ..."
  // done; infeasible when a reorder was asked for and the program cannot be reordered.
  Summary summary;
};

struct OrderedProgram {
  Program program;
  CutOrderReport report;
};

// Orders `program`'s cuts as the options say (see the file comment).
OrderedProgram order_cuts(const Program& program, const CutOrderOptions& options);

}  // namespace machplan::motion
