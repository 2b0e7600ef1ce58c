// Where to put the workpiece: the study's evasion search and a certified optimum, on any
// machine behind the model interface (machines/machine_model.h).
//
// Objectives (what "best" means), each feasible first:
//
//   lowest   the lowest pad (fixture), then the placement nearest the table centre, then the
//            smallest rotation (the HexaM study's rule; the default on the hexapod)
//   travel   the least total travel of the linear axes over the path (the sum over axes of the
//            distance each one moves), then nearest the centre (the default on a table-tilting
//            machine; Wei and Lee, "Optimization of the setup position of a workpiece for
//            five-axis machining to reduce machining time", 2020)
//   time     the least machining time as the control's feed planner runs the path
//            (engine/motion/axis_planner.h: joint-space moves between the poses, per-axis
//            speed, acceleration and jerk limits, corner speeds, look-ahead, S-curves, the
//            programmed feed as the machine file's feed_mode reads it)
//
// Strategies:
//
// paper   Starts at the table centre on pad 0. At an interference it moves the workpiece one
//         step (10 mm) along the evasion direction of the interference found: towards the table
//         axis for self-interference and struts, away from the peripheral's facing side for
//         peripherals. When two successive evasion directions are more than 150 deg apart, the
//         plane is judged exhausted and the pad is raised one step (10 mm), keeping x, y.
//         Hexapod only; rotation 0.
//
// optimal Branch and bound over boxes of placements: x, y and pad on a grid of `resolution_mm`,
//         and the rotations asked for (a list, a range, or `any`: every multiple of the scene's
//         rotation_step_deg). Boxes are taken in order of the best objective any placement in
//         them could have. A box is screened against the interferences met so far (each a
//         spot on the path and the constraint it broke: one pose query each, bounded over the
//         box by the machine model's own box bounds where it has them (the machine moves
//         rigidly with the workpiece at one rotation, so distances are convex and slider
//         strokes concave in the move), else, and for the turn, by its motion bounds). A box is
//         dropped when one interference is provably present everywhere in it; its pads are
//         cut from below when a constraint that keeps a pad rate condemns them; it is split
//         when undecided, on the side that narrows the undecided constraints most; and when no
//         known interference objects anywhere in it, its best point is certified over the
//         whole path. If that fails, the interference found is learned and the box goes back to
//         be screened again. On `lowest` the first certified point is the optimum on the grid
//         (all boxes before it were proven infeasible; ties are broken by a total order on the
//         placement, so the answer never depends on the order work was done in). On `travel`
//         and `time` the objective's lower bound over a box (exact per pose and axis: the
//         linear axes are affine in the placement) orders the boxes, and the search ends when
//         no box left could beat the best certified placement by more than
//         `kObjectiveTolerance`.
//
//         On `time` the bound that orders the boxes is the larger of two lower bounds of the
//         planner's time: the velocity-only time's convex bound above (every step at its feed
//         or an axis at its speed limit, which the planner never beats), and the planner's own
//         speed envelope with every cap at its largest over the box (search/internal/
//         planned_time.h: the planner's speed, acceleration and corner caps fall as the axes'
//         rates grow, and the rates are affine in the placement). Placements are then taken in
//         order of that bound and timed by the planner (a few milliseconds each, in parallel
//         with the screening); one whose planned time beats the best so far is certified over
//         the whole path, and becomes the best when free. The search ends when no box left has
//         a bound below the best planned time (the answer is the least on the grid), or once
//         kMaxTimed (100) placements are timed: the bound is a few per cent under the planned
//         time (the jerk and the look-ahead's coupling are left out of it), so proving the
//         optimum can need every placement near it timed when the time hardly depends on the
//         placement. The answer is then the best of those timed, and `time_lower_bound_s` (in
//         the report) says how much less any placement could take at most.
//
//         Learning interferences lazily is what makes this fast: the optimum of the bundled
//         HexaM scene needs about 30 whole-path certifications, not one per box.
//
// The rotation the answer claims: after the search, the answer is certified over the widest
// interval of rotations around it (up to half the rotation step) that the checker can prove
// free, and the report gives it, so that the operator knows how precisely the workpiece must
// be turned.
//
// Threads: screening runs over batches of boxes on every thread, and every certification uses
// them all (oneTBB; `threads` limits them). The answer, its report and its status do not depend
// on the number of threads; the work counts may.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/common/names.h"
#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "solvers/placement/check/checker.h"

namespace machplan::placement {

struct PlacementOptions {
  enum class Strategy { paper, optimal } strategy = Strategy::optimal;
  // automatic: lowest on a hexapod, travel on a table-tilting machine.
  enum class Objective { automatic, lowest, travel, time } objective = Objective::automatic;
  // Workpiece rotations about the table's z the optimal strategy may choose (degrees, each
  // within +-360, no two the same angle modulo 360; the paper strategy takes only {0}) ...
  std::vector<double> rotations_deg = {0.0};
  // ... or every multiple of the scene's search.rotation_step_deg in (-180, 180].
  bool any_rotation = false;
  // Worker threads; 0 uses every core.
  int threads = 0;
  // Time: the search stops once no setup left can be more than this many per cent faster than
  // the best one timed (0: only when none can be faster, or after the timing budget).
  double time_gap_pct = 1.0;

  // Rotation lists are bounded (a range 0:360:0.1 is 3600 rotations).
  static constexpr std::size_t kMaxRotations = 3600;

  // Throws InputError naming the field (rotations_deg, threads, time_gap_pct) and the rule broken.
  void validate() const;
};

// Reads a rotation list as people write it: "any", "0,90,180,270" or a range "FROM:TO:STEP"
// (TO excluded when it is FROM + 360, the same angle), or lists of both ("0:90:15,180").
// Throws InputError::field("rotations_deg", ...).
void parse_rotations(std::string_view text, PlacementOptions& options);

// Names of objectives and strategies, one spelling each.
PlacementOptions::Objective parse_objective(std::string_view text);
const char* to_string(PlacementOptions::Objective o);
// "paper" | "optimal"; InputError::field("strategy", ...) listing them otherwise.
const char* to_string(PlacementOptions::Strategy s);
Parsed<PlacementOptions::Strategy> parse_placement_strategy(std::string_view text);

// Axis travel of a table-tilting machine over the whole path at one placement.
struct AxisTravel {
  std::vector<std::string> axes;   // X, Y, Z, then the rotary axes; or a hexapod's sliders
  int linear_axes = 3;             // the first ones are linear
  std::vector<double> travel;      // mm for linear axes, degrees for rotary ones
  double linear_mm = 0.0;          // the linear axes' sum (X + Y + Z)
  // Machining time: the 5-axis feed planner's (engine/motion/axis_planner.h) when the machine
  // gives accelerations and jerks (`planned`), else the velocity-only time.
  double time_s = 0.0;
  double velocity_only_time_s = 0.0;  // every step at its feed or an axis at its speed limit, no acceleration
  bool planned = false;
  long flips = 0;                  // rotary-table flips (a half turn within one step)
  long forced_flips = 0;           // of which the axis limits force
  std::vector<long> flip_poses;
};

struct PlacementResult {
  // How the search ended, with its brief and full report: done (a free placement, certified
  // over the whole path); infeasible (class-1 interference no relocation can cure, or no
  // placement within the table and the pad limit is free: the message says which); budget
  // (the paper's search ran out of steps, or the pose queries' budget was spent); cancelled or
  // deadline.
  Summary summary = [] {
    Summary s;
    s.status = Status::infeasible;  // until the search finds a placement
    return s;
  }();
  // The Termination (a stop request, deadline or budget) ended the search inside a decision:
  // no answer and nothing examined to show.
  bool ended_early() const { return !summary.done() && summary.status != Status::infeasible && placements_examined == 0; }
  Placement placement;
  // The answer is certified free for every rotation within this of its own (degrees).
  double rotation_tolerance_deg = 0.0;
  CheckReport report;   // at the answer (or at the last placement tried); empty when cancelled
  bool verified = false;
  CheckCounts counts;   // all checking done by the search
  long placements_examined = 0;
  long certifications = 0;       // optimal: candidate answers checked over the whole path
  long rotations = 0;            // rotations the search could choose from
  double seconds = 0;
  int threads = 1;
  PlacementOptions::Objective objective = PlacementOptions::Objective::lowest;
  double objective_value = 0.0;  // travel (mm) or time (s) at the answer
  // time: no placement on the grid takes less (the bound of those not timed); equal to
  // objective_value when the answer is the least on the grid.
  double time_lower_bound_s = 0.0;
  std::vector<Placement> trail;  // paper: every placement visited, in order
  Eigen::AlignedBox2d region;    // x, y range searched (workpiece origin)
  WorkOffset work_offset;        // where to set the control's work offset
  std::optional<AxisTravel> travel;         // table-tilting: at the answer ...
  std::optional<AxisTravel> centre_travel;  // ... and at the table centre on the lowest fixture
};

PlacementResult place(const Scene& scene, const PlacementOptions& options, Termination& term,
                      Progress* progress = nullptr);

// The x, y range where the workpiece's footprint (rotated) stays on the table.
Eigen::AlignedBox2d placement_region(const Scene& scene, double rotation_deg);

// Axis travel along the path at one placement, for a machine that has an AxisPath
// (machines/machine_model.h; on a hexapod, with the sliders' limits); nullopt otherwise.
std::optional<AxisTravel> axis_travel(const Scene& scene, const Placement& p);
// The same at several workpiece offsets of one rotation, the path built once: one per offset,
// or none.
std::vector<AxisTravel> axis_travel(const Scene& scene, double rotation_deg, const std::vector<Eigen::Vector3d>& offsets);

}  // namespace machplan::placement
