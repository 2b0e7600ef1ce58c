// Where to put the workpiece: the study's evasion search and a certified lexicographic optimum.
//
// Both strategies use the same Checker and the same rule for "best": the lowest pad first,
// then the placement nearest the table centre.
//
// paper   Starts at the table centre on pad 0. At an interference it moves the workpiece one
//         step (10 mm) along the evasion direction of the interference found: towards the table
//         axis for self-interference and struts, away from the peripheral's facing side for
//         peripherals. When two successive evasion directions are more than 150 deg apart, the
//         plane is judged exhausted and the pad is raised one step (10 mm), keeping x, y.
//
// optimal Branch and bound over boxes of placements (x, y, pad on a grid of `resolution_mm`),
//         taken in order of (lowest pad in the box, distance of the box to the centre). A box
//         is screened against the interferences met so far (Checker::screen: one pose query
//         each, bounded over the box by the placement Lipschitz constants); a large box they
//         leave undecided is probed for a deep interference at its centre (Checker::probe).
//         A box is dropped when one interference is provably present everywhere in it, split
//         when undecided, and when no known interference objects anywhere in it, its best point
//         is certified over the whole path (Checker::decide). If that fails, the interference
//         found is learned and the box goes back to be screened again; the first certified
//         point is the optimum on the grid (all boxes before it were proven infeasible).
//         Learning interferences lazily is what makes this fast: the optimum of the bundled
//         scene needs about 30 whole-path certifications, not one per box.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "engine/common/names.h"
#include "solvers/placement/checker.h"

namespace machplan::placement {

struct PlacementOptions {
  enum class Strategy { paper, optimal } strategy = Strategy::optimal;
  // Workpiece rotations about z tried by the optimal strategy (degrees); the best wins, ties
  // go to the first listed.
  std::vector<double> rotations_deg = {0.0};
  // A stop request from outside (the CLI connects SIGINT, SIGTERM and SIGHUP to it), polled
  // between placements and at every exact pose query; once set, the search ends with status
  // `cancelled`.
  StopToken stop;
  // Called with a fraction in [0, 1] as the search advances (for a progress bar).
  std::function<void(double)> progress;

  // Each rotation is a whole search (the bundled scene: about half a second each), so the
  // list is bounded: at most kMaxRotations entries, each finite, within +-360 deg, and no
  // two the same angle (modulo 360).
  static constexpr std::size_t kMaxRotations = 72;

  // Throws InputError::field naming the field (rotations_deg) and the rule broken.
  void validate() const;
};
// "paper" | "optimal"; InputError::field("strategy", ...) listing them otherwise.
const char* to_string(PlacementOptions::Strategy s);
Parsed<PlacementOptions::Strategy> parse_placement_strategy(std::string_view text);

enum class PlacementStatus {
  found,         // a free placement, certified over the whole path
  unavoidable,   // class-1 interference: no relocation can cure it
  no_placement,  // no placement within the table and the pad limit is free
  gave_up,       // the paper's search ran out of steps
  cancelled,
};
const char* to_string(PlacementStatus s);

struct PlacementResult {
  PlacementStatus status = PlacementStatus::no_placement;
  std::string message;
  Placement placement;
  CheckReport report;   // at the answer (or at the last placement tried); empty when cancelled
  bool verified = false;
  CheckCounts counts;   // all checking done by the search
  long placements_examined = 0;
  long certifications = 0;       // optimal: candidate answers checked over the whole path
  double seconds = 0;
  std::vector<Placement> trail;  // paper: every placement visited, in order
  Eigen::AlignedBox2d region;    // x, y range searched (workpiece origin)
};

PlacementResult place(const Scene& scene, const PlacementOptions& options);

// The x, y range where the workpiece's footprint (rotated) stays on the table.
Eigen::AlignedBox2d placement_region(const Scene& scene, double rotation_deg);

}  // namespace machplan::placement
