// The moves of a tool change, which depend on where the workpiece sits: the machine's change
// position is fixed to the table, the path to the workpiece.
//
// At each change (ToolRun k > 0) the spindle takes the old tool out of the work and to the
// change position, swaps tools there, and brings the new one to the first pose of its run:
//
//   out (old tool)   the last pose of run k-1; the tool drawn back along its own axis until the
//                    spindle nose is at the change position's height; the change position,
//                    tool vertical
//   in (new tool)    the change position, tool vertical; above the first pose of run k along
//                    its axis at the change position's height; that first pose
//
// Drawing back and coming down follow the tool axis; the moves between the drawn-back poses and
// the change position are made in machine coordinates, every axis linear
// (MachineModel::axis_move: on a trunnion the table tilts on the way without swinging the
// linear axes round it). Heights are the spindle nose's up the machine's spindle direction (MachineModel::nose_height):
// on a trunnion the tool is drawn back along the machine's Z, the table still tilted. A tool
// already above the change height is not drawn back; one whose nose rises less than 0.2 mm per
// mm drawn back (a hexapod's spindle tilted past 78 deg) is drawn back no further than
// kMaxRetractMm. The poses are in the workpiece frame at one placement, for the checker's runs
// (check/checker.h).
#pragma once

#include <vector>

#include "solvers/placement/machines/machine_model.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

inline constexpr double kMaxRetractMm = 1000.0;

struct ChangeMoves {
  std::vector<PathPose> out, in;  // workpiece frame
};

// The change before run k (k >= 1) of a scene with a change position, at `where`; `last` and
// `first` are the poses either side of it as the machine takes them (rotary angles filled in).
ChangeMoves change_moves(const Scene& scene, std::size_t k, const Where& where, const PathPose& last,
                         const PathPose& first);

}  // namespace machplan::placement
