// Interference checking of a whole five-axis tool path at one workpiece placement.
//
// Five kinds of interference are told apart, as in the HexaM placement study:
//   self                   slider stroke, reach, joint cones, strut-to-strut clearance
//   workpiece_class1       tool shank, chuck, spindle head, plate and plate hinges against the
//                          workpiece: they move rigidly with the tool pose, so their clearance
//                          does not depend on where the workpiece sits, and relocation cannot
//                          cure it. (The study lists hinges under class 2; here the plate never
//                          spins about the tool axis, so its hinges are as rigid as the head.)
//   workpiece_class2       struts against the workpiece and its pad: relocation can cure it.
//   machine_peripheral     any moving part against a peripheral (the tool magazine)
//   workpiece_peripheral   the workpiece with its pad against a peripheral
// A kind "interferes" when some clearance falls below the safe distance (the paper grows
// objects by it), or when a limit is crossed.
//
// Soundness between tool points. The path is checked as a continuous motion: between poses
// i and i+1 the tip moves on a line and the axis on a great circle. For every interval the
// checker knows how far any point of each moving body can travel (delta_rigid for the tool
// assembly, kappa * delta_joint for the struts; see models/hexam/hexam.h), so a clearance c at
// one pose proves clearance c - delta over every pose within that travel. The intervals are
// held in a bounding-volume tree built on pose proximity (tip and axis): a node is proven by
// one exact query at its centre pose when the clearance there exceeds the required one plus
// the travel to the farthest pose of its intervals (kappa taken from the struts' actual angles
// to their rails, widened by how far they can turn inside the node); otherwise its children
// are opened, lowest bound first, down to single intervals, which are subdivided by
// interpolated poses until proven or until an interference is found. No interval is assumed
// free without such a proof, so nothing can hide between checked points.
//
// The same bounds carry over to the placement itself: moving the workpiece by |d| moves the
// tool assembly by |d| and the struts by at most kappa |d|, which lets the optimal search
// decide whole boxes of placements at once (screen(), probe() and decide() with a radius).
//
// Thread safety: a Checker is not thread-safe (it caches per-scan values); give each thread its
// own. Construction does the placement-independent work (class 1, motion bounds) once.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/stop.h"
#include "engine/interference/height_field.h"
#include "solvers/placement/scene.h"

namespace machplan::placement {

struct Placement {
  double x_mm = 0, y_mm = 0, pad_mm = 0, rotation_deg = 0;
  Eigen::Vector3d offset() const { return {x_mm, y_mm, pad_mm}; }
};

enum class Kind { self, workpiece_class1, workpiece_class2, machine_peripheral, workpiece_peripheral };
inline constexpr int kKindCount = 5;
const char* kind_name(Kind kind);

// The worst spot found for one kind.
struct Finding {
  bool interferes = false;
  double clearance_mm = 0;     // smallest clearance (mm); for limits, see `what`
  long pose = -1;              // tool-path index (the interval starting there when t > 0)
  double t = 0;                // position inside the interval [pose, pose + 1]
  std::string what;            // the parts or the limit involved
  Eigen::Vector2d evasion = Eigen::Vector2d::Zero();  // direction the paper moves the workpiece
};

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

struct CheckReport {
  Placement placement;
  std::array<Finding, kKindCount> kinds;
  double stroke_margin_mm = 0;  // smallest slider distance to a stroke end
  double joint_margin_deg = 0;  // smallest angle left in a joint cone
  bool free() const;
  CheckCounts counts;
};

enum class Decision { feasible, infeasible, unknown };

// A workpiece rotation about z: finite and within +-360 deg, else InputError::field(field, ...).
void validate_rotation_deg(double rotation_deg, const char* field);

class Checker {
 public:
  // `stop`: a stop request from outside (the CLI connects SIGINT, SIGTERM and SIGHUP to it),
  // polled at every exact pose query, from construction on; once it is set the call under way
  // throws Cancelled (exit 3), as there is no partial answer worth giving.
  explicit Checker(const Scene& scene, double rotation_deg = 0.0, StopToken stop = {});

  // Class 1 clearance over the whole path (placement-independent, computed at construction).
  const Finding& class1() const { return class1_; }

  // Full report at one placement: for each kind the smallest clearance over the whole path
  // and whether it interferes. Near the safe distance a minimum is found to within 0.25 mm
  // (0.3 deg for joints); a clearance far above it, to within half its excess (the value shown
  // is one actually met). A report that finds every kind free is a certificate like decide().
  CheckReport report(const Placement& p);

  // Decides whether every placement within `radius_mm` (Euclidean, in x, y, pad) of p is free
  // (feasible), none is (infeasible), or neither could be shown. With radius 0 it decides p.
  // On infeasible, `witness` holds the interference that proved it. With
  // `peripherals_first`, the peripheral constraints are scanned over the whole path before
  // the others, so the witness is a peripheral interference whenever there is one (the
  // paper's search evades the magazine before anything else); the verdict is the same.
  Decision decide(const Placement& p, double radius_mm, Finding* witness = nullptr, bool peripherals_first = false);

  // Screens a box of placements (radius around p, as in decide) against the interferences
  // this checker has already met (each a tool pose, possibly inside an interval, and the
  // constraint it broke) plus the workpiece-vs-peripheral and class-1 checks. `infeasible` is
  // proven as in decide(); `feasible` only means that no known interference objects, and must
  // be confirmed with decide() before it is trusted. Cheap: a handful of pose queries.
  // `settled` (optional) marks the known interferences already shown absent over a larger
  // ball containing this one (bits by learning order, the first 64); they are skipped, and
  // the ones shown absent here are added.
  Decision screen(const Placement& p, double radius_mm, std::uint64_t* settled = nullptr);
  std::size_t known_interferences() const { return learned_.size(); }

  // Looks over the whole path for one interference deep enough to make every placement within
  // `radius_mm` of p infeasible (learned for screen() when found); `unknown` otherwise. Much
  // cheaper than decide() when the radius is large, since it follows only deep interferences.
  Decision probe(const Placement& p, double radius_mm);

  // Brute-force re-check: every tool pose and interpolated poses every `step_mm` of tip
  // motion (and every 0.5 deg of axis turn), every constraint evaluated without the stretch
  // bounds. Slow; used by tests and benchmarks to confirm an answer. `progress` (may be
  // empty) hears the fraction of the path done, in [0, 1] (for a progress bar).
  CheckReport dense_check(const Placement& p, double step_mm = 0.5, const std::function<void(double)>& progress = {});

  const CheckCounts& counts() const { return counts_; }
  std::size_t pose_count() const { return tips_.size(); }
  const Scene& scene() const { return scene_; }
  double rotation_deg() const { return rotation_deg_; }

  // Constraint ids (one value per pose; larger is better).
  enum Constraint { kStroke, kJoint, kStrutStrut, kClass2, kFirstPeripheral };

 private:
  struct Pose {
    Eigen::Vector3d tip, axis;  // workpiece frame, rotated by the placement rotation
  };
  struct Eval;
  // Counts one exact pose query; more than scene.search.max_pose_queries within one public
  // call (report, decide, probe, screen, dense_check; the outermost when they nest) throws
  // Infeasible (exit 3) naming the limit and how to raise it; a stop request throws Cancelled.
  void count_query() const;
  StopToken stop_;
  struct QueryBudget {
    explicit QueryBudget(Checker& c);
    ~QueryBudget();
    Checker& checker;
  };
  long query_limit_ = 0;
  int budget_depth_ = 0;
  void evaluate(const Pose& pose, const Eigen::Vector3d& offset, unsigned mask, double* values, Eval* detail) const;
  // Exact class-1 clearance at one pose (infinity when the height field proves every part at
  // least `threshold` away; NaN: the safe distance); `who` names the closest part.
  double class1_value(const Pose& pose, std::string* who,
                      double threshold = std::numeric_limits<double>::quiet_NaN()) const;
  // The part's box swept by sweep_mm stays at least threshold_mm from the workpiece.
  bool class1_box_clear(Eigen::AlignedBox3d box, double sweep_mm, double threshold_mm) const;
  void compute_class1();

  // The path's intervals in a bounding-volume tree built on pose proximity (tip position
  // and tool axis), not on path order: a node holds a set of intervals, one of their poses as
  // its centre, and how far (tip distance, axis angle) any pose of its intervals, including
  // poses inside them, lies from that centre. A raster path's neighbouring rows share nodes,
  // so a node's travel bound is far smaller than that of a path stretch of as many poses.
  struct Node {
    long centre = 0;
    double tip_mm = 0, angle_rad = 0;  // largest distances of a member pose from the centre
    int left = -1, right = -1;         // children; a leaf has right = -1 and left = its interval
  };
  int build_tree(std::vector<long>& intervals, std::size_t lo, std::size_t hi);
  double node_travel(int kind, const Node& node) const;
  struct Witness {
    long pose;
    double t;
    int constraint;
    int id = 0;  // order of learning
  };
  void learn(const Witness& w);

  struct ScanSettings;
  bool scan(const Eigen::Vector3d& offset, ScanSettings& s);
  bool scan_best_first(unsigned mask, const Eigen::Vector3d& offset, ScanSettings& s);
  double report_need(int constraint, double best) const;
  // Slider-speed factor valid within `move_mm` of a pose whose values are v.
  double local_kappa(const double* v, double move_mm) const;
  unsigned all_constraints() const { return constraint_count_ >= 32 ? ~0u : (1u << constraint_count_) - 1; }
  // The workpiece block (with its pad) against the peripherals over the ball of placements.
  Decision decide_workpiece_block(const Eigen::Vector3d& offset, double radius_mm, Finding* witness) const;
  ScanSettings decision_settings(double radius_mm) const;
  // The value at or below which constraint c at a pose (values v) condemns the whole ball.
  double fail_threshold(int c, const double* v, const ScanSettings& s) const;
  bool check_exact(long i, double t, const double* v, unsigned mask, ScanSettings& s);
  bool scan_interval(long i, double t0, double t1, const double* v0, const double* v1, unsigned mask,
                     const Eigen::Vector3d& offset, ScanSettings& s, int depth);
  const double* cached_values(long i, const Eigen::Vector3d& offset, ScanSettings& s);
  Pose interpolate(long i, double t) const;
  Finding describe(int constraint, const Pose& pose, long index, double t, const Eigen::Vector3d& offset,
                   double value) const;
  // Workpiece and pad against peripheral k; a lower bound when that bound is at least `enough`.
  double workpiece_peripheral_value(const Eigen::Vector3d& offset, int k, Eigen::Vector2d* evasion,
                                    double enough = std::numeric_limits<double>::infinity()) const;

  const Scene& scene_;
  double rotation_deg_;
  int constraint_count_;
  int stride_;  // values per pose: the constraints, then the largest strut-to-rail angle
  std::vector<Eigen::Vector3d> tips_, axes_;
  // Per interval i (pose i to i+1): travel bounds.
  std::vector<double> cum_rigid_, cum_joint_, cum_angle_;
  // A Lipschitz constant a kappa + b, kappa being the slider-speed factor in force.
  struct Lipschitz {
    double a, b;
  };
  static double lipschitz(const Lipschitz& l, double kappa) { return l.a * kappa + l.b; }
  std::vector<Lipschitz> path_lipschitz_;  // per constraint: value change per unit of its travel
  std::vector<int> travel_kind_;           // per constraint: 0 rigid, 1 joint, 2 angle
  std::vector<Lipschitz> placement_lipschitz_;  // per constraint: value change per mm of placement
  std::vector<double> limit_;              // per constraint: the value it must reach
  std::vector<double> report_tolerance_;   // per constraint: precision of report() minima
  std::vector<interference::Shape> rigid_shapes_;  // tool parts, plate, then hinges (shared)
  std::vector<interference::Shape> strut_shapes_;  // one capsule per strut (its length)
  interference::Shape workpiece_shape_;
  interference::Shape workpiece_box_shape_;
  Eigen::Vector3d workpiece_box_half_;
  Eigen::Vector3d workpiece_box_centre_;
  struct Class1Part {
    std::size_t shape;
    double from_mm, to_mm, radius_mm;
    std::string name;
  };
  std::vector<Class1Part> class1_parts_;
  std::unique_ptr<interference::HeightField> height_field_;
  Finding class1_;
  CheckCounts counts_;
  // Per-scan cache of exact values by pose index.
  std::vector<double> cache_;
  std::vector<unsigned> cache_gen_;
  unsigned gen_ = 0;
  Eigen::Vector3d cache_offset_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  bool cache_complete_ = false;
  std::vector<Node> nodes_;  // nodes_[0] is the root (empty for a single-pose path)
  Eigen::Matrix<double, 6, Eigen::Dynamic> tree_keys_;  // while building: one key per interval
  double rot_factor_ = 1.0, min_strut_mm_ = 0.0;
  std::vector<Witness> learned_;  // interferences met so far, most recently useful first
};

}  // namespace machplan::placement
