#include "solvers/placement/hexam_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "engine/common/error.h"
#include "engine/interference/collision.h"
#include "solvers/placement/bounds.h"
#include "solvers/placement/scene.h"
#include "solvers/placement/workpiece.h"

namespace machplan::placement {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = M_PI / 180.0;
// Lower bounds this far above what a check needs are kept instead of an exact query.
constexpr double kSlack_mm = 50.0;

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

class HexapodModel;

class HexapodEvaluator final : public PoseEvaluator {
 public:
  explicit HexapodEvaluator(const HexapodModel& model);
  void evaluate(const PathPose& pose, const Where& where, Mask mask, double* v) override;
  void describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) override;
  double placement_value(int k, const Where& where, double enough, Finding* f) override;

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
  double assembly_to_peripheral(const Peripheral& per, const interference::Shape& shape, const hexam::IkResult& ik,
                                const Eigen::Vector3d& tip, const Eigen::Vector3d& axis, std::string* part);
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
    if (vertical) constraints_[kStroke].pad_trend = 1, constraints_[kStrokeHigh].pad_trend = -1;
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

  const hexam::Machine& machine() const { return m_; }
  double safe() const { return c_; }
  int support() const { return support_; }
  const std::vector<Peripheral>& peripherals() const { return peripherals_; }
  const WorkpieceSolid& workpiece() const { return wp_; }

 private:
  hexam::Machine m_;
  double c_;
  std::vector<Peripheral> peripherals_;
  WorkpieceSolid wp_;
  double rot_factor_ = 1.0, L_min_ = 0.0;
  int support_ = 0;
};

HexapodEvaluator::HexapodEvaluator(const HexapodModel& model)
    : model_(model), workpiece_(interference::Shape::sphere(1.0)) {
  const hexam::Machine& m = model.machine();
  for (const auto& st : m.struts) struts_.push_back(interference::Shape::capsule(m.strut_radius_mm, st.length_mm));
  rigid_ = axial_shapes(m.tool_parts);
  rigid_.push_back(interference::Shape::cylinder(m.plate_radius_mm, m.plate_thickness_mm));
  rigid_.push_back(interference::Shape::sphere(m.hinge_radius_mm));
  tool_ = axial_shapes(m.tool_parts);
  for (const auto& p : model.peripherals()) periph_.push_back(p.shape.copy());
  workpiece_ = interference::Shape::mesh(model.workpiece().vertices, model.workpiece().triangles);
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

double HexapodEvaluator::assembly_to_peripheral(const Peripheral& per, const interference::Shape& shape,
                                                const hexam::IkResult& ik, const Eigen::Vector3d& tip,
                                                const Eigen::Vector3d& axis, std::string* part) {
  const hexam::Machine& m = model_.machine();
  const Eigen::Vector3d top = tip + axis * (m.gauge_mm + m.plate_thickness_mm);
  const double assembly_lb = gap(per, tip, top, std::max(m.plate_radius_mm, m.plate_joint_reach_mm), false);
  if (assembly_lb >= model_.safe() + kSlack_mm) {
    if (part) *part = "tool assembly";
    return assembly_lb;
  }
  // Every rigid part with a lower bound; exact distances in order of the bounds, so the
  // closest part is usually met first and the rest are skipped by their bounds.
  struct Part {
    double lower;
    std::size_t shape;
    Eigen::Isometry3d pose;
    int name;  // tool part index, -1 the plate, -2 - k hinge k
  };
  std::array<Part, 16> parts;
  std::size_t count = 0;
  for (std::size_t s = 0; s < m.tool_parts.size() && count < parts.size(); ++s) {
    const auto& tp = m.tool_parts[s];
    const Eigen::Vector3d a = tip + axis * tp.from_mm, b = tip + axis * tp.to_mm;
    parts[count++] = {gap(per, a, b, tp.radius_mm, !tp.capsule), s, interference::segment_pose(a, b), static_cast<int>(s)};
  }
  const Eigen::Vector3d pa = tip + axis * m.gauge_mm;
  if (count < parts.size())
    parts[count++] = {gap(per, pa, top, m.plate_radius_mm, true), m.tool_parts.size(), interference::segment_pose(pa, top), -1};
  for (int s = 0; s < 6 && count < parts.size(); ++s) {
    const Eigen::Vector3d h = ik.struts[s].plate_mm;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = h;
    parts[count++] = {gap(per, h, h, m.hinge_radius_mm, false), rigid_.size() - 1, T, -2 - s};
  }
  std::sort(parts.begin(), parts.begin() + static_cast<long>(count), [](const Part& x, const Part& y) { return x.lower < y.lower; });
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
      if (nm >= 0) {
        const auto& tp = m.tool_parts[nm];
        depth = depth_into(tip + axis * tp.from_mm, tip + axis * tp.to_mm, tp.radius_mm, tp.capsule, sdf);
      } else if (nm == -1) {
        depth = depth_into(pa, top, m.plate_radius_mm, false, sdf);
      } else {
        const Eigen::Vector3d h = ik.struts[-2 - nm].plate_mm;
        depth = depth_into(h, h, m.hinge_radius_mm, true, sdf);
      }
      if (depth < 0.0 && depth < best) best = depth, best_name = nm;
    }
  }
  for (std::size_t k = 0; k < count && parts[k].lower < best && best > 0.0; ++k) {
    const double dist = interference::distance(rigid_[parts[k].shape], parts[k].pose, shape, per.T_table_peripheral).distance_mm;
    if (dist < best) best = dist, best_name = parts[k].name;
  }
  if (part && std::isfinite(best))
    *part = best_name >= 0 ? m.tool_parts[best_name].name
            : best_name == -1 ? std::string("spindle plate")
                              : fmt::format("plate hinge {}", -1 - best_name);
  return best;
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
  // Strut to strut: capsules, closed form.
  double ss = kInf;
  for (int a = 0; a < 6 && (mask & bit(kStrutStrut)); ++a)
    for (int b = a + 1; b < 6; ++b) {
      const double dist = interference::segment_distance(ik.struts[a].slider_mm, ik.struts[a].plate_mm,
                                                         ik.struts[b].slider_mm, ik.struts[b].plate_mm) -
                          2 * m.strut_radius_mm;
      if (dist < ss) {
        ss = dist;
        if (d) d->strut_a = a, d->strut_b = b;
      }
    }
  v[kStrutStrut] = ss;
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
