#include "solvers/placement/machines/hexam_model.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "engine/common/error.h"
#include "engine/interference/collision.h"
#include "solvers/placement/machines/internal/bounds.h"
#include "solvers/placement/scene/internal/workpiece.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

namespace {

enum : int { kStroke = 0, kStrokeHigh = 1, kJoint = 2, kStrutStrut = 3, kClass2 = 4, kFirstPeripheral = 5 };

// The paper's evasion from a peripheral: the horizontal normal of its side that faces `point`
// (a box), or the direction from its centre to the point (a mesh).
Eigen::Vector2d evasion_from(const Peripheral& per, const Eigen::Vector3d& point) {
  if (per.is_box) {
    const Eigen::Vector3d q = per.T_table_peripheral.inverse() * point;
    const int axis = std::abs(q.x()) / per.box_half_mm.x() >= std::abs(q.y()) / per.box_half_mm.y() ? 0 : 1;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[axis] = q[axis] >= 0 ? 1.0 : -1.0;
    return (per.T_table_peripheral.linear() * n).head<2>().normalized();
  }
  const Eigen::Vector2d dir = point.head<2>() - per.bounds.center().head<2>();
  return dir.norm() > 1e-9 ? Eigen::Vector2d(dir.normalized()) : Eigen::Vector2d::Zero();
}

// The point of a part (radius r around the segment a b, a capsule or a flat cylinder) nearest
// to q.
template <class Part>
Eigen::Vector3d nearest_on(const Part& p, const Eigen::Vector3d& q) {
  const Eigen::Vector3d d = p.b - p.a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 1e-18 ? std::clamp((q - p.a).dot(d) / len2, 0.0, 1.0) : 0.0;
  const Eigen::Vector3d on_axis = p.a + t * d;
  if (p.capsule) {
    const Eigen::Vector3d v = q - on_axis;
    return v.norm() <= p.r ? q : Eigen::Vector3d(on_axis + v * (p.r / v.norm()));
  }
  // Flat cylinder: along the axis within its ends, across it within the radius.
  const Eigen::Vector3d w = len2 > 1e-18 ? Eigen::Vector3d(d / std::sqrt(len2)) : Eigen::Vector3d::UnitZ();
  Eigen::Vector3d v = (q - p.a) - (q - p.a).dot(w) * w;
  if (v.norm() > p.r) v *= p.r / v.norm();
  return on_axis + v;
}

// Corner j (0 .. 7) of the box of moves within `half` of its centre.
Eigen::Vector3d corner(const Eigen::Vector3d& half, int j) {
  return {j & 1 ? half.x() : -half.x(), j & 2 ? half.y() : -half.y(), j & 4 ? half.z() : -half.z()};
}

// How much of a range over the box of moves each of its sides makes, for the direction (or
// gradient) g the range changes along.
void set_spread(BoxRange& r, const Eigen::Vector3d& g, const Eigen::Vector3d& half) {
  for (int k = 0; k < 3; ++k) r.spread_mm[k] = std::abs(g[k]) * half[k];
}

// A box peripheral and the moves of the tool assembly within a box of placements (by up to
// `half` along each table axis: the assembly moves rigidly with the workpiece at one rotation).
//   Below: any unit direction g separates. A part's lowest point along g less the box's highest
//   bounds their distance, and a move d changes that by g.d.
//   Above: the distance from any point of a part to the box is convex in the move, so its
//   largest over the moves is at a corner; the part is never farther than that.
// Both hold for any g and any point of the part; they are tight for the direction between the
// nearest points and the part's point nearest the box.
struct MovedNearBox {
  // The bounds are drawn from the geometry itself; measured distances (GJK) may lie above the
  // true ones by their tolerance, far less than this.
  static constexpr double kSlack = 1e-4;
  MovedNearBox(const Peripheral& per, const Eigen::Vector3d& h)
      : to_local(per.T_table_peripheral.inverse()), R(per.T_table_peripheral.linear()),
        centre(per.T_table_peripheral.translation()), box_half(per.box_half_mm), half(h), reach(h.norm()) {}

  // The largest signed distance from q moved to a corner of the moves.
  double corners_max(const Eigen::Vector3d& q) const {
    double worst = -kInf;
    for (int j = 0; j < 8; ++j) worst = std::max(worst, box_sdf(to_local * (q + corner(half, j)), box_half));
    return worst;
  }
  // What a part's bound (its gap) shows of its value anywhere in the moves: a positive gap
  // less the reach; nothing from a gap of 0 (the part may overlap the box, and a value is
  // carried below 0 by the depth).
  template <class Part>
  double floor(const Part& p) const {
    return p.lower > 0.0 ? p.lower - reach : -kInf;
  }
  // How far along g the moves reach.
  double move_along(const Eigen::Vector3d& g) const { return g.cwiseAbs().dot(half); }
  // At the centre: the part's lowest point along g (into `at`) less the box's highest.
  template <class Part>
  double separation(const Part& p, const Eigen::Vector3d& g, Eigen::Vector3d* at) const {
    const Eigen::Vector3d& e = g.dot(p.a) <= g.dot(p.b) ? p.a : p.b;
    Eigen::Vector3d out = p.capsule ? Eigen::Vector3d(g) : Eigen::Vector3d::Zero();
    if (!p.capsule) {
      const Eigen::Vector3d w = (p.b - p.a).normalized();
      const Eigen::Vector3d side = g - g.dot(w) * w;
      if (side.norm() > 1e-12) out = side.normalized();
    }
    *at = e - p.r * out;
    return g.dot(*at) - (g.dot(centre) + (R.transpose() * g).cwiseAbs().dot(box_half));
  }
  // From the box's point nearest q to q (zero inside the box).
  Eigen::Vector3d away(const Eigen::Vector3d& q) const {
    const Eigen::Vector3d l = to_local * q;
    return R * (l - l.cwiseMax(-box_half).cwiseMin(box_half));
  }
  Eigen::Isometry3d to_local;
  Eigen::Matrix3d R;
  Eigen::Vector3d centre, box_half, half;
  double reach;
};

class HexapodModel;

class HexapodEvaluator final : public PoseEvaluator {
 public:
  explicit HexapodEvaluator(const HexapodModel& model);
  void evaluate(const PathPose& pose, const Where& where, Mask mask, double* v) override;
  void describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) override;
  double placement_value(int k, const Where& where, double enough, Finding* f) override;
  std::optional<BoxRange> box_range(int c, const PathPose& pose, const Where& where, const Eigen::Vector3d& half) override;

 private:
  // What evaluate() found besides the values, for describe().
  struct Detail {
    hexam::IkResult ik;
    hexam::LimitMargins limits;
    int strut_a = -1, strut_b = -1, class2_strut = -1, support_part = -1, low_strut = -1, high_strut = -1;
    std::vector<std::string> periph_part;
  };
  void run(const PathPose& pose, const Where& where, Mask mask, double* v, Detail* d);
  double class2(const hexam::IkResult& ik, const Where& where, Detail* d);
  // The tool assembly's parts near a peripheral, and what measuring them found (box_range()
  // bounds from them).
  struct Near {
    static constexpr std::size_t kParts = 16;
    struct Part {
      double lower;
      std::size_t shape;
      int name;  // tool part index, -1 the plate, -2 - k hinge k
      Eigen::Vector3d a, b;  // the solid: radius r around the segment a b, capsule or flat cylinder
      double r;
      bool capsule;
      // Set when measured (no initializers: a pose's evaluation fills few of the 16).
      bool measured;
      double exact;
      Eigen::Vector3d on_part, on_peripheral;
    };
    std::array<Part, kParts> parts;
    std::size_t count = 0;  // 0: far, the value is the assembly's bound
    int best = -1;          // the part whose measured distance is the value
    bool deep = false;      // the value is the depth of `ball`
    DepthBall ball;
  };
  double assembly_to_peripheral(const Peripheral& per, const interference::Shape& shape, const hexam::IkResult& ik,
                                const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, std::string* part);
  // The value from parts assembly_parts() found (n.count > 0): depths, else exact distances.
  double measure_assembly(const Peripheral& per, const interference::Shape& shape, const hexam::IkResult& ik,
                          const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, Near& n, std::string* part);
  std::optional<BoxRange> assembly_box_range(const Peripheral& per, const interference::Shape& shape,
                                             const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                                             const Eigen::Vector3d& axis, const Eigen::Vector3d& half);
  // Without an exact distance: the range when it decides, or when measuring could not.
  std::optional<BoxRange> assembly_range_unmeasured(const MovedNearBox& box, const Near& n) const;
  BoxRange assembly_range_measured(const MovedNearBox& box, const Peripheral& per, const interference::Shape& shape,
                                   const hexam::IkResult& ik, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis,
                                   Near& n);
  std::optional<BoxRange> stroke_box_range(const hexam::IkResult& ik, const Eigen::Vector3d& half);
  std::size_t assembly_parts(const Peripheral& per, const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                             const Eigen::Vector3d& axis, std::array<Near::Part, Near::kParts>& parts,
                             double* assembly_lb) const;
  double struts_to_peripheral(const Peripheral& per, const interference::Shape& shape, const hexam::IkResult& ik,
                              std::string* part);
  double gap(const Peripheral& per, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, bool cylinder) const;

  const HexapodModel& model_;
  // This thread's own collision objects.
  std::vector<interference::Shape> rigid_;     // tool parts, plate, then a hinge sphere
  std::vector<interference::Shape> struts_;    // one capsule per strut
  std::vector<interference::Shape> periph_;    // per peripheral
  std::vector<interference::Shape> tool_;      // tool parts (tool_support)
  interference::Shape workpiece_;
};

class HexapodModel final : public MachineModel {
 public:
  HexapodModel(const hexam::Machine& m, const Scene& scene)
      : m_(m), c_(scene.safe_distance_mm), peripherals_(scene.peripherals), wp_(workpiece_solid(scene)) {
    rot_factor_ = hexam::plate_rotation_factor(m.max_tilt_rad);
    L_min_ = kInf;
    for (const auto& s : m.struts) L_min_ = std::min(L_min_, s.length_mm);
    using M = Constraint::Margin;
    constraints_ = {{"slider stroke (lower end)", Kind::self, 0.0, 0.25, false, false, 1.0, M::travel, true},
                    {"slider stroke (upper end)", Kind::self, 0.0, 0.25, false, false, 1.0, M::travel, true},
                    {"joint cones", Kind::self, 0.0, 0.005, false, false, 100.0, M::joint, true},
                    {"strut clearance", Kind::self, c_, 0.25, true, false, 1.0, M::none, true},
                    {"struts / workpiece", Kind::workpiece_class2, c_, 0.25, true, false, 1.0, M::none}};
    for (const auto& p : peripherals_) {
      // Against a box the overlaps are carried below 0 by their depth (see evaluate()).
      constraints_.push_back({"tool assembly / " + p.name, Kind::machine_peripheral, c_, 0.25, true, p.is_box, 1.0, M::none});
      constraints_.push_back({"struts / " + p.name, Kind::machine_peripheral, c_, 0.25, true, p.is_box, 1.0, M::none});
    }
    support_ = count();
    constraints_.push_back({"tool / support", Kind::tool_support, c_, 0.25, true, false, 1.0, M::none});
    // On vertical rails a slider rises exactly as much as the plate, and whether a strut reaches
    // its rail does not depend on the height: the lower stroke margin never falls as the pad
    // rises, the upper one never rises.
    bool vertical = true;
    for (const auto& st : m.struts) vertical = vertical && st.rail_direction == Eigen::Vector3d::UnitZ();
    // More: a slider on a vertical rail follows the plate one to one, so the lower margin falls
    // exactly as much as the pad; where a strut cannot reach its rail at all, it cannot at any
    // height (the reach is horizontal), and the margin is negative at every pad.
    if (vertical) {
      constraints_[kStroke].pad_trend = 1, constraints_[kStrokeHigh].pad_trend = -1;
      constraints_[kStroke].pad_rate = 1.0;
    }
    // What carries the workpiece (the pad over its footprint and the table below it) only
    // shrinks as the pad rises: the tool's clearance to it never falls.
    constraints_[support_].pad_trend = 1;
    extras_ = 1;  // the largest strut-to-rail angle
    placement_count_ = static_cast<int>(peripherals_.size());
    MACHPLAN_ASSERT(count() <= 64, "too many constraints: {}", count());
  }

  std::string kind() const override { return "hexapod"; }
  std::string name() const override { return m_.name; }
  std::unique_ptr<PoseEvaluator> evaluator() const override { return std::make_unique<HexapodEvaluator>(*this); }

  double fall(int c, const double* v, const Motion& mo) const override {
    const double th = mo.axis_rad * rot_factor_;
    const double joint = mo.tip_mm + th * m_.plate_joint_reach_mm;
    const double k = v ? local_kappa(v, joint) : m_.kappa;
    switch (c) {
      case kStroke:
      case kStrokeHigh: return k * joint;
      case kJoint: return (k + 1) * joint / L_min_ + th;
      case kStrutStrut: return 2 * k * joint;
      case kClass2: return k * joint + mo.workpiece_mm;
      default: break;
    }
    const double rigid = mo.tip_mm + th * m_.rigid_reach_mm;
    // The tool against the pad: it moves relative to the workpiece only along the path.
    if (c == support_) return (mo.along_path ? rigid : 0.0) + mo.pad_mm;
    return (c - kFirstPeripheral) % 2 == 0 ? rigid : k * joint;
  }

  std::optional<std::pair<long, std::string>> prepare(std::vector<PathPose>& poses) const override {
    for (std::size_t i = 0; i < poses.size(); ++i)
      if (poses[i].axis.z() <= std::cos(m_.max_tilt_rad) - 1e-12)
        return std::make_pair(static_cast<long>(i),
                              fmt::format("tool axis tilts {:.1f} deg from +z; this machine accepts at most {:.1f} deg",
                                          std::acos(std::clamp(poses[i].axis.z(), -1.0, 1.0)) / kDeg, m_.max_tilt_rad / kDeg));
    return std::nullopt;
  }
  PathPose interpolate(const PathPose& a, const PathPose& b, double t) const override {
    if (t <= 0) return a;
    if (t >= 1) return b;
    return {(1 - t) * a.tip + t * b.tip, slerp_axis(a.axis, b.axis, t)};
  }
  Motion motion_between(const PathPose& a, const PathPose& b) const override {
    return {(b.tip - a.tip).norm(), angle_between(a.axis, b.axis), 0.0, 0.0, 0.0, true};
  }
  double axis_weight_mm() const override { return rot_factor_ * m_.rigid_reach_mm; }

  std::vector<AxialPart> class1_parts() const override {
    std::vector<AxialPart> parts;
    for (const auto& p : m_.tool_parts)
      if (p.cls == ToolPart::Class::class1) parts.push_back(p);
    parts.push_back({"spindle plate", m_.gauge_mm, m_.gauge_mm + m_.plate_thickness_mm, m_.plate_radius_mm, false,
                     ToolPart::Class::class1});
    return parts;
  }
  std::optional<PlateRing> plate_ring() const override {
    PlateRing ring;
    ring.height_mm = m_.gauge_mm;
    ring.sphere_radius_mm = m_.hinge_radius_mm;
    for (const auto& s : m_.struts) ring.points.push_back(s.plate_joint_mm);
    return ring;
  }
  Eigen::Matrix3d plate_rotation(const Eigen::Vector3d& axis) const override { return hexam::plate_rotation(axis); }
  double assembly_reach_mm() const override { return m_.rigid_reach_mm; }
  double assembly_motion_mm(const Motion& mo) const override {
    return mo.tip_mm + mo.axis_rad * rot_factor_ * m_.rigid_reach_mm;
  }
  std::vector<AxialPart> tool_parts() const override { return m_.tool_parts; }

  TableShape table() const override { return {false, m_.table_size_mm / 2}; }
  WorkOffset work_offset(const Placement& p, const Eigen::Vector3d& origin_w) const override {
    const Where w = Where::of(p);
    return {"the table centre on the table top", w.R * origin_w + w.offset, p.rotation_deg, "G68"};
  }

  double local_kappa(const double* v, double move_mm) const {
    // Moving the plate joints by at most `move_mm` (along the path, or by moving the
    // workpiece) turns a strut by at most (kappa + 1) move / L, so the struts' angles to their
    // rails at the pose bound the slider-speed factor over that move, often far below the
    // machine-wide kappa.
    return hexam::slider_rate_bound(m_, v[count()] + (m_.kappa + 1) * move_mm / L_min_);
  }

  bool has_axis_path() const override { return true; }
  std::optional<AxisPath> axis_path(const std::vector<PathPose>& poses, const std::vector<double>& feeds,
                                    double rotation_rad) const override;

  const hexam::Machine& machine() const { return m_; }
  double safe() const { return c_; }
  int support() const { return support_; }
  const std::vector<Peripheral>& peripherals() const { return peripherals_; }
  const WorkpieceSolid& workpiece() const override { return wp_; }

 private:
  hexam::Machine m_;
  double c_;
  std::vector<Peripheral> peripherals_;
  WorkpieceSolid wp_;
  double rot_factor_ = 1.0, L_min_ = 0.0;
  int support_ = 0;
};

std::optional<AxisPath> HexapodModel::axis_path(const std::vector<PathPose>& poses, const std::vector<double>& feeds,
                                                double rotation_rad) const {
  AxisPath ap;
  for (int k = 0; k < 6; ++k) ap.names.push_back(fmt::format("slider {}", k + 1));
  ap.speed.setZero();
  ap.rapid.setZero();
  ap.rails.assign(m_.struts.begin(), m_.struts.end());
  if (m_.slider_dynamics()) {
    motion::AxisLimits l;
    l.names = ap.names;
    l.rotary_axes = 0;
    l.velocity.setConstant(m_.slider_feed_mm_per_s);
    l.rapid_velocity.setConstant(m_.slider_rapid_mm_per_s);
    l.acceleration.setConstant(m_.slider_accel_mm_per_s2);
    l.jerk.setConstant(m_.slider_jerk_mm_per_s3);
    ap.limits = l;
  } else {
    ap.dynamics_missing = "the sliders give no feed_mm_per_min, rapid_mm_per_min, accel_mm_per_s2 and jerk_mm_per_s3";
  }
  ap.dynamics_file = m_.source;
  ap.dynamics_line = m_.sliders_line;
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(rotation_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const hexam::IkResult ik = hexam::inverse_kinematics(m_, Rz * poses[i].tip, Rz * poses[i].axis);
    std::array<Eigen::Vector3d, 6> joints;
    for (int k = 0; k < 6; ++k) joints[k] = ik.struts[k].plate_mm - m_.struts[k].rail_foot_mm;
    ap.joints_mm.push_back(joints);
    ap.feed_mm_per_s.push_back(i < feeds.size() ? feeds[i] / 60.0 : 0.0);
    ap.tip_step_mm.push_back(i > 0 ? (poses[i].tip - poses[i - 1].tip).norm() : 0.0);
    ap.turn_rad.push_back(i > 0 ? angle_between(poses[i - 1].axis, poses[i].axis) : 0.0);
  }
  return ap;
}

HexapodEvaluator::HexapodEvaluator(const HexapodModel& model)
    : model_(model), workpiece_(interference::Shape::sphere(1.0)) {
  const hexam::Machine& m = model.machine();
  for (const auto& st : m.struts) struts_.push_back(interference::Shape::capsule(m.strut_radius_mm, st.length_mm));
  rigid_ = axial_shapes(m.tool_parts);
  rigid_.push_back(interference::Shape::cylinder(m.plate_radius_mm, m.plate_thickness_mm));
  rigid_.push_back(interference::Shape::sphere(m.hinge_radius_mm));
  tool_ = axial_shapes(m.tool_parts);
  for (const auto& p : model.peripherals()) periph_.push_back(p.shape.copy());
  workpiece_ = model.workpiece().mesh();
}

double HexapodEvaluator::gap(const Peripheral& per, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r,
                             bool cylinder) const {
  // Lower bound of the distance from a segment grown by r to the peripheral: box gaps, taken in
  // the peripheral's own frame when it is a box (tight for a turned box).
  if (!per.is_box) return aabb_distance(cylinder ? cylinder_box(a, b, r) : segment_box(a, b, r), per.bounds);
  const Eigen::Isometry3d to_local = per.T_table_peripheral.inverse();
  return box_gap(to_local * a, to_local * b, r, per.box_half_mm, cylinder);
}

void HexapodEvaluator::evaluate(const PathPose& pose, const Where& where, Mask mask, double* v) {
  run(pose, where, mask, v, nullptr);
}

double HexapodEvaluator::class2(const hexam::IkResult& ik, const Where& where, Detail* d) {
  const hexam::Machine& m = model_.machine();
  const WorkpieceSolid& wp = model_.workpiece();
  const double c = model_.safe();
  const Eigen::AlignedBox3d wbox = wp.block_bounds(where);
  const auto block = interference::Shape::box(2 * wp.block_half(where.offset.z()));
  const Eigen::Isometry3d T_block = wp.block_pose(where);
  Eigen::Isometry3d T_wp = Eigen::Isometry3d::Identity();
  T_wp.linear() = where.R;
  T_wp.translation() = where.offset;
  double best = kInf;
  for (int s = 0; s < 6; ++s) {
    const auto& st = ik.struts[s];
    const double lb = aabb_distance(segment_box(st.slider_mm, st.plate_mm, m.strut_radius_mm), wbox);
    if (lb >= best || lb >= c + kSlack_mm) {
      if (lb < best) {
        best = lb;
        if (d) d->class2_strut = s;
      }
      continue;
    }
    const auto& cap = struts_[s];
    const auto T = interference::segment_pose(st.slider_mm, st.plate_mm);
    double dist = interference::distance(cap, T, block, T_block).distance_mm;
    if (dist < c + kSlack_mm) {
      // The block is only a hull; ask the real solid (workpiece mesh) and the pad separately.
      double exact = interference::distance(cap, T, workpiece_, T_wp).distance_mm;
      const double pad = where.offset.z();
      if (pad > 1e-9) {
        const Eigen::Vector3d half(wp.bounds.sizes().x() / 2, wp.bounds.sizes().y() / 2, pad / 2);
        Eigen::Isometry3d Tp = Eigen::Isometry3d::Identity();
        Tp.linear() = where.R;
        Tp.translation() =
            where.R * Eigen::Vector3d(wp.bounds.center().x(), wp.bounds.center().y(), -pad / 2) + where.offset;
        exact = std::min(exact, interference::distance(cap, T, interference::Shape::box(2 * half), Tp).distance_mm);
      }
      dist = exact;
    }
    if (dist < best) {
      best = dist;
      if (d) d->class2_strut = s;
    }
  }
  return best;
}

std::size_t HexapodEvaluator::assembly_parts(const Peripheral& per, const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                                             const Eigen::Vector3d& axis, std::array<Near::Part, Near::kParts>& parts,
                                             double* assembly_lb) const {
  const hexam::Machine& m = model_.machine();
  const Eigen::Vector3d top = tip + axis * (m.gauge_mm + m.plate_thickness_mm);
  *assembly_lb = gap(per, tip, top, std::max(m.plate_radius_mm, m.plate_joint_reach_mm), false);
  if (*assembly_lb >= model_.safe() + kSlack_mm) return 0;
  // Every rigid part with a lower bound; exact distances are taken in order of the bounds, so
  // the closest part is usually met first and the rest are skipped by their bounds.
  std::size_t count = 0;
  for (std::size_t s = 0; s < m.tool_parts.size() && count < parts.size(); ++s) {
    const auto& tp = m.tool_parts[s];
    const Eigen::Vector3d a = tip + axis * tp.from_mm, b = tip + axis * tp.to_mm;
    parts[count++] = {gap(per, a, b, tp.radius_mm, !tp.capsule), s, static_cast<int>(s), a, b, tp.radius_mm, tp.capsule,
                      false, 0.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  }
  const Eigen::Vector3d pa = tip + axis * m.gauge_mm;
  if (count < parts.size())
    parts[count++] = {gap(per, pa, top, m.plate_radius_mm, true), m.tool_parts.size(), -1, pa, top, m.plate_radius_mm, false,
                      false, 0.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  for (int s = 0; s < 6 && count < parts.size(); ++s) {
    const Eigen::Vector3d h = ik.struts[s].plate_mm;
    parts[count++] = {gap(per, h, h, m.hinge_radius_mm, false), rigid_.size() - 1, -2 - s, h, h, m.hinge_radius_mm, true,
                      false, 0.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  }
  std::sort(parts.begin(), parts.begin() + static_cast<long>(count),
            [](const Near::Part& x, const Near::Part& y) { return x.lower < y.lower; });
  return count;
}

double HexapodEvaluator::assembly_to_peripheral(const Peripheral& per, const interference::Shape& shape,
                                                const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                                                const Eigen::Vector3d& axis, std::string* part) {
  Near n;
  double assembly_lb = 0.0;
  n.count = assembly_parts(per, ik, tip, axis, n.parts, &assembly_lb);
  if (n.count == 0) {
    if (part) *part = "tool assembly";
    return assembly_lb;
  }
  return measure_assembly(per, shape, ik, tip, axis, n, part);
}

double HexapodEvaluator::measure_assembly(const Peripheral& per, const interference::Shape& shape, const hexam::IkResult& ik,
                                          const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, Near& n,
                                          std::string* part) {
  const hexam::Machine& m = model_.machine();
  const std::size_t count = n.count;
  n.best = -1, n.deep = false;
  std::array<Near::Part, Near::kParts>& parts = n.parts;
  const Eigen::Vector3d top = tip + axis * (m.gauge_mm + m.plate_thickness_mm), pa = tip + axis * m.gauge_mm;
  double best = kInf;
  int best_name = 0;
  if (per.is_box && parts[0].lower <= 0.0) {
    // Possibly overlapping: how deep (balls inside the parts, inside the box), so that an
    // overlap proves itself over a neighbourhood; no exact distance is needed then.
    const Eigen::Isometry3d to_local = per.T_table_peripheral.inverse();
    const auto sdf = [&](const Eigen::Vector3d& q) { return box_sdf(to_local * q, per.box_half_mm); };
    for (std::size_t k = 0; k < count && parts[k].lower <= 0.0; ++k) {
      const int nm = parts[k].name;
      double depth;
      DepthBall ball;
      if (nm >= 0) {
        const auto& tp = m.tool_parts[nm];
        depth = depth_into(tip + axis * tp.from_mm, tip + axis * tp.to_mm, tp.radius_mm, tp.capsule, sdf, &ball);
      } else if (nm == -1) {
        depth = depth_into(pa, top, m.plate_radius_mm, false, sdf, &ball);
      } else {
        const Eigen::Vector3d h = ik.struts[-2 - nm].plate_mm;
        depth = depth_into(h, h, m.hinge_radius_mm, true, sdf, &ball);
      }
      if (depth < 0.0 && depth < best) best = depth, best_name = nm, n.deep = true, n.ball = ball;
    }
  }
  for (std::size_t k = 0; k < count && parts[k].lower < best && best > 0.0; ++k) {
    // The part's solid along its segment (a hinge's sphere at its point).
    const interference::Proximity p = interference::distance(rigid_[parts[k].shape], interference::segment_pose(parts[k].a, parts[k].b),
                                                             shape, per.T_table_peripheral);
    parts[k].measured = true;
    parts[k].exact = p.distance_mm;
    parts[k].on_part = p.point_a_mm;
    parts[k].on_peripheral = p.point_b_mm;
    if (p.distance_mm < best) best = p.distance_mm, best_name = parts[k].name, n.best = static_cast<int>(k);
  }
  if (part && std::isfinite(best))
    *part = best_name >= 0 ? m.tool_parts[best_name].name
            : best_name == -1 ? std::string("spindle plate")
                              : fmt::format("plate hinge {}", -1 - best_name);
  return best;
}

std::optional<BoxRange> HexapodEvaluator::assembly_box_range(const Peripheral& per, const interference::Shape& shape,
                                                             const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                                                             const Eigen::Vector3d& axis, const Eigen::Vector3d& half) {
  if (!per.is_box) return std::nullopt;
  const MovedNearBox box(per, half);
  Near n;
  double far = 0.0;
  n.count = assembly_parts(per, ik, tip, axis, n.parts, &far);
  if (n.count == 0) {  // far: the assembly's bound
    BoxRange r;
    r.lower = far - box.reach, r.upper = kInf;
    return r;
  }
  if (auto r = assembly_range_unmeasured(box, n)) return r;
  return assembly_range_measured(box, per, shape, ik, tip, axis, n);
}

std::optional<BoxRange> HexapodEvaluator::assembly_range_unmeasured(const MovedNearBox& box, const Near& n) const {
  // From a few directions per part near enough, without an exact distance. When that decides
  // the box, it is the answer; so it is when what it shows of the distance at the centre, d,
  // leaves the measured path no way to decide it either: that one's bounds are at best d less
  // (or plus) the box's smallest half side (any unit g has |g|.half at least that).
  BoxRange r;
  double lower = kInf, upper = kInf, d_low = kInf, d_high = kInf;  // d within [d_low, d_high]
  for (std::size_t k = 0; k < n.count; ++k) {
    const Near::Part& p = n.parts[k];
    if (box.floor(p) >= lower) {  // sorted by their bounds: the rest are farther
      d_low = std::min(d_low, p.lower);
      break;
    }
    // Directions: the peripheral's face normals turned towards the part, the part's axis, and
    // those between alternating projections (the peripheral's point nearest the part's, and
    // back).
    Eigen::Vector3d g_best = Eigen::Vector3d::Zero(), at_best = (p.a + p.b) / 2, at;
    double sep_best = -kInf, up_best = kInf, lo_best = -kInf;
    auto look = [&](const Eigen::Vector3d& g) {
      const double sep = box.separation(p, g, &at);
      if (sep - box.move_along(g) > lo_best) lo_best = sep - box.move_along(g), g_best = g;
      sep_best = std::max(sep_best, sep);
      const double up = box.away(at).norm();
      if (up < up_best) up_best = up, at_best = at;
    };
    const Eigen::Vector3d side = box.R.transpose() * ((p.a + p.b) / 2 - box.centre);
    for (int j = 0; j < 3; ++j) look(box.R.col(j) * (side[j] >= 0 ? 1.0 : -1.0));
    if (!p.capsule && (p.b - p.a).norm() > 1e-9) {
      const Eigen::Vector3d w = (p.b - p.a).normalized();
      look(w.dot((p.a + p.b) / 2 - box.centre) >= 0 ? w : Eigen::Vector3d(-w));
    }
    Eigen::Vector3d on_part = (p.a + p.b) / 2;
    for (int step = 0; step < 3; ++step) {
      const Eigen::Vector3d out = box.away(on_part);
      if (out.norm() < 1e-9) {  // a point of the part in the box
        up_best = 0.0, at_best = on_part;
        break;
      }
      look(out.normalized());
      if (out.norm() < up_best) up_best = out.norm(), at_best = on_part;
      on_part = nearest_on(p, on_part - out);
    }
    const double lo = std::max(box.floor(p), lo_best);
    if (lo < lower) lower = lo, set_spread(r, g_best, box.half);
    upper = std::min(upper, std::max(0.0, box.corners_max(at_best)));
    d_low = std::min(d_low, p.lower > 0.0 ? std::max(p.lower, sep_best) : sep_best), d_high = std::min(d_high, up_best);
  }
  r.lower = lower - MovedNearBox::kSlack, r.upper = upper + MovedNearBox::kSlack;
  const double limit = model_.safe(), least = box.half.minCoeff();
  if (r.upper < limit || r.lower >= limit) return r;
  if (d_high < limit + least && d_low >= limit - least) return r;
  return std::nullopt;
}

BoxRange HexapodEvaluator::assembly_range_measured(const MovedNearBox& box, const Peripheral& per,
                                                   const interference::Shape& shape, const hexam::IkResult& ik,
                                                   const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, Near& n) {
  // Measured (FCL): the nearest points give the direction; an overlap, the deepest ball.
  constexpr double slack = MovedNearBox::kSlack;
  const double value = measure_assembly(per, shape, ik, tip, axis, n, nullptr);
  // Whatever the case, the value (a distance, or a depth that moves like one) changes no
  // faster than the move.
  BoxRange r;
  r.lower = value - box.reach - slack, r.upper = value + box.reach + slack;
  if (n.deep) {
    r.upper = std::min(r.upper, box.corners_max(n.ball.centre) - n.ball.radius_mm + slack);
    return r;
  }
  if (n.best < 0 || !(value > 0.0)) return r;
  auto direction = [&](const Near::Part& p) -> Eigen::Vector3d {
    if (p.measured && p.exact > 1e-9 && (p.on_part - p.on_peripheral).norm() > 1e-12)
      return (p.on_part - p.on_peripheral).normalized();
    const Eigen::Vector3d mid = (p.a + p.b) / 2, out = box.away(mid);
    return out.norm() > 1e-12 ? Eigen::Vector3d(out.normalized()) : Eigen::Vector3d(mid - box.centre).normalized();
  };
  const Near::Part& nearest = n.parts[n.best];
  Eigen::Vector3d at;
  const Eigen::Vector3d g = direction(nearest);
  double lower = std::max(r.lower, box.separation(nearest, g, &at) - box.move_along(g));
  set_spread(r, g, box.half);
  r.upper = std::min(r.upper, std::max(0.0, box.corners_max(at)) + slack);
  for (std::size_t k = 0; k < n.count; ++k) {
    const Near::Part& p = n.parts[k];
    if (static_cast<int>(k) == n.best || box.floor(p) >= lower) continue;
    const Eigen::Vector3d gk = direction(p);
    lower = std::min(lower, std::max(box.floor(p), box.separation(p, gk, &at) - box.move_along(gk)));
  }
  r.lower = std::max(r.lower, lower - slack);
  return r;
}

std::optional<BoxRange> HexapodEvaluator::stroke_box_range(const hexam::IkResult& ik, const Eigen::Vector3d& half) {
  // A slider on its rail: s = u.d + sqrt(L^2 - |d - (u.d) u|^2), d from the rail's foot to the
  // plate joint, which moves with the workpiece. s is concave in the move, so over the box it
  // is smallest at a corner, and at most its tangent plane at the centre.
  const hexam::Machine& m = model_.machine();
  if (!ik.reachable) return std::nullopt;
  BoxRange r;
  r.lower = r.upper = kInf;
  for (int i = 0; i < 6; ++i) {
    const hexam::Strut& st = m.struts[i];
    const Eigen::Vector3d& u = st.rail_direction;
    const Eigen::Vector3d d = ik.struts[i].plate_mm - st.rail_foot_mm;
    const Eigen::Vector3d perp = d - u.dot(d) * u;
    const double root = std::sqrt(std::max(0.0, st.length_mm * st.length_mm - perp.squaredNorm()));
    const double low = ik.struts[i].s_mm - m.stroke_min_mm;
    if (root < 1e-9) return std::nullopt;
    const Eigen::Vector3d g = u - perp / root;
    if (low + g.cwiseAbs().dot(half) < r.upper) {
      r.upper = low + g.cwiseAbs().dot(half);
      set_spread(r, g, half);
    }
    for (int j = 0; j < 8; ++j) {
      const hexam::RailPosition at = hexam::slider_on_rail(st, d + corner(half, j));
      // A corner out of reach: a placement in the box fails the stroke (its margin is then the
      // negative reach deficit); nothing better than that is known below.
      r.lower = std::min(r.lower, at.reachable ? at.s_mm - m.stroke_min_mm : -kInf);
    }
  }
  r.lower -= 1e-9, r.upper += 1e-9;
  return r;
}

std::optional<BoxRange> HexapodEvaluator::box_range(int c, const PathPose& pose, const Where& where,
                                                    const Eigen::Vector3d& half) {
  const bool periph = c >= kFirstPeripheral && c < model_.support() && (c - kFirstPeripheral) % 2 == 0;
  if (c != kStroke && !periph) return std::nullopt;
  const hexam::Machine& m = model_.machine();
  const Eigen::Vector3d tip = where.R * pose.tip + where.offset;
  const Eigen::Vector3d axis = where.R * pose.axis;
  const hexam::IkResult ik = hexam::inverse_kinematics(m, tip, axis);
  if (c == kStroke) return stroke_box_range(ik, half);
  const std::size_t p = static_cast<std::size_t>(c - kFirstPeripheral) / 2;
  return assembly_box_range(model_.peripherals()[p], periph_[p], ik, tip, axis, half);
}

double HexapodEvaluator::struts_to_peripheral(const Peripheral& per, const interference::Shape& shape,
                                              const hexam::IkResult& ik, std::string* part) {
  const hexam::Machine& m = model_.machine();
  // Struts, closest bound first.
  std::array<std::pair<double, int>, 6> order;
  for (int s = 0; s < 6; ++s) order[s] = {gap(per, ik.struts[s].slider_mm, ik.struts[s].plate_mm, m.strut_radius_mm, false), s};
  std::sort(order.begin(), order.end());
  double best = kInf;
  int best_strut = -1;
  if (per.is_box && order[0].first <= 0.0) {
    // Possibly overlapping: how deep, without an exact distance (see above).
    const Eigen::Isometry3d to_local = per.T_table_peripheral.inverse();
    const auto sdf = [&](const Eigen::Vector3d& q) { return box_sdf(to_local * q, per.box_half_mm); };
    for (const auto& [lb, s] : order) {
      if (lb > 0.0) break;
      const double depth = depth_into(ik.struts[s].slider_mm, ik.struts[s].plate_mm, m.strut_radius_mm, true, sdf);
      if (depth < 0.0 && depth < best) best = depth, best_strut = s;
    }
  }
  for (const auto& [lb, s] : order) {
    if (lb >= best || best <= 0.0) break;
    const auto& st = ik.struts[s];
    double dist = lb;
    if (lb < model_.safe() + kSlack_mm)
      dist = interference::distance(struts_[s], interference::segment_pose(st.slider_mm, st.plate_mm), shape,
                                    per.T_table_peripheral).distance_mm;
    if (dist < best) best = dist, best_strut = s;
  }
  if (part && best_strut >= 0) *part = fmt::format("strut {}", best_strut + 1);
  return best;
}

void HexapodEvaluator::run(const PathPose& pose, const Where& where, Mask mask, double* v, Detail* d) {
  const hexam::Machine& m = model_.machine();
  const int n = model_.count();
  const int support = model_.support();
  const Eigen::Vector3d tip = where.R * pose.tip + where.offset;
  const Eigen::Vector3d axis = where.R * pose.axis;
  hexam::IkResult ik = hexam::inverse_kinematics(m, tip, axis);
  // The tool and holder against the pad and the table, in the workpiece frame.
  auto support_value = [&] {
    if (!(mask & bit(support))) return kInf;
    return support_clearance(m.tool_parts, tool_, model_.workpiece(), pose, where.offset.z(), true,
                             model_.safe() + kSlack_mm, d ? &d->support_part : nullptr);
  };
  if (!ik.reachable) {
    // Out of reach: every strut-related value is meaningless; report the deficit where it
    // matters, which is 1-Lipschitz in the placement (kappa >= 1 covers it).
    for (int k = 0; k < n; ++k) v[k] = kInf;
    v[kStroke] = v[kStrokeHigh] = -ik.reach_deficit_mm;
    v[support] = support_value();
    v[n] = m.alpha_max_rad;
    if (d) d->ik = ik;
    return;
  }
  const hexam::LimitMargins lm = hexam::limit_margins(m, ik, (mask & bit(kJoint)) != 0);
  v[kStroke] = v[kStrokeHigh] = kInf;
  for (int j = 0; j < 6; ++j) {
    const double low = ik.struts[j].s_mm - m.stroke_min_mm, high = m.stroke_max_mm - ik.struts[j].s_mm;
    if (low < v[kStroke]) {
      v[kStroke] = low;
      if (d) d->low_strut = j;
    }
    if (high < v[kStrokeHigh]) {
      v[kStrokeHigh] = high;
      if (d) d->high_strut = j;
    }
  }
  v[kJoint] = lm.joint_rad;
  v[n] = hexam::strut_rail_angle(m, ik);
  if (d) d->ik = ik, d->limits = lm;
  v[kStrutStrut] = (mask & bit(kStrutStrut))
                       ? hexam::strut_clearance(m, ik, d ? &d->strut_a : nullptr, d ? &d->strut_b : nullptr)
                       : kInf;
  v[kClass2] = (mask & bit(kClass2)) ? class2(ik, where, d) : kInf;
  const auto& pers = model_.peripherals();
  if (d) d->periph_part.assign(2 * pers.size(), std::string());
  for (std::size_t p = 0; p < pers.size(); ++p) {
    const int ci = kFirstPeripheral + 2 * static_cast<int>(p);
    v[ci] = (mask & bit(ci)) ? assembly_to_peripheral(pers[p], periph_[p], ik, tip, axis, d ? &d->periph_part[2 * p] : nullptr)
                                : kInf;
    v[ci + 1] =
        (mask & bit(ci + 1)) ? struts_to_peripheral(pers[p], periph_[p], ik, d ? &d->periph_part[2 * p + 1] : nullptr) : kInf;
  }
  v[support] = support_value();
}

void HexapodEvaluator::describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) {
  const hexam::Machine& m = model_.machine();
  Detail d;
  std::vector<double> v(model_.stride());
  run(pose, where, ~Mask{0}, v.data(), &d);
  const Eigen::Vector3d offset = where.offset;
  const Eigen::Vector3d tip = where.R * pose.tip + offset, axis = where.R * pose.axis;
  // Self and class-2 interference come from reaching too far, so the paper's evasion for them
  // moves the workpiece back toward the table centre; at the centre itself, the way that brings
  // the spindle plate toward the machine's axis.
  const Eigen::Vector2d to_axis = offset.head<2>().norm() > 1e-6 ? Eigen::Vector2d(-offset.head<2>())
                                                                 : Eigen::Vector2d(-(tip + axis * m.gauge_mm).head<2>());
  const Eigen::Vector2d toward_centre = to_axis.norm() > 1e-9 ? Eigen::Vector2d(to_axis.normalized()) : Eigen::Vector2d::Zero();
  f.evasion = toward_centre;
  if (c == kStroke || c == kStrokeHigh) {
    const bool low = c == kStroke;
    f.what = !d.ik.reachable ? fmt::format("out of reach by {:.1f} mm", d.ik.reach_deficit_mm)
                             : fmt::format("slider {} {:.1f} mm from its {} stroke end", (low ? d.low_strut : d.high_strut) + 1,
                                           v[c], low ? "lower" : "upper");
  } else if (c == kJoint) {
    f.what = fmt::format("{} joint of strut {} {:.1f} deg from its cone limit", d.limits.joint_at_plate ? "plate" : "slider",
                         d.limits.joint_strut + 1, d.limits.joint_rad / kDeg);
  } else if (c == kStrutStrut) {
    f.what = fmt::format("strut {} / strut {}", d.strut_a + 1, d.strut_b + 1);
  } else if (c == kClass2) {
    f.what = fmt::format("strut {} / workpiece", d.class2_strut + 1);
  } else if (c == model_.support()) {
    f.what = (d.support_part >= 0 ? m.tool_parts[d.support_part].name : std::string("tool")) + " / pad or table";
    f.evasion = Eigen::Vector2d::Zero();
  } else {
    const int p = (c - kFirstPeripheral) / 2;
    const Peripheral& per = model_.peripherals()[p];
    const std::string& part = d.periph_part[c - kFirstPeripheral];
    f.what = part.empty() ? per.name : part + " / " + per.name;
    // Evade along the normal of the peripheral's side that faces the machine (horizontal).
    f.evasion = evasion_from(per, tip + axis * (m.gauge_mm * 0.5));
  }
}

double HexapodEvaluator::placement_value(int k, const Where& where, double enough, Finding* f) {
  const Peripheral& per = model_.peripherals()[k];
  const WorkpieceSolid& wp = model_.workpiece();
  const Eigen::AlignedBox3d wbox = wp.block_bounds(where);
  if (f) {
    f->what = "workpiece and pad / " + per.name;
    f->evasion = evasion_from(per, wbox.center());
  }
  // When a lower bound is all the caller needs, the boxes' bounds settle most placements.
  const double lower = aabb_distance(wbox, per.bounds);
  if (lower >= enough) return lower;
  return interference::distance(interference::Shape::box(2 * wp.block_half(where.offset.z())), wp.block_pose(where),
                                periph_[k], per.T_table_peripheral)
      .distance_mm;
}

}  // namespace

std::shared_ptr<const MachineModel> make_hexapod_model(const hexam::Machine& machine, const Scene& scene) {
  return std::make_shared<HexapodModel>(machine, scene);
}

}  // namespace machplan::placement
