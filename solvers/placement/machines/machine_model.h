// What a machine tells the placement checker: its constraints at one tool pose, and how fast
// each can change as the tool moves along the path or the workpiece moves on the table.
//
// The checker (check/checker.h) and the searches (search/search.h) see a machine only through
// this interface, so a new machine is a new model, not a change to them. Two models exist:
//
//   hexapod         the HexaM-type parallel machine (machines/hexam_model.h, models/hexam)
//   table_tilting   a 5-axis trunnion: X, Y, Z on the head, two rotary axes under the table
//                   (machines/trunnion_model.h, models/trunnion)
//
// The contract, which the certifier's proofs rest on:
//
//   * evaluate() gives, for one tool pose of the path (workpiece frame) and one placement, a
//     value per constraint (larger is better; margins in mm or radians, clearances in mm),
//     followed by `extras()` values of the model's own (state that fall() may use). A value
//     may be a lower bound instead of the exact one when it is at least 10 mm above the
//     constraint's limit (a far part is not measured exactly).
//   * fall(c, v, m) bounds how far constraint c can drop over a motion m: from any state whose
//     distances to the evaluated one are within m, the value is at least v[c] - fall. With v
//     null the bound must hold from every state (path intervals use that form); with v given it
//     may use the evaluated state's extras, but must then hold within m of that state.
//   * motion_between() bounds the motion between two poses of the path and everything the
//     machine passes through between them, as interpolate() describes the motion.
//
// A model is immutable once built and shared by every thread; each thread evaluates through
// its own PoseEvaluator, which owns its collision objects.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/motion/axis_planner.h"
#include "models/common/tooling.h"
#include "models/hexam/hexam.h"
#include "solvers/placement/machines/finding.h"

namespace machplan {
class Yaml;
}  // namespace machplan

namespace machplan::placement {

struct Scene;
struct WorkpieceSolid;

// A set of constraints, one bit each (at most 64 per machine and scene).
using Mask = std::uint64_t;
inline constexpr Mask bit(int c) { return Mask{1} << c; }

// A tool pose of the path in the workpiece frame, with the angles of the rotary axes that reach
// it on a table-tilting machine (0 on machines without rotary axes).
struct PathPose {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit, from the tip up into the spindle
  double a_rad = 0.0, c_rad = 0.0;
};

// The workpiece frame in the machine's table frame: p_table = R p_workpiece + offset.
struct Where {
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  double rotation_rad = 0.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  static Where of(const Placement& p);
  bool operator==(const Where& o) const { return offset == o.offset && rotation_rad == o.rotation_rad; }
};

// Upper bounds of how far things move between two states the certifier compares: two poses of
// the path and what lies between them, a tree node's centre and its members, or a placement
// and the others in a ball.
struct Motion {
  double tip_mm = 0;        // the tool tip, relative to the table
  double axis_rad = 0;      // the tool axis's turn, relative to the table
  double joints_rad = 0;    // the rotary axes' turns, summed (table-tilting machines)
  double workpiece_mm = 0;  // any point of the workpiece, its pad or fixture, relative to the table
  double pad_mm = 0;        // the pad's (fixture's) height
  // Along the path the tool moves relative to the workpiece as tip_mm and axis_rad say; when
  // the placement changes (a ball) the path moves with the workpiece and the tool stays put
  // relative to it.
  bool along_path = true;
};

// One constraint: a value per pose, larger is better, that must reach `limit`.
struct Constraint {
  std::string name;
  Kind kind = Kind::self;
  double limit = 0.0;
  double report_tolerance = 0.25;  // report() pins its smallest value to within this
  bool distance = true;            // a distance, else a margin
  bool signed_distance = false;    // a distance carried below 0 by the depth of an overlap
  double order_weight = 1.0;       // weight of a deficit when scans order their work
  // A travel margin (mm: sliders, linear axes) or a joint margin (rad: joint cones, rotary
  // axes) reported on their own beside the kinds.
  enum class Margin { none, travel, joint } margin = Margin::none;
  // Cheap to evaluate (kinematics only, no collision query): probes look at these first.
  bool cheap = false;
  // +1: the value never falls as the pad rises (with everything else held); -1: never rises;
  // 0: either. Screening a box tall in pad then looks at its top (or bottom) only.
  int pad_trend = 0;
  // With pad_trend +1, a rate the value keeps to: lowering the pad by d lowers it by at least
  // pad_rate d, except where it is below the limit at every pad. One look at a box's top then
  // condemns every pad far enough below it (0: no such rate).
  double pad_rate = 0.0;
};

// A part of the tool assembly that rides on the tool axis and keeps its shape whatever the
// rotation about that axis (class-1 checks); see models/common/tooling.h.
using AxialPart = ToolPart;

// Parts fixed to the spindle plate that turn with the workpiece's rotation relative to the
// plate (the hexapod's plate hinges: spheres at `points` in the plate frame, z = 0 on the
// plate's lower face `height_mm` above the tip). A ring of them covers every rotation.
struct PlateRing {
  double height_mm = 0.0;
  double sphere_radius_mm = 0.0;
  std::vector<Eigen::Vector3d> points;  // plate frame
  double radius_mm() const;             // largest distance of a point from the axis
};

// The machine's table, for the search region and the on-table check.
struct TableShape {
  bool round = false;
  Eigen::Vector2d half_mm = Eigen::Vector2d::Zero();  // rectangle: half sizes; round: radius, radius
  // Margin of a point in the table frame: distance to the edge, negative outside.
  double margin(const Eigen::Vector2d& p) const;
};

// Where the machine's axes are when the tool tip is at the workpiece origin with the rotary
// axes at zero: the work offset a process planner types into the control (G54).
struct WorkOffset {
  std::string frame;           // what the numbers are measured from
  Eigen::Vector3d xyz_mm = Eigen::Vector3d::Zero();
  double rotation_deg = 0.0;   // the workpiece's turn about the table's z
  std::string rotation_axis;   // how the control applies the rotation ("G68", "C")
};

// Axis positions along the path at one rotation, as functions of the workpiece's offset o (x,
// y, pad), in one of two forms:
//   * affine (a table-tilting machine): the linear axes at q_i(o) = M_i o + b_i (mm), the rotary
//     axes at rotary_rad[i], whatever o;
//   * rails (a hexapod, `rails` not empty; M, b, rotary_rad, speed and rapid empty or unused): six
//     sliders on the rails of models/hexam/hexam.h. At pose i plate joint k lies at
//     joints_mm[i][k] + o from its rail's foot (the machine's frame is the table's), and the
//     slider where hexam::slider_on_rail puts it: concave in o, not affine.
struct AxisPath {
  std::vector<std::string> names;            // the linear axes, then the rotary ones
  std::vector<Eigen::Matrix3d> M;            // per pose
  std::vector<Eigen::Vector3d> b;            // per pose
  std::vector<Eigen::Vector2d> rotary_rad;   // per pose: the two rotary axes
  Eigen::Matrix<double, 5, 1> speed;         // largest speed per axis: mm/s, rad/s
  Eigen::Matrix<double, 5, 1> rapid;         // rapid speed per axis
  std::vector<hexam::Strut> rails;           // rails: the struts, in slider order
  std::vector<std::array<Eigen::Vector3d, 6>> joints_mm;  // rails: per pose, plate joints from the feet
  std::vector<double> turn_rad;              // rails: per pose, the tool axis's turn from the pose before
  bool on_rails() const { return !rails.empty(); }
  std::vector<double> feed_mm_per_s;         // per pose: the feed of the step that ends there; 0: rapid
  std::vector<double> tip_step_mm;           // per pose: the tip's distance from the pose before
  // The programmed feed caps the combined speed of the axes (rotary degrees as mm), not the
  // tip's speed relative to the workpiece (engine/motion/axis_planner.h, "Feed").
  bool feed_on_axes = false;
  long flips = 0;                            // rotary flips along the path (see the model)
  long forced_flips = 0;                     // of which the machine's limits force
  std::vector<long> flip_poses;              // where (the pose after the flip)
  // The axes' limits for the 5-axis feed planner (engine/motion/axis_planner.h), when the
  // machine gives accelerations and jerks; else `dynamics_missing` says which axis lacks them,
  // at `dynamics_file`:`dynamics_line`.
  std::optional<motion::AxisLimits> limits;
  std::string dynamics_missing, dynamics_file;
  int dynamics_line = 0;
};

// Bounds of a constraint's value over a box of placements.
struct BoxRange {
  double lower = 0.0, upper = 0.0;
  // How much of the range each side of the box (x, y, pad) makes, where known (else 0).
  double spread_mm[3] = {0.0, 0.0, 0.0};
};

class PoseEvaluator {
 public:
  virtual ~PoseEvaluator() = default;
  // Values of the constraints in `mask` and the model's extras into values[0 .. stride). A
  // constraint outside the mask may be left at any value; one in it never below its true
  // value (see the contract above).
  virtual void evaluate(const PathPose& pose, const Where& where, Mask mask, double* values) = 0;
  // Constraint c at one pose over a box of placements at one rotation: the workpiece moved by
  // up to `half` along each axis of the table (x, y, pad) from `where`: the value evaluate()
  // gives at any placement in the box is at most `upper`, and the constraint's true value at
  // least `lower` (evaluate() may give less only where it is 10 mm above the limit; see the
  // contract above). A machine moves rigidly with the workpiece at one rotation, so the
  // bounds can follow the geometry's shape (convex distances, concave strokes) where fall()
  // knows only how far things move. nullopt when the model has no such bounds for c at this
  // pose (fall() is used instead).
  virtual std::optional<BoxRange> box_range(int c, const PathPose& pose, const Where& where, const Eigen::Vector3d& half) {
    return std::nullopt;
  }
  // The parts or the limit behind constraint c at a pose, and the paper search's evasion.
  virtual void describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) = 0;
  // Placement-only constraint k (the workpiece with its pad against the peripherals): its
  // value, or a lower bound when that is at least `enough`.
  virtual double placement_value(int k, const Where& where, double enough, Finding* f) = 0;
};

class MachineModel {
 public:
  virtual ~MachineModel() = default;

  virtual std::string kind() const = 0;  // "hexapod", "table_tilting"
  virtual std::string name() const = 0;  // the machine file's name
  const std::vector<Constraint>& constraints() const { return constraints_; }
  int count() const { return static_cast<int>(constraints_.size()); }
  int extras() const { return extras_; }
  int stride() const { return count() + extras_; }
  Mask all_mask() const { return count() >= 64 ? ~Mask{0} : bit(count()) - 1; }
  // Placement-only constraints (workpiece and pad against the peripherals): all of kind
  // workpiece_peripheral, limit the safe distance.
  int placement_count() const { return placement_count_; }

  virtual std::unique_ptr<PoseEvaluator> evaluator() const = 0;
  // The workpiece as the model checks it (scene/internal/workpiece.h).
  virtual const WorkpieceSolid& workpiece() const = 0;
  virtual double fall(int c, const double* v, const Motion& m) const = 0;

  // The path as this machine runs it: fills the rotary angles of every pose (an inverse
  // kinematics branch chosen along the path), or leaves them 0. Placement-independent. A pose
  // the machine cannot take (a tilt beyond its reach) is returned with the reason.
  virtual std::optional<std::pair<long, std::string>> prepare(std::vector<PathPose>& poses) const { return std::nullopt; }
  // The pose at fraction t in [0, 1] of the interval from a to b.
  virtual PathPose interpolate(const PathPose& a, const PathPose& b, double t) const = 0;
  // Motion from a to b, and over the interval between them (interpolate()).
  virtual Motion motion_between(const PathPose& a, const PathPose& b) const = 0;
  // Weights of the pose-tree keys: an axis turn of 1 rad weighs `axis_weight_mm`, a rotary
  // turn of 1 rad `joint_weight_mm`.
  virtual double axis_weight_mm() const = 0;
  virtual double joint_weight_mm() const { return 0.0; }

  // Class-1 geometry: the tool assembly's parts of revolution, and the plate ring if any.
  virtual std::vector<AxialPart> class1_parts() const = 0;
  virtual std::optional<PlateRing> plate_ring() const { return std::nullopt; }
  virtual Eigen::Matrix3d plate_rotation(const Eigen::Vector3d& axis) const;
  // Farthest any point of the tool assembly lies from the tip.
  virtual double assembly_reach_mm() const = 0;
  // How far any point of the tool assembly (class-1 parts, plate ring) can move, relative to
  // the workpiece, over a motion.
  virtual double assembly_motion_mm(const Motion& m) const = 0;
  // The whole tool assembly, flutes included (tool_support checks).
  virtual std::vector<AxialPart> tool_parts() const = 0;

  virtual TableShape table() const = 0;
  virtual WorkOffset work_offset(const Placement& p, const Eigen::Vector3d& origin_in_workpiece) const = 0;
  // Whether axis_path() gives an affine path (the travel objective needs it), or any (the time
  // objective).
  virtual bool affine_axes() const { return false; }
  virtual bool has_axis_path() const { return affine_axes(); }
  // Axis positions along the path at a rotation (AxisPath: affine on a table-tilting machine,
  // rails on a hexapod); nullopt for a machine that gives none.
  virtual std::optional<AxisPath> axis_path(const std::vector<PathPose>& poses, const std::vector<double>& feeds,
                                            double rotation_rad) const {
    return std::nullopt;
  }
  // How high the spindle nose stands at a pose and placement with a tool `gauge_mm` from tip
  // to nose, measured as a tool change position is (scene.h ToolChange: up the machine's
  // spindle direction, in the table frame with the rotary axes at zero), and how much it rises
  // for each mm the tool is drawn back along its axis. Default: a machine without rotary axes,
  // whose table frame is fixed.
  struct NoseHeight {
    double height_mm = 0.0, rise_per_mm = 1.0;
  };
  virtual NoseHeight nose_height(const PathPose& pose, const Where& where, double gauge_mm) const {
    const Eigen::Vector3d axis = where.R * pose.axis;
    return {(where.R * pose.tip + where.offset).z() + gauge_mm * axis.z(), axis.z()};
  }
  // A move the control makes in machine coordinates (to and from a tool change: every axis
  // interpolated linearly, no tool centre point control), from `a` to `b` (rotary angles
  // filled in), as poses close enough that interpolate() between neighbours follows it.
  // Default: a machine whose interpolation is already linear in its axes.
  virtual std::vector<PathPose> axis_move(const PathPose& a, const PathPose& b, const Where& where, double gauge_mm) const {
    return {a, b};
  }
  // The machine's rotary table turns the workpiece about the table's z with nothing else
  // turning (a round, unlimited C table and nothing fixed on it): a rotation is then the same
  // setup as a position, and rotation searches can be skipped.
  virtual bool rotation_is_position() const { return false; }

 protected:
  std::vector<Constraint> constraints_;
  int extras_ = 0;
  int placement_count_ = 0;
};

// Builds the model of the machine file the scene names (scene.machine.source, read as `root`)
// with one tool of the job, the scene's peripherals and workpiece (a hexapod file has no `kind`, or
// `kind: hexapod`; a trunnion file says `kind: table_tilting`). Throws InputError naming the
// file and key, or, at `origin` (file and line), the tool that does not fit the machine (its
// gauge length beyond what the spindle's stroke can bring down to the table).
struct ToolingOrigin {
  std::string tool;  // "T16", "the tooling"
  std::string file;
  int line = 0;
};
std::shared_ptr<const MachineModel> make_machine_model(const Scene& scene, const Yaml& root, const Tooling& tooling,
                                                       const ToolingOrigin& origin);

}  // namespace machplan::placement
