// Class-1 interference: the tool assembly (shank, chuck, spindle parts, plate) against the
// workpiece over the whole continuous path. These parts move rigidly with the tool pose, so
// the check is done once in the workpiece frame and holds for every placement.
//
// A stretch of the path is proven when a height field of the workpiece (an upper envelope seen
// from above) shows a vertical gap of at least the safe distance under every part's box swept
// over the stretch; otherwise exact distances (FCL) to the workpiece mesh decide, at poses and
// inside intervals subdivided until proven. Once an interference is known only a smaller
// clearance can change the finding, pinned as precisely as a report pins it, so a large safe
// distance, which no stretch clears, still costs a small part of the path.
//
// Parts that turn with the workpiece's rotation relative to the tool (the hexapod's plate
// hinges, machines/machine_model.h PlateRing) are checked either at one rotation (exact
// spheres), or for every rotation at once as the ring they sweep (a cylinder around the axis
// that holds every position of every hinge): a ring found clear clears every rotation.
//
// The walk is split into a fixed set of subtrees of the pose tree, each walked with its own
// record (in parallel when threads are available); the result is the same for any number of
// threads.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/common/termination.h"
#include "engine/interference/collision.h"
#include "engine/interference/height_field.h"
#include "solvers/placement/check/internal/pose_tree.h"
#include "solvers/placement/machines/finding.h"
#include "solvers/placement/scene/internal/workpiece.h"

namespace machplan::placement {

struct Class1Result {
  Finding finding;   // smallest clearance met, the part, where; interferes below the safe distance
  CheckCounts counts;
};

class Class1Check {
 public:
  Class1Check(const MachineModel& model, const PoseTree& tree, const WorkpieceSolid& workpiece, double safe_mm);

  // One thread's collision objects.
  struct Shapes {
    std::vector<interference::Shape> parts;  // class1_parts(), then the ring cylinder
    interference::Shape hinge;
    interference::Shape workpiece;
  };
  Shapes make_shapes() const;

  // Which parts a walk looks at: all, the parts of revolution only (the same at every
  // rotation), or the plate parts only (the hinges at one rotation, or their ring).
  enum class Parts { all, axial, plate };
  // `rotation_rad`: the exact plate parts at that rotation; nullopt: the ring (every rotation).
  // Each exact query charges one unit to `term`; when it ends the walk throws WorkEnded.
  // `shapes` gives the calling thread's own collision objects.
  Class1Result run(std::optional<double> rotation_rad, Termination& term, const std::function<Shapes&()>& shapes,
                   Parts which = Parts::all) const;
  bool has_ring() const { return ring_.has_value(); }
  // The exact clearance at one pose (infinity when the height field proves every part at least
  // the safe distance away), for dense re-checks; `who` names the closest part.
  double exact(const PathPose& pose, std::optional<double> rotation_rad, Shapes& shapes, std::string* who) const;

 private:
  struct Walk;
  Walk make_walk(std::optional<double> rotation_rad, Termination& term, Shapes& s, Parts which = Parts::all) const;
  const MachineModel& model_;
  const PoseTree& tree_;
  const WorkpieceSolid& wp_;
  double safe_;
  std::vector<AxialPart> parts_;
  std::optional<PlateRing> ring_;
  std::unique_ptr<interference::HeightField> height_field_;
};

}  // namespace machplan::placement
