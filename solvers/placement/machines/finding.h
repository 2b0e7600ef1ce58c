// The vocabulary of placement checks: where the workpiece is, which kinds of interference are
// told apart, and what a check found for each.
//
// Kinds of interference (after the HexaM placement study, with the support added):
//   self                   the machine against its own limits and parts: travel and joint
//                          limits, strut against strut (hexapod), tool and head against the
//                          trunnion's cradle and rotary table (table-tilting machine)
//   workpiece_class1       tool shank, chuck and spindle parts against the workpiece: they move
//                          rigidly with the tool pose, so their clearance does not depend on
//                          where the workpiece sits, and relocation cannot cure it
//   workpiece_class2       moving machine parts against the workpiece (and its pad or fixture)
//                          whose clearance relocation changes: the hexapod's struts, the
//                          trunnion's cradle as the table turns
//   machine_peripheral     a moving part against a peripheral (the tool magazine, a clamp)
//   workpiece_peripheral   the workpiece with its pad or fixture against a peripheral
//   tool_support           the tool, flutes included, and its holder against what carries the
//                          workpiece: the pad or fixture under it (below any sacrificial
//                          spoilboard) and the table
// A kind "interferes" when some clearance falls below the safe distance (the paper grows
// objects by it), or when a limit is crossed.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/termination.h"

namespace machplan::placement {

// A workpiece placement: its frame's origin (the centre of the bottom face unless the scene
// says otherwise) at (x, y, pad) in the machine's table frame, turned by `rotation_deg` about
// the table's z. The pad (hexapod) or fixture (trunnion) fills the workpiece's footprint from
// the table up to z = pad.
struct Placement {
  double x_mm = 0, y_mm = 0, pad_mm = 0, rotation_deg = 0;
  Eigen::Vector3d offset() const { return {x_mm, y_mm, pad_mm}; }
};

// A set of placements around one: every placement within `radius_mm` (Euclidean, in x, y and
// pad) and within `turn_deg` of rotation. A ball of radius 0 and turn 0 is the placement.
struct Ball {
  double radius_mm = 0.0;
  double turn_deg = 0.0;
  // When the ball stands for a box of placements: half its height in pad (the rest of the
  // radius lies in x and y); negative when not known (up to the radius). Lets the checker look
  // at the box's top or bottom only for constraints that change with the pad one way.
  double pad_half_mm = -1.0;
  // ... and half its sizes in x and y (negative when not known).
  double x_half_mm = -1.0, y_half_mm = -1.0;
  bool point() const { return radius_mm == 0.0 && turn_deg == 0.0; }
  bool box() const { return pad_half_mm >= 0.0 && x_half_mm >= 0.0 && y_half_mm >= 0.0; }
};

enum class Kind { self, workpiece_class1, workpiece_class2, machine_peripheral, workpiece_peripheral, tool_support };
inline constexpr int kKindCount = 6;
const char* kind_name(Kind kind);

// The worst spot found for one kind.
struct Finding {
  bool interferes = false;
  double clearance_mm = 0;     // smallest clearance (mm); for limits, see `what`
  long pose = -1;              // tool-path index (the interval starting there when t > 0)
  double t = 0;                // position inside the interval [pose, pose + 1]
  int line = 0;                // the tool-path file's line of that pose (0: none)
  std::string what;            // the parts or the limit involved
  Eigen::Vector2d evasion = Eigen::Vector2d::Zero();  // direction the paper moves the workpiece
};

// Work done, for reports and benchmarks. Not part of a result: with several threads a search
// may do more or less work for the same answer.
struct CheckCounts {
  long stretches = 0;          // tree nodes examined
  long exact_queries = 0;      // poses evaluated exactly
  long interpolated_poses = 0; // poses added inside intervals that needed it
  long proven_by_bound = 0;    // stretches certified without looking inside
  void add(const CheckCounts& o) {
    stretches += o.stretches, exact_queries += o.exact_queries, interpolated_poses += o.interpolated_poses,
        proven_by_bound += o.proven_by_bound;
  }
};

// The tightest clearance of the moves one tool makes (a job with several tools).
struct ToolClearance {
  std::string tool;        // "T16"
  long poses = 0;          // made with it
  Finding tightest;        // its smallest distance (any kind but the placement-only one)
  Kind kind = Kind::self;  // of which kind
};

struct CheckReport {
  Placement placement;
  std::array<Finding, kKindCount> kinds;
  std::vector<ToolClearance> tools;  // per tool of the job, in order of first use
  double stroke_margin_mm = 0;  // smallest distance of an axis (slider, linear axis) to its travel end
  double joint_margin_deg = 0;  // smallest angle left to a joint's limit (cone, rotary axis)
  bool on_table = true;         // the workpiece's footprint lies on the table
  bool free() const;
  CheckCounts counts;
};

enum class Decision { feasible, infeasible, unknown };

// Thrown by checks when their Termination ends the work: no partial answer is certified.
struct WorkEnded {
  Termination::Reason reason;
};

// A spot on the path: pose index, position inside the interval after it, constraint.
struct Spot {
  long pose = -1;
  double t = 0;
  int constraint = -1;
  double value = 0;
  bool exact = false;  // value is an exact one (else a bound that could not be raised)
  // On a tool change's moves, which are fixed to the table: it holds at that placement alone.
  bool tool_change = false;
};

// What screening a known interference against a box of placements found besides its decision.
struct SpotScreen {
  // For a constraint that keeps a pad rate (machine_model.h): every placement more than this
  // below the box's top pad is condemned (infinite: none is known to be).
  double condemned_below_mm = std::numeric_limits<double>::infinity();
  // How much of the constraint's range over the box each of its sides (x, y, pad) makes
  // (zero when not known): splitting the side with the most narrows it most.
  double spread_mm[3] = {0.0, 0.0, 0.0};
};

}  // namespace machplan::placement
