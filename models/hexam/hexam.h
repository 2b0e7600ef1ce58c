// A HexaM-type parallel-kinematic machine: six fixed-length struts whose lower ends hold the
// spindle plate and whose upper ends ride on sliders along six straight rails.
//
// Toyoda's HexaM publishes no dimensions, so this model is parametric and the bundled machine
// (datasets/hexam-paper/machine.yaml) is a reconstruction; its README says which numbers are
// assumed.
//
// Frames and conventions
//   * Table frame: origin at the table centre on the table top, z up. Everything here is in it.
//   * A tool pose is (tip, axis): the tool tip point and the unit tool axis pointing from the
//     tip up into the spindle.
//   * The spindle plate frame has its origin on the tool axis at `gauge_mm` above the tip and
//     its z axis along the tool axis. The plate does not spin about the tool axis: its
//     orientation is the smallest rotation taking +z to the axis (a five-axis machine leaves
//     that sixth freedom to the machine, and this is the choice the controller makes).
//
// Kinematics (strut i: rail foot B_i, unit rail direction u_i, strut length L_i, plate joint
// p_i in the plate frame):
//     P_i = c + R p_i                       plate joint in the table frame
//     S_i = B_i + s_i u_i                   slider joint
//     |S_i - P_i| = L_i                     strut length is fixed
//   so with d = P_i - B_i:  s_i = u_i.d + sqrt((u_i.d)^2 - |d|^2 + L_i^2)   (upper branch).
//   A negative discriminant means the pose is out of reach.
//
// Self-interference and limits checked per pose
//   * slider stroke:   stroke_min_mm <= s_i <= stroke_max_mm
//   * joint cones:     the strut direction stays within `joint_half_angle_deg` of its direction
//                      at the home pose, seen from the slider (fixed frame) and from the plate
//                      (rotating frame).
//   * strut clearance: strut capsules keep `safe distance` from each other (strut_clearance()
//                      below) and from the spindle head and plate (the placement checker
//                      measures those with FCL).
//
// Motion bound used to certify whole intervals: if the plate joints move at most dP along an
// interval, a slider moves at most kappa dP, kappa = 1 / cos(alpha_max), where alpha_max bounds
// the angle between a strut and its rail whenever the slider joint is inside its cone.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "models/common/tooling.h"

namespace machplan {

class Yaml;

namespace hexam {

struct Strut {
  Eigen::Vector3d rail_foot_mm;     // B_i, table frame
  Eigen::Vector3d rail_direction;   // u_i, unit
  Eigen::Vector3d plate_joint_mm;   // p_i, plate frame
  double length_mm = 0.0;           // L_i
};

// The tool assembly's parts (models/common/tooling.h): tool, chuck, then the spindle head.
using ToolPart = ::machplan::ToolPart;

struct Machine {
  std::string name;
  std::string source;  // file it came from
  std::array<Strut, 6> struts;
  double stroke_min_mm = 0.0, stroke_max_mm = 0.0;
  double slider_joint_half_angle_rad = 0.0;  // cone of the slider-side joints
  double plate_joint_half_angle_rad = 0.0;   // cone of the plate hinges (they also see the tilt)
  double strut_radius_mm = 0.0;     // struts are capsules of this radius
  double hinge_radius_mm = 0.0;     // plate hinges are spheres of this radius at p_i
  double plate_radius_mm = 0.0;     // spindle plate: a disc of this radius ...
  double plate_thickness_mm = 0.0;  // ... and thickness, its lower face at gauge_mm
  double gauge_mm = 0.0;            // tip to plate lower face along the axis (tool + chuck + head)
  std::vector<ToolPart> tool_parts; // tool, chuck, spindle head (plate is added by the checker)
  Eigen::Vector3d home_tip_mm = Eigen::Vector3d::Zero();  // home pose: axis +z at this tip
  Eigen::Vector2d table_size_mm = Eigen::Vector2d::Zero();  // table top, centred at the origin
  double max_tilt_rad = 0.0;        // largest tool tilt from +z the controller accepts
  // The sliders' limits for the feed planner (`sliders:` feed_mm_per_min, rapid_mm_per_min,
  // accel_mm_per_s2 and jerk_mm_per_s3, all or none): 0 when the file gives none; then
  // `sliders_line` is the line of the `sliders:` block.
  double slider_feed_mm_per_s = 0.0, slider_rapid_mm_per_s = 0.0;
  double slider_accel_mm_per_s2 = 0.0, slider_jerk_mm_per_s3 = 0.0;
  int sliders_line = 0;
  bool slider_dynamics() const { return slider_jerk_mm_per_s3 > 0.0; }

  // Derived at load time.
  std::array<Eigen::Vector3d, 6> home_dir_base;   // strut direction (slider -> plate) at home
  std::array<Eigen::Vector3d, 6> home_dir_plate;  // same, in the plate frame
  double kappa = 1.0;          // slider speed / plate-joint speed bound (see header)
  double alpha_max_rad = 0.0;  // largest strut-to-rail angle inside the joint cones
  double plate_joint_reach_mm = 0.0;  // largest distance from the tip to a plate joint
  double rigid_reach_mm = 0.0;        // largest distance from the tip to any rigid part point

  // Validates the numbers and computes the derived fields; throws InputError naming the key.
  void finalize(const Yaml* where = nullptr);
};

Machine load_machine(const std::string& path);
Machine machine_from_yaml(const Yaml& root);

// Smallest rotation taking +z to `axis` (unit). Undefined for axis = -z (never reachable).
Eigen::Matrix3d plate_rotation(const Eigen::Vector3d& axis);

// Angle bound factor: the plate's rotation between two axes a1, a2 (angle theta apart, both
// tilted at most `tilt` from +z) is at most theta * plate_rotation_factor(tilt).
double plate_rotation_factor(double max_tilt_rad);

struct StrutState {
  Eigen::Vector3d slider_mm;  // S_i
  Eigen::Vector3d plate_mm;   // P_i
  double s_mm = 0.0;          // slider position along its rail
};

struct IkResult {
  bool reachable = true;        // every strut closes (discriminant >= 0)
  double reach_deficit_mm = 0;  // when not reachable: how far the worst strut is too short
  std::array<StrutState, 6> struts;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d plate_centre_mm = Eigen::Vector3d::Zero();
};

IkResult inverse_kinematics(const Machine& m, const Eigen::Vector3d& tip_mm, const Eigen::Vector3d& axis);

// Where a strut's slider stands on its rail when its plate joint lies at `d_mm` from the rail's
// foot (table frame): s = u.d + sqrt(L^2 - |d|^2 + (u.d)^2), the upper branch. When the joint lies farther from the rail line than the strut is long there is no
// such s: `reachable` is false, `s_mm` is u.d and `deficit_mm` says how much the strut is short.
struct RailPosition {
  double s_mm = 0.0;
  bool reachable = true;
  double deficit_mm = 0.0;
};
RailPosition slider_on_rail(const Strut& st, const Eigen::Vector3d& d_mm);

// Smallest distance between two struts' capsules at one pose (their axes' distance less two
// radii, negative when they overlap); `a` and `b` (optional) receive the pair. Meaningless when
// the pose is out of reach.
double strut_clearance(const Machine& m, const IkResult& ik, int* a = nullptr, int* b = nullptr);

// Limit margins of one pose: positive is inside the limit.
struct LimitMargins {
  double stroke_mm = 0;      // smallest distance of a slider to a stroke end
  double joint_rad = 0;      // smallest angle left in any joint cone
  int stroke_strut = -1, joint_strut = -1;
  bool joint_at_plate = false;
};
// Without `joints`, only the stroke margin is computed (joint_rad stays infinite).
LimitMargins limit_margins(const Machine& m, const IkResult& ik, bool joints = true);

// Largest angle between a strut and its rail at one pose (radians; alpha_max_rad when the
// pose is out of reach). A slider moves at most 1 / cos(angle) times as fast as its plate
// joint, so near a pose whose struts stand close to their rails the bound kappa is loose.
double strut_rail_angle(const Machine& m, const IkResult& ik);
// The slider-speed factor for struts at most `angle_rad` from their rails (kappa at most).
double slider_rate_bound(const Machine& m, double angle_rad);

// Forward kinematics: plate pose (R, c) from slider positions, by Newton iteration from a
// starting guess. Returns nullopt when it does not converge.
struct PlatePose {
  Eigen::Matrix3d R;
  Eigen::Vector3d centre_mm;
};
std::optional<PlatePose> forward_kinematics(const Machine& m, const std::array<double, 6>& s_mm,
                                            const PlatePose& guess, int max_iterations = 50);

}  // namespace hexam
}  // namespace machplan

namespace machplan::hexam {

using Tooling = ::machplan::Tooling;

// Puts the tool and chuck under the spindle head, sets the gauge length and finalizes.
void attach_tooling(Machine& m, const Tooling& t);

}  // namespace machplan::hexam
