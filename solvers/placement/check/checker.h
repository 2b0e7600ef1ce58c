// Interference checking of a whole five-axis tool path at one workpiece placement, or over a
// ball of placements, on any machine behind the model interface (machines/machine_model.h).
//
// The checker is the constraint model, the certifier and class 1 put together for one scene
// (for each run of moves one tool makes, with the machine model built with that tool; poses and
// spots are numbered along the whole path):
//
//   machine model     what interferes with what at one pose, per kind (machines/hexam_model.h,
//                     machines/trunnion_model.h)
//   certifier         what happens between checked poses, along the continuous path and over
//                     balls of placements (internal/certifier.h, internal/pose_tree.h)
//   class 1           the tool assembly against the workpiece, once for every placement
//                     (internal/class1.h)
//
// and it gives the answers a user or a search asks for: a report per kind of interference at
// one placement, a decision (free, not free, undecided) over a ball of placements, a quick
// probe for a deep interference, a brute-force dense re-check, and one constraint at one spot
// for the searches' cache of known interferences (search/search.h keeps that cache).
//
// Work and threads: every call takes a Termination; each exact pose query charges it one unit,
// and each call has a budget of its own of scene.search.max_pose_queries queries. When the work
// must end (a stop request, a deadline, a budget) the call throws WorkEnded (no partial answer
// is certified); check() and place() turn that into a status. The checker uses every thread of
// the task arena it is called in (oneTBB), each with its own collision objects; its answers do
// not depend on the number of threads. Calls on one Checker must not overlap, except
// screen_spot() and probe(), which may be called from several threads at once.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "solvers/placement/machines/finding.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

class Checker {
 public:
  // Builds the pose tree (class 1 is checked when first asked, once per rotation).
  explicit Checker(const Scene& scene);
  ~Checker();
  Checker(const Checker&) = delete;
  Checker& operator=(const Checker&) = delete;

  // Class-1 clearance over the whole path at a rotation (computed once per rotation).
  const Finding& class1(double rotation_deg, Termination& term);
  // Class 1 for every rotation at once (checked when first asked): free means free at every
  // rotation; an interference by a part that does not turn with the workpiece is one at every
  // rotation; one by the plate ring (what begins "plate hinges (any rotation)") says nothing
  // about a single rotation.
  const Finding& class1_every_rotation(Termination& term);
  bool class1_clear_every_rotation(Termination& term) { return !class1_every_rotation(term).interferes; }

  // Full report at one placement: for each kind the smallest clearance over the whole path
  // and whether it interferes. Near the safe distance a minimum is found to within 0.25 mm
  // (0.3 deg for joints); a clearance far above it, to within half its excess (the value shown
  // is one actually met). A report that finds every kind free is a certificate like decide().
  CheckReport report(const Placement& p, Termination& term);

  // Decides whether every placement in the ball around p is free (feasible), none is
  // (infeasible), or neither could be shown. With a point ball it decides p. On infeasible,
  // `witness` holds the interference that proved it and `spot` (optional) where it is. With
  // `peripherals_first`, the peripheral constraints are scanned over the whole path before the
  // others, so the witness is a peripheral interference whenever there is one (the paper's
  // search evades the magazine before anything else); the verdict is the same.
  Decision decide(const Placement& p, const Ball& ball, Termination& term, Finding* witness = nullptr,
                  Spot* spot = nullptr, bool peripherals_first = false);

  // Looks, with a bounded effort, for one interference deep enough to make every placement in
  // the ball infeasible (`spot` receives it); unknown otherwise. Thread-safe.
  Decision probe(const Placement& p, const Ball& ball, Termination& term, Spot* spot);

  // One known interference (a spot) against a ball: infeasible when it is deep enough to
  // condemn every placement in the ball, feasible when the ball clears it everywhere, unknown
  // otherwise. One pose query. Thread-safe. When unknown, `more` (optional) tells what else
  // is known (SpotScreen).
  Decision screen_spot(const Spot& spot, const Placement& centre, const Ball& ball, Termination& term);
  Decision screen_spot(const Spot& spot, const Where& centre, const Ball& ball, Termination& term,
                       SpotScreen* more = nullptr);

  // The placement-only checks over a ball: the workpiece with its pad on the table and clear
  // of the peripherals (no pose query).
  Decision decide_block(const Placement& centre, const Ball& ball, Finding* witness = nullptr);

  // Brute-force re-check: every tool pose and interpolated poses every `step_mm` of tip
  // motion (and every 0.5 deg of axis or rotary turn), every constraint evaluated without
  // the bounds. Slow; the reference the certified answers are checked against.
  CheckReport dense_check(const Placement& p, double step_mm, Termination& term, Progress* progress = nullptr);

  CheckCounts counts() const;
  std::size_t pose_count() const;
  // The path's poses as the machine runs them (rotary angles filled in).
  const std::vector<PathPose>& poses() const;
  const Scene& scene() const;
  // The name of the constraint a spot (from decide() or probe()) broke.
  const std::string& constraint_name(const Spot& spot) const;

 private:
  struct Run;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct CheckOptions {
  bool dense = false;         // brute-force re-check instead of the certified one
  double dense_step_mm = 0.5;
  int threads = 0;            // worker threads; 0 uses every core
  // Throws InputError naming the field.
  void validate() const;
};

struct CheckResult {
  Summary summary;  // done: the check ran to its end (free or not: see report.free())
  CheckReport report;
  CheckCounts counts;
  bool dense = false;
  std::size_t poses = 0;
};

// `machplan check`: the report at one placement, with its brief and full text.
CheckResult check(const Scene& scene, const Placement& p, const CheckOptions& options, Termination& term,
                  Progress* progress = nullptr);

}  // namespace machplan::placement
