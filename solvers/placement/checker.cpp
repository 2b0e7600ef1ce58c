#include "solvers/placement/checker.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>

#include "engine/common/error.h"
#include "engine/interference/height_field.h"

namespace machplan::placement {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = M_PI / 180.0;
constexpr int kMaxIntervalDepth = 12;
// Lower bounds this far above what a scan needs are kept instead of an exact query.
constexpr double kLowerBoundSlack_mm = 50.0;
// Tree nodes a probe opens before it gives up.
constexpr long kProbeBudget = 30;

double aabb_distance(const Eigen::AlignedBox3d& a, const Eigen::AlignedBox3d& b) {
  const Eigen::Vector3d gap =
      (a.min() - b.max()).cwiseMax(b.min() - a.max()).cwiseMax(Eigen::Vector3d::Zero());
  return gap.norm();
}

Eigen::AlignedBox3d segment_box(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double r) {
  Eigen::AlignedBox3d b(p0.cwiseMin(p1), p0.cwiseMax(p1));
  b.min().array() -= r;
  b.max().array() += r;
  return b;
}

// Exact bounds of a flat-ended cylinder from p0 to p1: each rim circle reaches r sqrt(1 - d_k^2)
// along world axis k, d being the unit cylinder axis.
Eigen::AlignedBox3d cylinder_box(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double r) {
  const Eigen::Vector3d d = (p1 - p0).normalized();
  const Eigen::Vector3d e = r * (Eigen::Vector3d::Ones() - d.cwiseProduct(d)).cwiseMax(0.0).cwiseSqrt();
  return Eigen::AlignedBox3d(p0.cwiseMin(p1) - e, p0.cwiseMax(p1) + e);
}

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

Eigen::Vector3d slerp_axis(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double t) {
  const double th = std::atan2(a.cross(b).norm(), a.dot(b));
  if (th < 1e-9) return ((1 - t) * a + t * b).normalized();
  const double s = std::sin(th);
  return (std::sin((1 - t) * th) / s * a + std::sin(t * th) / s * b).normalized();
}
}  // namespace

const char* kind_name(Kind k) {
  switch (k) {
    case Kind::self: return "self";
    case Kind::workpiece_class1: return "workpiece_class1";
    case Kind::workpiece_class2: return "workpiece_class2";
    case Kind::machine_peripheral: return "machine_peripheral";
    case Kind::workpiece_peripheral: return "workpiece_peripheral";
  }
  return "?";
}

bool CheckReport::free() const {
  return std::none_of(kinds.begin(), kinds.end(), [](const Finding& f) { return f.interferes; });
}

// What evaluate() found at one pose, for messages.
struct Checker::Eval {
  hexam::IkResult ik;
  hexam::LimitMargins limits;
  int strut_a = -1, strut_b = -1;  // closest strut pair
  int class2_strut = -1;
  std::vector<std::string> periph_part;  // per constraint index beyond kFirstPeripheral
};

struct Checker::ScanSettings {
  bool report = false;                 // minimise instead of decide
  std::vector<double> thr_ok, thr_fail;  // per constraint
  std::vector<double> best;            // report: smallest value so far
  std::vector<long> best_pose;
  std::vector<double> best_t;
  unsigned mask = 0;                   // constraints this scan settles (0: all)
  int failed_constraint = -1;
  long failed_pose = -1;
  double failed_t = 0, failed_value = 0;
  bool failed_exact = false;           // failed_value is an exact value (else a lower bound)
  double radius = 0;                   // decisions: the radius of the ball of placements
  bool skip_learned = false;           // do not try the learned interferences first
  bool poses_only = false;             // a search for interferences at the tool poses only
  long budget = -1;                    // nodes to open before giving up (-1: no limit)
  unsigned all_mask = 0;
};

void validate_rotation_deg(double rotation_deg, const char* field) {
  if (!std::isfinite(rotation_deg) || std::abs(rotation_deg) > 360.0)
    throw InputError::field(field, fmt::format("rotation {} deg: must be a finite angle within -360 .. 360", rotation_deg));
}

Checker::Checker(const Scene& scene, double rotation_deg, StopToken stop)
    : stop_(stop),
      scene_(scene),
      rotation_deg_(rotation_deg),
      workpiece_shape_(interference::Shape::sphere(1.0)),
      workpiece_box_shape_(interference::Shape::sphere(1.0)) {
  validate_rotation_deg(rotation_deg, "rotation_deg");  // NaN would reach Eigen's solvers
  const QueryBudget budget(*this);                     // class 1 is checked over the path here
  const hexam::Machine& m = scene.machine;
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(rotation_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::size_t n = scene.tips_mm.size();
  tips_.resize(n);
  axes_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    tips_[i] = Rz * scene.tips_mm[i];
    axes_[i] = Rz * scene.axes[i];
  }
  std::vector<Eigen::Vector3d> wv(scene.workpiece_vertices.size());
  Eigen::AlignedBox3d wb;
  for (std::size_t i = 0; i < wv.size(); ++i) {
    wv[i] = Rz * scene.workpiece_vertices[i];
    wb.extend(wv[i]);
  }
  workpiece_shape_ = interference::Shape::mesh(wv, scene.workpiece_triangles);
  // Workpiece plus pad as one box in the workpiece frame: from the table (z = -pad) up; the
  // pad's height is added per placement, so the box here spans the workpiece only and is
  // stretched down in evaluate().
  workpiece_box_half_ = wb.sizes() / 2;
  workpiece_box_centre_ = wb.center();

  // Struts have fixed lengths: one capsule each, posed per query.
  for (const auto& st : m.struts) strut_shapes_.push_back(interference::Shape::capsule(m.strut_radius_mm, st.length_mm));
  // Tool assembly shapes: tool parts along the axis, the plate, the hinges.
  for (const auto& part : m.tool_parts) {
    const double len = part.to_mm - part.from_mm;
    rigid_shapes_.push_back(part.capsule ? interference::Shape::capsule(part.radius_mm, std::max(len - 2 * part.radius_mm, 0.0))
                                         : interference::Shape::cylinder(part.radius_mm, len));
  }
  rigid_shapes_.push_back(interference::Shape::cylinder(m.plate_radius_mm, m.plate_thickness_mm));
  rigid_shapes_.push_back(interference::Shape::sphere(m.hinge_radius_mm));

  // Motion bounds per interval.
  const double rot_factor = hexam::plate_rotation_factor(m.max_tilt_rad);
  double L_min = kInf;
  for (const auto& s : m.struts) L_min = std::min(L_min, s.length_mm);
  cum_rigid_.assign(n, 0.0);
  cum_joint_.assign(n, 0.0);
  cum_angle_.assign(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    const double dtip = (tips_[i] - tips_[i - 1]).norm();
    const double th = std::atan2(axes_[i].cross(axes_[i - 1]).norm(), axes_[i].dot(axes_[i - 1])) * rot_factor;
    const double dj = dtip + th * m.plate_joint_reach_mm;
    cum_rigid_[i] = cum_rigid_[i - 1] + dtip + th * m.rigid_reach_mm;
    cum_joint_[i] = cum_joint_[i - 1] + dj;
    cum_angle_[i] = cum_angle_[i - 1] + (m.kappa + 1) * dj / L_min + th;
  }
  rot_factor_ = rot_factor;
  min_strut_mm_ = L_min;
  if (n > 1) {
    std::vector<long> intervals(n - 1);
    for (std::size_t i = 0; i + 1 < n; ++i) intervals[i] = static_cast<long>(i);
    nodes_.reserve(2 * n);
    const double w = rot_factor_ * m.rigid_reach_mm;
    tree_keys_.resize(6, static_cast<long>(n - 1));
    for (std::size_t i = 0; i + 1 < n; ++i)
      tree_keys_.col(static_cast<long>(i)) << (tips_[i] + tips_[i + 1]) / 2, w * (axes_[i] + axes_[i + 1]) / 2;
    build_tree(intervals, 0, intervals.size());
    tree_keys_.resize(0, 0);
  }

  const double c = scene.safe_distance_mm;
  // stroke, joint, strut-strut, class 2, then (rigid, struts) per peripheral
  // Lipschitz constants as a kappa + b: the slider-speed factor kappa can be replaced by a
  // local one where the struts are known to stand closer to their rails than alpha_max.
  path_lipschitz_ = {{1, 0}, {0, 1}, {2, 0}, {1, 0}};
  travel_kind_ = {1, 2, 1, 1};
  placement_lipschitz_ = {{1, 0}, {1 / L_min, 1 / L_min}, {2, 0}, {1, 1}};
  limit_ = {0.0, 0.0, c, c};
  for (std::size_t p = 0; p < scene.peripherals.size(); ++p) {
    path_lipschitz_.insert(path_lipschitz_.end(), {{0, 1}, {1, 0}});
    travel_kind_.insert(travel_kind_.end(), {0, 1});
    placement_lipschitz_.insert(placement_lipschitz_.end(), {{0, 1}, {1, 0}});
    limit_.insert(limit_.end(), {c, c});
  }
  constraint_count_ = static_cast<int>(limit_.size());
  stride_ = constraint_count_ + 1;
  // A report finds each smallest value to within this (mm; rad for the joints).
  report_tolerance_.assign(constraint_count_, 0.25);
  report_tolerance_[kJoint] = 0.005;
  MACHPLAN_ASSERT(constraint_count_ <= 32, "at most 14 peripherals are supported, got {}", scene.peripherals.size());
  cache_.assign(n * stride_, 0.0);
  cache_gen_.assign(n, 0u);
  compute_class1();
}

Checker::Pose Checker::interpolate(long i, double t) const {
  if (t <= 0) return {tips_[i], axes_[i]};
  if (t >= 1) return {tips_[i + 1], axes_[i + 1]};
  return {(1 - t) * tips_[i] + t * tips_[i + 1], slerp_axis(axes_[i], axes_[i + 1], t)};
}

Checker::QueryBudget::QueryBudget(Checker& c) : checker(c) {
  if (c.budget_depth_++ == 0) c.query_limit_ = c.counts_.exact_queries + c.scene_.search.max_pose_queries;
}
Checker::QueryBudget::~QueryBudget() { --checker.budget_depth_; }

void Checker::count_query() const {
  if (stop_.stop_requested())
    throw Cancelled(fmt::format("{}: the interference check was stopped on request before it had an answer", scene_.source));
  if (++const_cast<CheckCounts&>(counts_).exact_queries <= query_limit_) return;
  throw Infeasible(fmt::format(
      "{}: the interference check stopped at its limit of {} exact pose queries (search.max_pose_queries in the "
      "scene) without an answer; with a safe distance of {} mm little of the path can be certified in bulk. "
      "Raise the limit in the scene to let it run longer.",
      scene_.source, scene_.search.max_pose_queries, scene_.safe_distance_mm));
}

void Checker::evaluate(const Pose& pose, const Eigen::Vector3d& offset, unsigned mask, double* v, Eval* d) const {
  const hexam::Machine& m = scene_.machine;
  count_query();
  const Eigen::Vector3d tip = pose.tip + offset;
  hexam::IkResult ik = hexam::inverse_kinematics(m, tip, pose.axis);
  const double c = scene_.safe_distance_mm;
  if (!ik.reachable) {
    // Out of reach: every strut-related value is meaningless; report the deficit everywhere
    // it matters, which is 1-Lipschitz in the placement (kappa >= 1 covers it).
    for (int k = 0; k < constraint_count_; ++k) v[k] = kInf;
    v[kStroke] = -ik.reach_deficit_mm;
    v[constraint_count_] = m.alpha_max_rad;
    if (d) d->ik = ik;
    return;
  }
  const hexam::LimitMargins lm = hexam::limit_margins(m, ik, (mask & (1u << kJoint)) != 0);
  v[kStroke] = lm.stroke_mm;
  v[kJoint] = lm.joint_rad;
  v[constraint_count_] = hexam::strut_rail_angle(m, ik);
  if (d) {
    d->ik = ik;
    d->limits = lm;
  }
  // Strut to strut: capsules, closed form.
  double ss = kInf;
  for (int a = 0; a < 6 && (mask & (1u << kStrutStrut)); ++a)
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

  // Struts against the workpiece and its pad.
  if (mask & (1u << kClass2)) {
    Eigen::AlignedBox3d wbox(workpiece_box_centre_ - workpiece_box_half_ + offset,
                             workpiece_box_centre_ + workpiece_box_half_ + offset);
    wbox.min().z() = 0.0;  // the pad fills the footprint down to the table
    const Eigen::Vector3d half = wbox.sizes() / 2;
    const auto pad_box = interference::Shape::box(half * 2);
    Eigen::Isometry3d T_box = Eigen::Isometry3d::Identity();
    T_box.translation() = wbox.center();
    Eigen::Isometry3d T_wp = Eigen::Isometry3d::Identity();
    T_wp.translation() = offset;
    double best = kInf;
    for (int s = 0; s < 6; ++s) {
      const auto& st = ik.struts[s];
      const double lb = aabb_distance(segment_box(st.slider_mm, st.plate_mm, m.strut_radius_mm), wbox);
      if (lb >= best || lb >= c + kLowerBoundSlack_mm) {
        if (lb < best) {
          best = lb;
          if (d) d->class2_strut = s;
        }
        continue;
      }
      const auto& cap = strut_shapes_[s];
      const auto T = interference::segment_pose(st.slider_mm, st.plate_mm);
      double dist = interference::distance(cap, T, pad_box, T_box).distance_mm;
      if (dist < c + kLowerBoundSlack_mm) {
        // The box is only a hull; ask the real solid (workpiece mesh) and the pad separately.
        Eigen::AlignedBox3d padonly = wbox;
        padonly.max().z() = offset.z();
        double exact = interference::distance(cap, T, workpiece_shape_, T_wp).distance_mm;
        if (offset.z() > 1e-9) {
          Eigen::Isometry3d Tp = Eigen::Isometry3d::Identity();
          Tp.translation() = padonly.center();
          exact = std::min(exact, interference::distance(cap, T, interference::Shape::box(padonly.sizes()), Tp).distance_mm);
        }
        dist = exact;
      }
      if (dist < best) {
        best = dist;
        if (d) d->class2_strut = s;
      }
    }
    v[kClass2] = best;
  } else {
    v[kClass2] = kInf;
  }

  // Moving parts against each peripheral.
  for (std::size_t p = 0; p < scene_.peripherals.size(); ++p) {
    const Peripheral& per = scene_.peripherals[p];
    const int ci = kFirstPeripheral + 2 * static_cast<int>(p);
    if (!(mask & (3u << ci))) {
      v[ci] = v[ci + 1] = kInf;
      continue;
    }
    if (d && d->periph_part.size() < static_cast<std::size_t>(2 * scene_.peripherals.size()))
      d->periph_part.resize(2 * scene_.peripherals.size());
    // Rigid tool assembly.
    double best = kInf;
    std::string best_part;
    const Eigen::Vector3d top = tip + pose.axis * (m.gauge_mm + m.plate_thickness_mm);
    // Lower bound of the distance from a segment grown by r to the peripheral: box gaps, taken
    // in the peripheral's own frame when it is a box (tight for a turned box).
    const Eigen::Isometry3d to_local = per.T_table_peripheral.inverse();
    const Eigen::AlignedBox3d local_box(-per.box_half_mm, per.box_half_mm);
    // A separating plane along the segment, facing the box centre, often does better for a
    // long slanted strut passing beside the box. (A flat-ended cylinder lies inside the capsule
    // of the same segment and radius, so both bounds hold for it too.)
    auto gap = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, bool cylinder = false) {
      if (!per.is_box) return aabb_distance(cylinder ? cylinder_box(a, b, r) : segment_box(a, b, r), per.bounds);
      const Eigen::Vector3d la = to_local * a, lb = to_local * b;
      double lower = aabb_distance(cylinder ? cylinder_box(la, lb, r) : segment_box(la, lb, r), local_box);
      const Eigen::Vector3d d = lb - la, mid = (la + lb) / 2;
      const double len2 = d.squaredNorm();
      const Eigen::Vector3d off = len2 > 1e-12 ? Eigen::Vector3d(mid - d * (mid.dot(d) / len2)) : mid;
      const double dist = off.norm();
      if (dist > 1e-9) {
        const Eigen::Vector3d n = off / dist;
        lower = std::max(lower, dist - per.box_half_mm.cwiseProduct(n.cwiseAbs()).sum() - r);
      }
      return lower;
    };
    const double assembly_lb = gap(tip, top, std::max(m.plate_radius_mm, m.plate_joint_reach_mm));
    if (assembly_lb >= c + kLowerBoundSlack_mm) {
      best = assembly_lb;
      best_part = "tool assembly";
    } else {
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
        const auto& part = m.tool_parts[s];
        const Eigen::Vector3d a = tip + pose.axis * part.from_mm, b = tip + pose.axis * part.to_mm;
        parts[count++] = {gap(a, b, part.radius_mm, !part.capsule), s, interference::segment_pose(a, b), static_cast<int>(s)};
      }
      const Eigen::Vector3d pa = tip + pose.axis * m.gauge_mm;
      if (count < parts.size())
        parts[count++] = {gap(pa, top, m.plate_radius_mm, true), m.tool_parts.size(), interference::segment_pose(pa, top), -1};
      for (int s = 0; s < 6 && count < parts.size(); ++s) {
        const Eigen::Vector3d h = ik.struts[s].plate_mm;
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = h;
        parts[count++] = {gap(h, h, m.hinge_radius_mm), rigid_shapes_.size() - 1, T, -2 - s};
      }
      std::sort(parts.begin(), parts.begin() + static_cast<long>(count),
                [](const Part& x, const Part& y) { return x.lower < y.lower; });
      int best_name = 0;
      for (std::size_t k = 0; k < count && parts[k].lower < best; ++k) {
        const double dist =
            interference::distance(rigid_shapes_[parts[k].shape], parts[k].pose, per.shape, per.T_table_peripheral).distance_mm;
        if (dist < best) best = dist, best_name = parts[k].name;
      }
      if (d && std::isfinite(best))
        best_part = best_name >= 0 ? m.tool_parts[best_name].name
                    : best_name == -1 ? std::string("spindle plate")
                                      : fmt::format("plate hinge {}", -1 - best_name);
    }
    v[ci] = best;
    if (d) d->periph_part[2 * p] = best_part;
    // Struts, closest bound first.
    std::array<std::pair<double, int>, 6> order;
    for (int s = 0; s < 6; ++s) order[s] = {gap(ik.struts[s].slider_mm, ik.struts[s].plate_mm, m.strut_radius_mm), s};
    std::sort(order.begin(), order.end());
    double sbest = kInf;
    int sbest_strut = -1;
    for (const auto& [lb, s] : order) {
      if (lb >= sbest) break;
      const auto& st = ik.struts[s];
      double dist = lb;
      if (lb < c + kLowerBoundSlack_mm)
        dist = interference::distance(strut_shapes_[s], interference::segment_pose(st.slider_mm, st.plate_mm), per.shape,
                                      per.T_table_peripheral).distance_mm;
      if (dist < sbest) sbest = dist, sbest_strut = s;
    }
    const std::string spart = d && sbest_strut >= 0 ? fmt::format("strut {}", sbest_strut + 1) : std::string();
    v[ci + 1] = sbest;
    if (d) d->periph_part[2 * p + 1] = spart;
  }
}

const double* Checker::cached_values(long i, const Eigen::Vector3d& offset, ScanSettings& s) {
  double* v = &cache_[static_cast<std::size_t>(i) * stride_];
  if (cache_gen_[i] != gen_) {
    evaluate({tips_[i], axes_[i]}, offset, s.all_mask, v, nullptr);
    cache_gen_[i] = gen_;
  }
  return v;
}

namespace {
double travel(const std::vector<double>& cum, long a, long b) { return std::abs(cum[b] - cum[a]); }
}  // namespace

int Checker::build_tree(std::vector<long>& iv, std::size_t lo, std::size_t hi) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  // Key of an interval: its mid tip and its mid axis scaled so that an axis turn weighs what
  // it moves the rigid parts (tree_keys_, filled by the constructor).
  auto key = [&](long i) { return tree_keys_.col(i); };
  Eigen::Matrix<double, 6, 1> kmin = Eigen::Matrix<double, 6, 1>::Constant(kInf), kmax = -kmin;
  for (std::size_t j = lo; j < hi; ++j) {
    kmin = kmin.cwiseMin(key(iv[j])), kmax = kmax.cwiseMax(key(iv[j]));
  }
  // Centre: the member pose nearest the middle of the keys' box.
  const Eigen::Matrix<double, 6, 1> mid = (kmin + kmax) / 2;
  const double w = rot_factor_ * scene_.machine.rigid_reach_mm;
  long centre = iv[lo];
  double best = kInf;
  for (std::size_t j = lo; j < hi; ++j)
    for (long i : {iv[j], iv[j] + 1}) {
      const double d = (tips_[i] - mid.head<3>()).squaredNorm() + (w * axes_[i] - mid.tail<3>()).squaredNorm();
      if (d < best) best = d, centre = i;
    }
  double tip2 = 0, chord2 = 0;
  for (std::size_t j = lo; j < hi; ++j)
    for (long i : {iv[j], iv[j] + 1}) {
      tip2 = std::max(tip2, (tips_[i] - tips_[centre]).squaredNorm());
      chord2 = std::max(chord2, (axes_[i] - axes_[centre]).squaredNorm());
    }
  Node node;
  node.centre = centre;
  // Rounded up a little so the bound stays a bound in floating point.
  node.tip_mm = std::sqrt(tip2) * (1 + 1e-12) + 1e-9;
  node.angle_rad = 2 * std::asin(std::min(1.0, std::sqrt(chord2) / 2)) * (1 + 1e-12) + 1e-12;
  if (hi - lo == 1) {
    node.left = static_cast<int>(iv[lo]);
  } else {
    int dim = 0;
    (kmax - kmin).maxCoeff(&dim);
    const std::size_t m = lo + (hi - lo) / 2;
    std::nth_element(iv.begin() + lo, iv.begin() + m, iv.begin() + hi,
                     [&](long a, long b) { return tree_keys_(dim, a) < tree_keys_(dim, b); });
    node.left = build_tree(iv, lo, m);
    node.right = build_tree(iv, m, hi);
  }
  nodes_[id] = node;
  return id;
}

double Checker::node_travel(int kind, const Node& n) const {
  // The same travel measures as along the path (see the constructor), from the node's centre.
  const hexam::Machine& m = scene_.machine;
  const double th = n.angle_rad * rot_factor_;
  const double joint = n.tip_mm + th * m.plate_joint_reach_mm;
  switch (kind) {
    case 0: return n.tip_mm + th * m.rigid_reach_mm;
    case 1: return joint;
    default: return (m.kappa + 1) * joint / min_strut_mm_ + th;
  }
}

namespace {
// How precisely a report pins the smallest value `best` of a constraint whose limit is
// `limit`: to within `tolerance` near the limit; far above it, to within half its distance to
// the limit (a 40 mm clearance to within 17.5 mm), which keeps a report of flat, distant
// constraints from visiting every pose. Likewise far below it: an interference deeper than
// kDeepMm is pinned to within half of its depth beyond that (a clearance of 20 mm under a
// 1000 mm safe distance to within 485 mm). A large safe distance is broken along the whole
// path by nearly the same amount (a tool shank 20 mm above the surface everywhere); without
// this every pose would be an exact query. The verdict is the same either way.
double report_margin(double best, double limit, double tolerance) {
  constexpr double kDeepMm = 10.0;
  return std::max(tolerance, best >= limit ? 0.5 * (best - limit) : 0.5 * (limit - best - kDeepMm));
}
}  // namespace

double Checker::report_need(int c, double best) const {
  // While nothing below the limit has been seen, nothing that could be below it is left
  // unexamined, so a report that finds every kind free is also a proof.
  const double need = best - report_margin(best, limit_[c], report_tolerance_[c]);
  // Clearances (strut to strut, class 2, peripherals) are distances, never below 0: a need at
  // or below 0 is met everywhere (a huge tool touching the workpiece at every pose).
  if (c >= kStrutStrut && need <= 0) return -kInf;
  return best >= limit_[c] ? std::max(need, limit_[c]) : need;
}

bool Checker::check_exact(long i, double t, const double* v, unsigned mask, ScanSettings& s) {
  for (int c = 0; c < constraint_count_; ++c) {
    if (!(mask & (1u << c))) continue;
    if (s.report && v[c] < s.best[c]) s.best[c] = v[c], s.best_pose[c] = i, s.best_t[c] = t;
    if (!s.report && v[c] <= fail_threshold(c, v, s)) {
      s.failed_constraint = c, s.failed_pose = i, s.failed_t = t, s.failed_value = v[c], s.failed_exact = true;
      return false;
    }
  }
  return true;
}

bool Checker::scan_interval(long i, double t0, double t1, const double* v0, const double* v1, unsigned mask,
                            const Eigen::Vector3d& offset, ScanSettings& s, int depth) {
  const std::vector<double>* cums[3] = {&cum_rigid_, &cum_joint_, &cum_angle_};
  double worst_bound = kInf;
  int worst_c = -1;
  for (int c = 0; c < constraint_count_; ++c) {
    if (!(mask & (1u << c))) continue;
    const double d = lipschitz(path_lipschitz_[c], scene_.machine.kappa) * travel(*cums[travel_kind_[c]], i, i + 1) * (t1 - t0);
    // Along the stretch the value cannot drop below this (it falls at most d in total).
    const double bound = (v0[c] + v1[c] - d) / 2;
    const double need = s.report ? report_need(c, s.best[c]) : s.thr_ok[c];
    if (bound >= need || std::min(v0[c], v1[c]) - d >= need) {
      mask &= ~(1u << c);
      continue;
    }
    if (bound < worst_bound) worst_bound = bound, worst_c = c;
  }
  if (!mask) return true;
  if (depth >= kMaxIntervalDepth) {
    // Could not be proven to the required precision: report it, never assume it free.
    if (s.report) {
      for (int c = 0; c < constraint_count_; ++c)
        if ((mask & (1u << c))) {
          const double d = lipschitz(path_lipschitz_[c], scene_.machine.kappa) * travel(*cums[travel_kind_[c]], i, i + 1) * (t1 - t0);
          const double bound = (v0[c] + v1[c] - d) / 2;
          if (bound < s.best[c]) s.best[c] = bound, s.best_pose[c] = i, s.best_t[c] = (t0 + t1) / 2;
        }
      return true;
    }
    s.failed_constraint = worst_c, s.failed_pose = i, s.failed_t = (t0 + t1) / 2, s.failed_value = worst_bound;
    return false;
  }
  const double tm = (t0 + t1) / 2;
  std::vector<double> vm(stride_);
  evaluate(interpolate(i, tm), offset, s.all_mask, vm.data(), nullptr);
  ++counts_.interpolated_poses;
  if (!check_exact(i, tm, vm.data(), mask, s)) return false;
  return scan_interval(i, t0, tm, v0, vm.data(), mask, offset, s, depth + 1) &&
         scan_interval(i, tm, t1, vm.data(), v1, mask, offset, s, depth + 1);
}

bool Checker::scan(const Eigen::Vector3d& offset, ScanSettings& s) {
  s.all_mask = all_constraints();
  const unsigned mask = s.mask ? s.mask & s.all_mask : s.all_mask;
  // Exact values found by the previous scan at the same placement are kept (a report right
  // after the decision that certified the placement reuses them), unless that scan evaluated
  // only some constraints.
  if (!(cache_complete_ && offset == cache_offset_) && ++gen_ == 0) {
    std::fill(cache_gen_.begin(), cache_gen_.end(), 0u);
    gen_ = 1;
  }
  if (s.poses_only) s.all_mask = mask;  // a probe evaluates only what it looks for
  cache_offset_ = offset;
  cache_complete_ = s.all_mask == all_constraints();
  const long n = static_cast<long>(tips_.size());
  if (!s.report && !s.skip_learned) {
    // Interferences met before are the likeliest to recur: try them first.
    std::vector<double> v(stride_);
    for (const Witness& w : learned_) {
      if (!(mask & (1u << w.constraint))) continue;
      evaluate(interpolate(w.pose, w.t), offset, 1u << w.constraint, v.data(), nullptr);
      if (!check_exact(w.pose, w.t, v.data(), 1u << w.constraint, s)) return false;
    }
  }
  if (n == 1) {
    const double* v = cached_values(0, offset, s);
    if (!check_exact(0, 0, v, mask, s)) return false;
    for (int c = 0; c < constraint_count_; ++c)
      if ((mask & (1u << c)) && !s.report && v[c] < s.thr_ok[c]) {
        s.failed_constraint = c, s.failed_pose = 0, s.failed_value = v[c];
        return false;
      }
    return true;
  }
  return scan_best_first(mask, offset, s);
}

bool Checker::scan_best_first(unsigned mask, const Eigen::Vector3d& offset, ScanSettings& s) {
  // Nodes are opened in order of the smallest lower bound any of their constraints may reach
  // (relative to what it must reach; radians weigh as 100 mm), so an interference, when there
  // is one, is met early and is among the deepest.
  struct Item {
    double key;
    int node;
    unsigned mask;
    bool operator>(const Item& o) const { return key > o.key; }
  };
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  open.push({-kInf, 0, mask});
  while (!open.empty()) {
    if (s.budget >= 0 && s.budget-- == 0) return true;
    const Item it = open.top();
    open.pop();
    ++counts_.stretches;
    const Node& node = nodes_[it.node];
    unsigned m = it.mask;
    if (node.right < 0) {
      const long i = node.left;
      const double* v0 = cached_values(i, offset, s);
      if (!check_exact(i, 0, v0, m, s)) return false;
      std::vector<double> a(v0, v0 + stride_);
      const double* v1 = cached_values(i + 1, offset, s);
      if (!check_exact(i + 1, 0, v1, m, s)) return false;
      if (s.poses_only) continue;
      std::vector<double> b(v1, v1 + stride_);
      if (!scan_interval(i, 0.0, 1.0, a.data(), b.data(), m, offset, s, 0)) return false;
      continue;
    }
    const double* v = cached_values(node.centre, offset, s);
    if (!check_exact(node.centre, 0, v, m, s)) return false;
    double travel_of_kind[3] = {-1, -1, -1};
    double key = kInf;
    const double kappa = local_kappa(v, node_travel(1, node));
    for (int c = 0; c < constraint_count_; ++c) {
      if (!(m & (1u << c))) continue;
      double& tr = travel_of_kind[travel_kind_[c]];
      if (tr < 0) tr = node_travel(travel_kind_[c], node);
      const double low = v[c] - lipschitz(path_lipschitz_[c], kappa) * tr;
      const double need = s.report ? report_need(c, s.best[c]) : s.thr_ok[c];
      if (low >= need) {
        m &= ~(1u << c);
        ++counts_.proven_by_bound;
      } else {
        key = std::min(key, (low - need) * (c == kJoint ? 100.0 : 1.0));
      }
    }
    if (!m) continue;
    open.push({key, node.left, m});
    open.push({key, node.right, m});
  }
  return true;
}

Finding Checker::describe(int c, const Pose& pose, long index, double t, const Eigen::Vector3d& offset,
                          double value) const {
  Finding f;
  f.pose = index;
  f.t = t;
  f.clearance_mm = value;
  Eval d;
  std::vector<double> v(stride_);
  evaluate(pose, offset, ~0u, v.data(), &d);
  const Eigen::Vector3d tip = pose.tip + offset;
  // Self and class-2 interference come from reaching too far, so the paper's evasion for them
  // moves the workpiece back toward the table centre; at the centre itself, the way that brings
  // the spindle plate toward the machine's axis.
  const Eigen::Vector2d to_axis = offset.head<2>().norm() > 1e-6
                                      ? Eigen::Vector2d(-offset.head<2>())
                                      : Eigen::Vector2d(-(tip + pose.axis * scene_.machine.gauge_mm).head<2>());
  const Eigen::Vector2d toward_centre = to_axis.norm() > 1e-9 ? Eigen::Vector2d(to_axis.normalized()) : Eigen::Vector2d::Zero();
  switch (c) {
    case kStroke:
      if (!d.ik.reachable)
        f.what = fmt::format("out of reach by {:.1f} mm", d.ik.reach_deficit_mm);
      else
        f.what = fmt::format("slider {} {:.1f} mm from its stroke end", d.limits.stroke_strut + 1, d.limits.stroke_mm);
      f.evasion = toward_centre;
      break;
    case kJoint:
      f.what = fmt::format("{} joint of strut {} {:.1f} deg from its cone limit", d.limits.joint_at_plate ? "plate" : "slider",
                           d.limits.joint_strut + 1, d.limits.joint_rad / kDeg);
      f.evasion = toward_centre;
      break;
    case kStrutStrut:
      f.what = fmt::format("strut {} / strut {}", d.strut_a + 1, d.strut_b + 1);
      f.evasion = toward_centre;
      break;
    case kClass2:
      f.what = fmt::format("strut {} / workpiece", d.class2_strut + 1);
      f.evasion = toward_centre;
      break;
    default: {
      const int p = (c - kFirstPeripheral) / 2;
      const Peripheral& per = scene_.peripherals[p];
      f.what = d.periph_part.empty() ? per.name : d.periph_part[c - kFirstPeripheral] + " / " + per.name;
      // Evade along the normal of the peripheral's side that faces the machine (horizontal).
      f.evasion = evasion_from(per, tip + pose.axis * (scene_.machine.gauge_mm * 0.5));
    }
  }
  return f;
}

double Checker::workpiece_peripheral_value(const Eigen::Vector3d& offset, int k, Eigen::Vector2d* evasion,
                                           double enough) const {
  const Peripheral& per = scene_.peripherals[k];
  Eigen::AlignedBox3d wbox(workpiece_box_centre_ - workpiece_box_half_ + offset,
                           workpiece_box_centre_ + workpiece_box_half_ + offset);
  wbox.min().z() = 0.0;
  if (evasion) *evasion = evasion_from(per, wbox.center());
  // When a lower bound is all the caller needs, the boxes' bounds settle most placements.
  const double lower = aabb_distance(wbox, per.bounds);
  if (lower >= enough) return lower;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = wbox.center();
  const auto p = interference::distance(interference::Shape::box(wbox.sizes()), T, per.shape, per.T_table_peripheral);
  return p.distance_mm;
}

bool Checker::class1_box_clear(Eigen::AlignedBox3d b, double sweep, double threshold) const {
  // Proven at least `threshold` away when the solid under the swept box (grown by the
  // threshold sideways) stays that far below it.
  b.min().array() -= sweep;
  b.max().array() += sweep;
  const double grow = std::max(threshold, 0.0);
  const double h = height_field_->max_height(b.min().head<2>() - Eigen::Vector2d::Constant(grow),
                                             b.max().head<2>() + Eigen::Vector2d::Constant(grow));
  return b.min().z() - h >= threshold;
}

double Checker::class1_value(const Pose& pose, std::string* who, double threshold) const {
  const hexam::Machine& m = scene_.machine;
  if (std::isnan(threshold)) threshold = scene_.safe_distance_mm;
  count_query();
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  double best = kInf;
  for (const auto& p : class1_parts_) {
    const Eigen::Vector3d a = pose.tip + pose.axis * p.from_mm, b = pose.tip + pose.axis * p.to_mm;
    if (class1_box_clear(cylinder_box(a, b, p.radius_mm), 0.0, threshold)) continue;
    const double dist =
        interference::distance(rigid_shapes_[p.shape], interference::segment_pose(a, b), workpiece_shape_, I).distance_mm;
    if (dist < best) {
      best = dist;
      if (who) *who = p.name;
    }
  }
  const Eigen::Matrix3d R = hexam::plate_rotation(pose.axis);
  for (int s = 0; s < 6; ++s) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = pose.tip + pose.axis * m.gauge_mm + R * m.struts[s].plate_joint_mm;
    Eigen::AlignedBox3d hb(T.translation(), T.translation());
    hb.min().array() -= m.hinge_radius_mm;
    hb.max().array() += m.hinge_radius_mm;
    if (class1_box_clear(hb, 0.0, threshold)) continue;
    const double dist = interference::distance(rigid_shapes_.back(), T, workpiece_shape_, I).distance_mm;
    if (dist < best) {
      best = dist;
      if (who) *who = fmt::format("plate hinge {}", s + 1);
    }
  }
  return best;
}

void Checker::compute_class1() {
  // Placement-independent: tool shank, chuck, head, plate and hinges against the workpiece,
  // walked in the workpiece frame. A stretch is proven when the height field shows a vertical
  // gap of at least the safe distance under every part's swept box; otherwise the exact
  // distance to the workpiece mesh decides, at poses and inside intervals.
  const hexam::Machine& m = scene_.machine;
  const double c = scene_.safe_distance_mm;
  const Eigen::AlignedBox3d wb(workpiece_box_centre_ - workpiece_box_half_, workpiece_box_centre_ + workpiece_box_half_);
  std::vector<Eigen::Vector3d> wv(scene_.workpiece_vertices.size());
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(rotation_deg_ * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (std::size_t i = 0; i < wv.size(); ++i) wv[i] = Rz * scene_.workpiece_vertices[i];
  height_field_ = std::make_unique<interference::HeightField>(
      wv, scene_.workpiece_triangles, 2.0, Eigen::AlignedBox2d(wb.min().head<2>(), wb.max().head<2>()), 0.0);
  class1_parts_.clear();
  for (std::size_t s = 0; s < m.tool_parts.size(); ++s)
    if (m.tool_parts[s].cls == hexam::ToolPart::Class::class1)
      class1_parts_.push_back({s, m.tool_parts[s].from_mm, m.tool_parts[s].to_mm, m.tool_parts[s].radius_mm, m.tool_parts[s].name});
  class1_parts_.push_back({m.tool_parts.size(), m.gauge_mm, m.gauge_mm + m.plate_thickness_mm, m.plate_radius_mm, "spindle plate"});
  class1_ = Finding{};
  class1_.clearance_mm = kInf;
  // What a pose or stretch must be shown to clear: the safe distance until an interference is
  // known; after that only a smaller clearance can change the finding, pinned as precisely as
  // a report pins it (report_margin). Without this a large safe distance, which no stretch
  // clears and every part misses, would make every pose of the path a dozen exact mesh
  // distances (1000 mm: minutes for the bundled path).
  const double tolerance = report_tolerance_[kClass2];
  const auto threshold = [&] {
    const double best = class1_.clearance_mm;
    return best < c ? best - report_margin(best, c, tolerance) : c;
  };
  auto exact = [&](const Pose& pose, std::string* who) { return class1_value(pose, who, threshold()); };
  auto stretch_clear = [&](const Pose& pose, double sweep) {
    const double t = threshold();
    for (const auto& p : class1_parts_)
      if (!class1_box_clear(cylinder_box(pose.tip + pose.axis * p.from_mm, pose.tip + pose.axis * p.to_mm, p.radius_mm), sweep, t))
        return false;
    const Eigen::Matrix3d R = hexam::plate_rotation(pose.axis);
    Eigen::AlignedBox3d hb;
    for (const auto& s : m.struts) hb.extend(pose.tip + pose.axis * m.gauge_mm + R * s.plate_joint_mm);
    hb.min().array() -= m.hinge_radius_mm;
    hb.max().array() += m.hinge_radius_mm;
    return class1_box_clear(hb, sweep, t);
  };
  const long n = static_cast<long>(tips_.size());
  auto note = [&](double v, long i, double t, const std::string& who) {
    if (v < class1_.clearance_mm) {
      class1_.clearance_mm = v, class1_.pose = i, class1_.t = t, class1_.what = who + " / workpiece";
    }
  };
  // Interval between poses i and i+1 over [t0, t1], with exact values at its ends.
  std::function<void(long, double, double, double, double, int)> interval = [&](long i, double t0, double t1, double v0,
                                                                               double v1, int depth) {
    const double d = travel(cum_rigid_, i, i + 1) * (t1 - t0);
    if ((v0 + v1 - d) / 2 >= threshold() || threshold() <= 0) return;
    if (depth >= kMaxIntervalDepth) {
      note((v0 + v1 - d) / 2, i, (t0 + t1) / 2, "unproven interval");
      return;
    }
    const double tm = (t0 + t1) / 2;
    std::string who;
    const Pose pm = interpolate(i, tm);
    ++counts_.interpolated_poses;
    const double vm = exact(pm, &who);
    note(vm, i, tm, who);
    if (vm < c) return;  // the interference is found; deeper search only refines it
    interval(i, t0, tm, v0, vm, depth + 1);
    interval(i, tm, t1, vm, v1, depth + 1);
  };
  std::vector<double> value(n, std::nan(""));
  auto value_at = [&](long i) {
    if (std::isnan(value[i])) {
      std::string who;
      value[i] = exact({tips_[i], axes_[i]}, &who);
      note(value[i], i, 0, who);
    }
    return value[i];
  };
  std::function<void(int)> node = [&](int id) {
    // Distances are never below 0: once the threshold is, nothing left can change the finding.
    if (threshold() <= 0) return;
    ++counts_.stretches;
    const Node& nd = nodes_[id];
    // A node is left alone when the height field shows every part clears the threshold over
    // it, or, once an interference is known, when the exact value at its centre less its
    // travel does (the value is 1-Lipschitz in the rigid travel; infinity only says the centre
    // clears, and proves nothing about the rest).
    if (stretch_clear({tips_[nd.centre], axes_[nd.centre]}, node_travel(0, nd)) ||
        (class1_.clearance_mm < c && std::isfinite(value_at(nd.centre)) &&
         value_at(nd.centre) - node_travel(0, nd) >= threshold())) {
      ++counts_.proven_by_bound;
      return;
    }
    if (nd.right < 0) {
      interval(nd.left, 0.0, 1.0, value_at(nd.left), value_at(nd.left + 1), 0);
      return;
    }
    node(nd.left);
    node(nd.right);
  };
  value_at(0);
  if (n > 1) node(0);
  class1_.interferes = class1_.clearance_mm < c;
}

CheckReport Checker::report(const Placement& p) {
  const QueryBudget budget(*this);
  MACHPLAN_ASSERT(std::abs(p.rotation_deg - rotation_deg_) < 1e-9, "checker built for rotation {}, asked {}", rotation_deg_,
                  p.rotation_deg);
  const CheckCounts before = counts_;
  ScanSettings s;
  s.report = true;
  s.best.assign(constraint_count_, kInf);
  s.best_pose.assign(constraint_count_, -1);
  s.best_t.assign(constraint_count_, 0.0);
  s.thr_ok = s.thr_fail = std::vector<double>(constraint_count_, -kInf);
  const Eigen::Vector3d offset = p.offset();
  scan(offset, s);

  CheckReport r;
  r.placement = p;
  const double c = scene_.safe_distance_mm;
  auto fill = [&](Kind k, int constraint) {
    Finding& f = r.kinds[static_cast<int>(k)];
    const double v = s.best[constraint];
    const bool violates = v < limit_[constraint];
    // Keep the worst: a violated constraint beats a clearance; among clearances the smallest.
    const bool take = f.pose < 0 || (violates && !f.interferes) ||
                      (violates == f.interferes && v - limit_[constraint] < f.clearance_mm - (f.interferes ? 0 : c));
    if (!take || s.best_pose[constraint] < 0) return;
    f = describe(constraint, interpolate(s.best_pose[constraint], s.best_t[constraint]), s.best_pose[constraint],
                 s.best_t[constraint], offset, v);
    f.interferes = violates;
  };
  fill(Kind::self, kStrutStrut);
  fill(Kind::self, kStroke);
  fill(Kind::self, kJoint);
  fill(Kind::workpiece_class2, kClass2);
  for (std::size_t k = 0; k < scene_.peripherals.size(); ++k) {
    fill(Kind::machine_peripheral, kFirstPeripheral + 2 * static_cast<int>(k));
    fill(Kind::machine_peripheral, kFirstPeripheral + 2 * static_cast<int>(k) + 1);
  }
  r.stroke_margin_mm = s.best[kStroke];
  r.joint_margin_deg = s.best[kJoint] / kDeg;
  // Self: when no limit is crossed, the row reports the strut clearance and where it is
  // smallest (the margins of the limits are printed separately).
  Finding& self = r.kinds[static_cast<int>(Kind::self)];
  if (!self.interferes && s.best_pose[kStrutStrut] >= 0)
    self = describe(kStrutStrut, interpolate(s.best_pose[kStrutStrut], s.best_t[kStrutStrut]), s.best_pose[kStrutStrut],
                    s.best_t[kStrutStrut], offset, s.best[kStrutStrut]);
  r.kinds[static_cast<int>(Kind::workpiece_class1)] = class1_;
  Finding& wpp = r.kinds[static_cast<int>(Kind::workpiece_peripheral)];
  wpp.clearance_mm = kInf;
  for (std::size_t k = 0; k < scene_.peripherals.size(); ++k) {
    Eigen::Vector2d e;
    const double v = workpiece_peripheral_value(offset, static_cast<int>(k), &e);
    if (v < wpp.clearance_mm) {
      wpp.clearance_mm = v;
      wpp.what = "workpiece and pad / " + scene_.peripherals[k].name;
      wpp.evasion = e;
      wpp.interferes = v < c;
    }
  }
  r.counts = counts_;
  r.counts.stretches -= before.stretches;
  r.counts.exact_queries -= before.exact_queries;
  r.counts.interpolated_poses -= before.interpolated_poses;
  r.counts.proven_by_bound -= before.proven_by_bound;
  return r;
}

Decision Checker::decide_workpiece_block(const Eigen::Vector3d& offset, double radius, Finding* witness) const {
  const double c = scene_.safe_distance_mm;
  bool all_clear = true;
  for (std::size_t k = 0; k < scene_.peripherals.size(); ++k) {
    Eigen::Vector2d e;
    const double v = workpiece_peripheral_value(offset, static_cast<int>(k), witness ? &e : nullptr, c + radius);
    if (v <= c - radius && !(radius == 0 && v >= c)) {
      if (witness) {
        *witness = Finding{};
        witness->interferes = true;
        witness->clearance_mm = v;
        witness->what = "workpiece and pad / " + scene_.peripherals[k].name;
        witness->evasion = e;
      }
      return Decision::infeasible;
    }
    if (v < c + radius) all_clear = false;
  }
  return all_clear ? Decision::feasible : Decision::unknown;
}

Decision Checker::decide(const Placement& p, double radius, Finding* witness, bool peripherals_first) {
  const QueryBudget budget(*this);
  const Eigen::Vector3d offset = p.offset();
  // Placement-only constraint first: the workpiece block against the peripherals.
  const Decision block = decide_workpiece_block(offset, radius, witness);
  if (block == Decision::infeasible) return Decision::infeasible;
  const bool all_clear = block == Decision::feasible;
  if (class1_.interferes) {
    if (witness) *witness = class1_;
    return Decision::infeasible;
  }
  ScanSettings s = decision_settings(radius);
  bool ok = true;
  if (peripherals_first && constraint_count_ > kFirstPeripheral) {
    s.mask = ~((1u << kFirstPeripheral) - 1);
    ok = scan(offset, s);
    s.mask = 0;
  }
  if (ok && scan(offset, s)) return all_clear ? Decision::feasible : Decision::unknown;
  if (s.failed_exact) {
    learn({s.failed_pose, s.failed_t, s.failed_constraint});
    if (witness) {
      *witness = describe(s.failed_constraint, interpolate(s.failed_pose, s.failed_t), s.failed_pose, s.failed_t, offset,
                          s.failed_value);
      witness->interferes = true;
    }
    return Decision::infeasible;
  }
  if (radius == 0) {
    // An interval that could not be proven at the finest subdivision counts against the
    // placement: the checker never calls free what it could not prove.
    if (witness) {
      *witness = describe(s.failed_constraint, interpolate(s.failed_pose, s.failed_t), s.failed_pose, s.failed_t, offset,
                          s.failed_value);
      witness->interferes = true;
    }
    return Decision::infeasible;
  }
  return Decision::unknown;
}

Checker::ScanSettings Checker::decision_settings(double radius) const {
  ScanSettings s;
  s.radius = radius;
  s.thr_ok.resize(constraint_count_);
  s.thr_fail.resize(constraint_count_);
  for (int k = 0; k < constraint_count_; ++k) {
    s.thr_ok[k] = limit_[k] + lipschitz(placement_lipschitz_[k], scene_.machine.kappa) * radius;
    // At radius 0 a value exactly at the limit is still allowed (not strictly below it).
    s.thr_fail[k] = radius > 0 ? limit_[k] - lipschitz(placement_lipschitz_[k], scene_.machine.kappa) * radius
                               : std::nextafter(limit_[k], -kInf);
  }
  return s;
}

double Checker::local_kappa(const double* v, double move_mm) const {
  // Moving the plate joints by at most `move_mm` (along the path, or by moving the workpiece)
  // turns a strut by at most (kappa + 1) move / L, so the struts' angles to their rails at the
  // pose (v[constraint_count_]) bound the slider-speed factor over that move, often far below
  // the machine-wide kappa.
  return hexam::slider_rate_bound(scene_.machine,
                                  v[constraint_count_] + (scene_.machine.kappa + 1) * move_mm / min_strut_mm_);
}

double Checker::fail_threshold(int c, const double* v, const ScanSettings& s) const {
  if (s.radius == 0) return s.thr_fail[c];
  return limit_[c] - lipschitz(placement_lipschitz_[c], local_kappa(v, s.radius)) * s.radius;
}

Decision Checker::probe(const Placement& p, double radius) {
  const QueryBudget budget(*this);
  // Looks only for an interference deep enough to condemn the whole ball, at tool poses, with
  // a bounded effort: first the limits and strut clearance (inverse kinematics only), then
  // the peripherals (FCL). Nodes whose lower bounds stay above the failure threshold are
  // dropped at once.
  if (class1_.interferes) return Decision::infeasible;
  const unsigned cheap = (1u << kStroke) | (1u << kJoint) | (1u << kStrutStrut);
  for (unsigned mask : {cheap, all_constraints() & ~cheap & ~(1u << kClass2)}) {
    if (!mask) continue;
    ScanSettings s = decision_settings(radius);
    s.skip_learned = s.poses_only = true;
    s.mask = mask;
    s.budget = kProbeBudget;
    s.thr_ok = s.thr_fail;
    if (!scan(p.offset(), s) && s.failed_exact) {
      learn({s.failed_pose, s.failed_t, s.failed_constraint});
      return Decision::infeasible;
    }
  }
  return Decision::unknown;
}

void Checker::learn(const Witness& w) {
  auto same = [&](const Witness& o) { return o.pose == w.pose && o.t == w.t && o.constraint == w.constraint; };
  const auto it = std::find_if(learned_.begin(), learned_.end(), same);
  if (it != learned_.end()) {
    std::rotate(learned_.begin(), it, it + 1);
    return;
  }
  Witness fresh = w;
  fresh.id = static_cast<int>(learned_.size());
  learned_.insert(learned_.begin(), fresh);
}

Decision Checker::screen(const Placement& p, double radius, std::uint64_t* settled) {
  const QueryBudget budget(*this);
  const Eigen::Vector3d offset = p.offset();
  if (class1_.interferes) return Decision::infeasible;
  const Decision block = decide_workpiece_block(offset, radius, nullptr);
  if (block == Decision::infeasible) return Decision::infeasible;
  bool all_clear = block == Decision::feasible;
  std::vector<double> v(stride_);
  for (std::size_t j = 0; j < learned_.size(); ++j) {
    const Witness w = learned_[j];
    const std::uint64_t bit = w.id < 64 ? std::uint64_t{1} << w.id : 0;
    if (settled && (*settled & bit)) continue;
    evaluate(interpolate(w.pose, w.t), offset, 1u << w.constraint, v.data(), nullptr);
    const double value = v[w.constraint],
                 lip = lipschitz(placement_lipschitz_[w.constraint], local_kappa(v.data(), radius)) * radius;
    const bool bad = radius > 0 ? value <= limit_[w.constraint] - lip : value < limit_[w.constraint];
    if (bad) {
      // Move it to the front: neighbouring boxes are likely to fall to the same one.
      std::rotate(learned_.begin(), learned_.begin() + static_cast<long>(j), learned_.begin() + static_cast<long>(j) + 1);
      return Decision::infeasible;
    }
    if (value < limit_[w.constraint] + lip)
      all_clear = false;
    else if (settled)
      *settled |= bit;
  }
  return all_clear ? Decision::feasible : Decision::unknown;
}

CheckReport Checker::dense_check(const Placement& p, double step_mm, const std::function<void(double)>& progress) {
  const QueryBudget budget(*this);
  const Eigen::Vector3d offset = p.offset();
  CheckReport r = report(p);  // class 1, workpiece-peripheral and the description fields
  std::vector<double> v(stride_), worst(constraint_count_, kInf);
  const long n = static_cast<long>(tips_.size());
  long evaluated = 0;
  double class1_worst = kInf;
  auto visit = [&](const Pose& pose) {
    evaluate(pose, offset, ~0u, v.data(), nullptr);
    class1_worst = std::min(class1_worst, class1_value(pose, nullptr));
    ++evaluated;
    for (int c = 0; c < constraint_count_; ++c) worst[c] = std::min(worst[c], v[c]);
  };
  for (long i = 0; i + 1 < n; ++i) {
    const double dtip = (tips_[i + 1] - tips_[i]).norm();
    const double th = std::atan2(axes_[i].cross(axes_[i + 1]).norm(), axes_[i].dot(axes_[i + 1]));
    const int sub = std::clamp(static_cast<int>(std::ceil(std::max(dtip / step_mm, th / (0.5 * kDeg)))), 1, 100000);
    for (int k = 0; k < sub; ++k) visit(interpolate(i, double(k) / sub));
    if (progress && i % 256 == 0) progress(static_cast<double>(i) / static_cast<double>(n));
  }
  visit({tips_[n - 1], axes_[n - 1]});
  if (class1_worst < scene_.safe_distance_mm) r.kinds[static_cast<int>(Kind::workpiece_class1)].interferes = true;
  r.counts = CheckCounts{};
  r.counts.exact_queries = evaluated;
  for (int c = 0; c < constraint_count_; ++c) {
    const Kind k = c == kClass2 ? Kind::workpiece_class2 : c >= kFirstPeripheral ? Kind::machine_peripheral : Kind::self;
    Finding& f = r.kinds[static_cast<int>(k)];
    if (worst[c] < limit_[c]) f.interferes = true;
  }
  return r;
}

}  // namespace machplan::placement
