// The certifier: proves that every constraint of a machine (machines/machine_model.h) reaches
// its limit over the whole continuous tool path at a placement or over a ball of placements,
// finds the interference that refutes it, or pins each constraint's smallest value.
//
// Soundness between tool points. Between poses i and i+1 the machine moves as the model's
// interpolate() says (tip on a line; axis on a great circle, or rotary axes on lines). The
// model bounds how far each constraint can drop over a motion (fall()), so an exact value v at
// one pose proves v - fall over every state within that motion. The certifier walks the pose
// tree (pose_tree.h) best first: a node is proven by one exact query at its centre when the
// value there exceeds the required one plus its fall over the node's motion; otherwise its
// children are opened, lowest bound first, down to single intervals, which are subdivided by
// interpolated poses until proven, or until an interference is found. No interval is assumed
// free without such a proof, so nothing can hide between checked points.
//
// Balls of placements. Moving the workpiece by d and turning it by h moves the tool tip, in
// the table frame, by at most d + r h (r the tip's distance from the workpiece's z axis), turns
// the axis by at most h, and moves the workpiece by at most d + R h (R its radius); the same
// fall() then bounds every constraint over the ball, which lets searches decide whole boxes of
// placements at once.
//
// Threads: decide() opens nodes from one shared queue with every worker of the calling task
// arena, stopping all at the first refutation (the verdict never depends on the number of
// threads; the refuting interference found may). report() walks a fixed set of subtrees, each
// with its own record, so its figures are the same for any number of threads. Evaluations go
// through the calling thread's own PoseEvaluator (`evaluator`).
#pragma once

#include <atomic>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "engine/common/progress.h"
#include "engine/common/termination.h"
#include "solvers/placement/check/internal/class1.h"
#include "solvers/placement/check/internal/pose_tree.h"

namespace machplan::placement {

// Work counters several threads add to.
struct WorkCounts {
  std::atomic<long> stretches{0}, exact_queries{0}, interpolated_poses{0}, proven_by_bound{0};
  CheckCounts get() const {
    return {stretches.load(), exact_queries.load(), interpolated_poses.load(), proven_by_bound.load()};
  }
  void add(const CheckCounts& c) {
    stretches += c.stretches, exact_queries += c.exact_queries, interpolated_poses += c.interpolated_poses,
        proven_by_bound += c.proven_by_bound;
  }
};

// Each constraint's smallest value found, and where.
struct Minimum {
  double value = std::numeric_limits<double>::infinity();
  long pose = -1;
  double t = 0;
};

class Certifier {
 public:
  using Evaluator = std::function<PoseEvaluator&()>;

  // `workpiece_radius_mm`: farthest a point of the workpiece and its pad lies from its frame's
  // z axis (what a rotation moves it).
  Certifier(const MachineModel& model, const PoseTree& tree, double workpiece_radius_mm);

  // Whether every constraint in `mask` reaches its limit over the whole path for every
  // placement in the ball around `centre` (true), or a refutation (false, in `failure`: an
  // exact interference deep enough to condemn the whole ball, or, at a single placement, an
  // interval that could not be proven at the finest subdivision). With a ball larger than a
  // point, false with a non-exact failure means "undecided".
  bool decide(const Where& centre, const Ball& ball, Mask mask, Termination& term, const Evaluator& evaluator,
              WorkCounts& counts, Spot* failure);
  // A bounded look (a few dozen tree nodes, at tool poses only) for an interference deep enough
  // to condemn the whole ball: the limits first, then the constraints in `mask`.
  bool probe(const Where& centre, const Ball& ball, Mask cheap, Mask mask, Termination& term, const Evaluator& evaluator,
             WorkCounts& counts, Spot* found);
  // Each constraint's smallest value over the whole path at one placement: to within its
  // report tolerance near its limit, to within half its excess far above it (the value given is
  // one actually met). A report that finds every constraint at its limit is also a proof.
  std::vector<Minimum> report(const Where& where, Termination& term, const Evaluator& evaluator, WorkCounts& counts);
  // Brute force: every pose, and poses every `step_mm` of tip motion (and every 0.5 deg of axis
  // or rotary turn) between them, every constraint exact, no bounds. With `extra`, its
  // smallest value over the same poses is appended to the result.
  std::vector<Minimum> dense(const Where& where, double step_mm, Termination& term, const Evaluator& evaluator,
                             WorkCounts& counts, Progress* progress,
                             const std::function<double(const PathPose&)>& extra = {});

  // The value at which constraint c at a pose (values v) condemns the whole ball.
  double fail_threshold(int c, const double* v, const PathPose& pose, const Ball& ball) const;
  // How far the ball moves things at a pose whose tip lies r from the workpiece's z axis and
  // whose axis leans `lean` (the sine of its angle) from the vertical (1: any pose).
  Motion ball_motion(const Ball& ball, double tip_radius_mm, double lean = 1.0) const;
  Motion ball_motion(const Ball& ball, const PathPose& pose) const;
  // One exact evaluation, counted.
  void evaluate(const PathPose& pose, const Where& where, Mask mask, double* v, PoseEvaluator& e, Termination& term,
                WorkCounts& counts) const;
  // The model's bounds of constraint c over a box at one rotation (PoseEvaluator::box_range),
  // counted as one exact evaluation when there are any.
  std::optional<BoxRange> box_range(int c, const PathPose& pose, const Where& centre, const Eigen::Vector3d& half,
                                    PoseEvaluator& e, Termination& term, WorkCounts& counts) const;

  const PoseTree& tree() const { return tree_; }
  const MachineModel& model() const { return model_; }

 private:
  struct Scan;
  struct Cache;
  const MachineModel& model_;
  const PoseTree& tree_;
  double wp_radius_;
  std::shared_ptr<Cache> cache_;
};

}  // namespace machplan::placement
