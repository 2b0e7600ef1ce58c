#include "solvers/placement/machines/trunnion_model.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "engine/common/error.h"
#include "engine/interference/collision.h"
#include "solvers/placement/machines/internal/bounds.h"
#include "solvers/placement/scene/scene.h"
#include "solvers/placement/scene/internal/workpiece.h"

namespace machplan::placement {

namespace {
// The workpiece mesh itself is measured only within this of the safe distance.
constexpr double kMeshSlack_mm = 10.0;
// A flip: the table turning more than a quarter turn within one step of the path.
constexpr double kFlipRad = M_PI / 2;
// What a flip costs when the inverse-kinematics branches are chosen along the path, against
// rotary travel in radians: any flip that can be avoided is.
constexpr double kFlipCost = 1000.0;

enum : int { kLinear = 0, kRotary = 1, kWorkpiece = 2, kFirstPart = 3 };

// A solid of the machine as the evaluators use it.
struct MachineSolid {
  std::string name;
  int body = 0;                  // 0 base, 1 tilt body, 2 table body
  Eigen::Isometry3d T_zero = Eigen::Isometry3d::Identity();  // its pose with every axis at zero
  interference::Shape shape = interference::Shape::sphere(1.0);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // bounding sphere, machine frame at zero
  double radius = 0.0;
};

double wrap(double a) { return std::remainder(a, 2 * M_PI); }

class TrunnionModel;

class TrunnionEvaluator final : public PoseEvaluator {
 public:
  explicit TrunnionEvaluator(const TrunnionModel& model);
  void evaluate(const PathPose& pose, const Where& where, Mask mask, double* v) override { run(pose, where, mask, v, nullptr); }
  void describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) override;
  double placement_value(int k, const Where& where, double enough, Finding* f) override;

 private:
  struct Detail {
    std::string what[64];
  };
  struct State {
    Eigen::Isometry3d T_table, T_tilt;
    Eigen::Vector3d tip, p;  // machine frame, table frame
    double a = 0, c = 0;
  };
  void run(const PathPose& pose, const Where& where, Mask mask, double* v, Detail* d);
  // The parts of run(): axis margins and extras, the tool assembly's parts, the workpiece, the
  // peripherals, each against the machine's solids.
  void limits(const State& st, const Where& where, double* v, Detail* d) const;
  void parts_to_machine(const State& st, Mask mask, double* v, Detail* d);
  void workpiece_to_machine(const State& st, const Where& where, Mask mask, double* v, Detail* d);
  void peripherals_to_machine(const State& st, Mask mask, double* v, Detail* d);
  Eigen::Isometry3d solid_pose(const MachineSolid& s, const State& st) const;
  // The tool assembly (from the tip along the spindle) against a solid; `part` names the closest.
  double assembly_to(const State& st, const interference::Shape& shape, const Eigen::Isometry3d& T,
                     const Eigen::Vector3d& centre, double radius, double enough, int* part);

  const TrunnionModel& model_;
  std::vector<interference::Shape> assembly_;  // per assembly part
  std::vector<interference::Shape> tool_;      // tool parts (support)
  std::vector<interference::Shape> solids_;    // per machine solid
  std::vector<interference::Shape> periph_;    // per peripheral
  interference::Shape workpiece_;
};

class TrunnionModel final : public MachineModel {
 public:
  TrunnionModel(const trunnion::Machine& m, const Scene& scene, const Tooling& tooling)
      : m_(m), c_(scene.safe_distance_mm), peripherals_(scene.peripherals), wp_(workpiece_solid(scene)) {
    gauge_mm_ = tooling.stick_out_mm + tooling.chuck_length_mm;
    tool_ = tool_stack(tooling);
    assembly_ = tool_;
    for (const auto& sp : m.spindle)
      assembly_.push_back({sp.name, gauge_mm_ + sp.from_mm, gauge_mm_ + sp.to_mm, sp.radius_mm, false, ToolPart::Class::class1});
    for (const auto& p : assembly_) reach_ = std::max(reach_, std::hypot(p.to_mm, p.radius_mm));
    for (const auto& p : tool_) tool_reach_ = std::max(tool_reach_, std::hypot(p.to_mm, p.radius_mm));
    add_solids(m.base, 0);
    add_solids(m.tilt.solids, 1);
    add_solids(m.table.solids, 2);
    // Global bounds of the distances from the rotary axes (for bounds that hold everywhere).
    double tip_max = 0;
    for (const auto& t : scene.tips_mm) tip_max = std::max(tip_max, t.norm());
    const double reach_o = std::hypot(m.table_radius_mm, scene.search.pad_max_mm);
    e0_global_ = tip_max + reach_o + m.axes_offset_mm;
    e1_global_ = reach_o + wp_.bounds.max().norm() + wp_.bounds.min().norm() + m.axes_offset_mm;
    for (const auto& per : peripherals_) {
      double r = 0;
      for (int k = 0; k < 8; ++k)
        r = std::max(r, Eigen::Vector3d(k & 1 ? per.bounds.max().x() : per.bounds.min().x(),
                                        k & 2 ? per.bounds.max().y() : per.bounds.min().y(),
                                        k & 4 ? per.bounds.max().z() : per.bounds.min().z())
                            .norm());
      periph_radius_.push_back(r + m.axes_offset_mm);
    }
    using M = Constraint::Margin;
    constraints_ = {{"linear travel", Kind::self, 0.0, 0.25, false, false, 1.0, M::travel, true},
                    {"rotary travel", Kind::self, 0.0, 0.005, false, false, 100.0, M::joint, true},
                    {"workpiece / machine", Kind::workpiece_class2, c_, 0.25, true, false, 1.0, M::none, false}};
    // Each part of the tool assembly against the machine's solids on its own: a part moves as
    // far as its own reach from the tip says, and the far ones (the spindle housing) are rarely
    // the close ones.
    for (const auto& p : assembly_) {
      constraints_.push_back({p.name + " / machine", Kind::self, c_, 0.25, true, false, 1.0, M::none, false});
      part_reach_.push_back(std::hypot(p.to_mm, p.radius_mm));
    }
    periph0_ = count();
    for (const auto& p : peripherals_) {
      constraints_.push_back({"tool assembly / " + p.name, Kind::machine_peripheral, c_, 0.25, true, false, 1.0, M::none, false});
      constraints_.push_back({p.name + " / machine", Kind::machine_peripheral, c_, 0.25, true, false, 1.0, M::none, false});
    }
    support_ = count();
    constraints_.push_back({"tool / support", Kind::tool_support, c_, 0.25, true, false, 1.0, M::none, false});
    // The fixture grows downwards as it gets taller: the tool's clearance to it never rises.
    constraints_.back().pad_trend = -1;
    extras_ = 2;  // the tip's and the workpiece block's farthest distance from the rotary axes
    placement_count_ = static_cast<int>(peripherals_.size());
    MACHPLAN_ASSERT(count() <= 64, "too many constraints: {}", count());
  }

  std::string kind() const override { return "table_tilting"; }
  std::string name() const override { return m_.name; }
  std::unique_ptr<PoseEvaluator> evaluator() const override { return std::make_unique<TrunnionEvaluator>(*this); }

  double fall(int c, const double* v, const Motion& mo) const override {
    const double e0 = (v ? v[count()] : e0_global_) + mo.tip_mm;
    const double e1 = (v ? v[count() + 1] : e1_global_) + mo.workpiece_mm;
    if (c == kLinear) return mo.tip_mm + e0 * mo.joints_rad;
    if (c == kRotary) return mo.joints_rad;
    if (c == kWorkpiece) return e1 * mo.joints_rad + mo.workpiece_mm;
    if (c == support_) return (mo.along_path ? mo.tip_mm + tool_reach_ * mo.axis_rad : 0.0) + mo.pad_mm;
    if (c < periph0_) return mo.tip_mm + (e0 + part_reach_[c - kFirstPart]) * mo.joints_rad;
    const int k = (c - periph0_) / 2;
    return (c - periph0_) % 2 == 0 ? mo.tip_mm + reach_ * mo.joints_rad : periph_radius_[k] * mo.joints_rad;
  }

  std::optional<std::pair<long, std::string>> prepare(std::vector<PathPose>& poses) const override;

  PathPose interpolate(const PathPose& a, const PathPose& b, double t) const override {
    if (t <= 0) return a;
    if (t >= 1) return b;
    PathPose p;
    p.tip = (1 - t) * a.tip + t * b.tip;
    p.a_rad = (1 - t) * a.a_rad + t * b.a_rad;
    p.c_rad = (1 - t) * a.c_rad + t * b.c_rad;
    p.axis = trunnion::axis_at(m_, p.a_rad, p.c_rad);
    return p;
  }
  Motion motion_between(const PathPose& a, const PathPose& b) const override {
    const double da = std::abs(b.a_rad - a.a_rad), dc = std::abs(b.c_rad - a.c_rad);
    // The axis turns with the tilt, and with the table as far as it leans off the table's axis.
    const double lean = std::max(tilt_of(a.axis), tilt_of(b.axis)) + da;
    return {(b.tip - a.tip).norm(), da + dc * std::sin(std::min(M_PI / 2, lean)), da + dc, 0.0, 0.0, true};
  }
  double axis_weight_mm() const override { return reach_; }
  double joint_weight_mm() const override { return reach_ + 100.0; }

  std::vector<AxialPart> class1_parts() const override {
    std::vector<AxialPart> out;
    for (const auto& p : assembly_)
      if (p.cls == ToolPart::Class::class1) out.push_back(p);
    return out;
  }
  double assembly_reach_mm() const override { return reach_; }
  double assembly_motion_mm(const Motion& mo) const override { return mo.tip_mm + reach_ * mo.axis_rad; }
  std::vector<AxialPart> tool_parts() const override { return tool_; }
  TableShape table() const override { return {true, Eigen::Vector2d::Constant(m_.table_radius_mm)}; }

  WorkOffset work_offset(const Placement& p, const Eigen::Vector3d& origin_w) const override {
    const Where w = Where::of(p);
    const Eigen::Vector3d nose = m_.table_pose(0, 0) * (w.R * origin_w + w.offset);
    return {fmt::format("machine zero at {} 0 {} 0, tool length by G43", m_.tilt.name, m_.table.name),
            m_.axes_for_nose(nose), p.rotation_deg == 0 ? 0.0 : -p.rotation_deg, m_.table.name};
  }

  bool affine_axes() const override { return true; }
  std::optional<AxisPath> axis_path(const std::vector<PathPose>& poses, const std::vector<double>& feeds,
                                    double rotation_rad) const override;
  bool rotation_is_position() const override { return m_.table.continuous; }
  // The spindle is the tool axis: drawing the tool back raises the nose one for one.
  NoseHeight nose_height(const PathPose& pose, const Where& where, double gauge) const override {
    const Eigen::Vector3d nose =
        m_.table_pose(pose.a_rad, pose.c_rad - where.rotation_rad) * (where.R * pose.tip + where.offset) +
        gauge * m_.spindle_direction;
    return {(m_.table_pose(0, 0).inverse() * nose).dot(m_.spindle_direction), 1.0};
  }
  // The axes linear from a to b: poses at most 1 deg of either rotary axis apart.
  std::vector<PathPose> axis_move(const PathPose& a, const PathPose& b, const Where& w, double gauge) const override {
    const double ca = a.c_rad - w.rotation_rad, cb = b.c_rad - w.rotation_rad;
    auto nose = [&](const PathPose& p, double c) {
      return Eigen::Vector3d(m_.table_pose(p.a_rad, c) * (w.R * p.tip + w.offset) + gauge * m_.spindle_direction);
    };
    const Eigen::Vector3d na = nose(a, ca), nb = nose(b, cb);
    const double turn = std::max(std::abs(b.a_rad - a.a_rad), std::abs(cb - ca));
    const int n = std::clamp(static_cast<int>(std::ceil(turn / (M_PI / 180.0))), 1, 720);
    std::vector<PathPose> out;
    for (int k = 0; k <= n; ++k) {
      const double t = static_cast<double>(k) / n;
      const double ak = a.a_rad + t * (b.a_rad - a.a_rad), ck = ca + t * (cb - ca);
      const Eigen::Isometry3d T = m_.table_pose(ak, ck).inverse();
      const Eigen::Vector3d tip = T * (na + t * (nb - na) - gauge * m_.spindle_direction);
      out.push_back({w.R.transpose() * (tip - w.offset), w.R.transpose() * (T.linear() * m_.spindle_direction), ak,
                     ck + w.rotation_rad});
    }
    out.front() = a, out.back() = b;
    return out;
  }

  double tilt_of(const Eigen::Vector3d& axis) const {
    return angle_between(axis, m_.table_frame.transpose() * m_.table.direction);
  }

  const trunnion::Machine& machine() const { return m_; }
  double safe() const { return c_; }
  int support() const { return support_; }
  int first_peripheral() const { return periph0_; }
  double gauge_mm() const { return gauge_mm_; }
  const std::vector<AxialPart>& assembly() const { return assembly_; }
  const std::vector<AxialPart>& tool() const { return tool_; }
  const std::vector<MachineSolid>& solids() const { return solids_; }
  const std::vector<Peripheral>& peripherals() const { return peripherals_; }
  const WorkpieceSolid& workpiece() const override { return wp_; }

 private:
  void add_solids(const std::vector<trunnion::Solid>& list, int body) {
    for (const auto& s : list) {
      MachineSolid ms;
      ms.name = s.name;
      ms.body = body;
      if (s.shape == trunnion::Solid::Shape::box) {
        ms.shape = interference::Shape::box(s.size_mm);
        ms.T_zero.linear() = s.R;
        ms.T_zero.translation() = s.centre_mm;
        ms.centre = s.centre_mm;
        ms.radius = s.size_mm.norm() / 2;
      } else if (s.shape == trunnion::Solid::Shape::cylinder) {
        ms.shape = interference::Shape::cylinder(s.radius_mm, s.length_mm);
        ms.T_zero.linear() = s.R;
        ms.T_zero.translation() = s.centre_mm;
        ms.centre = s.centre_mm;
        ms.radius = std::hypot(s.radius_mm, s.length_mm / 2);
      } else {
        ms.shape = interference::Shape::mesh(s.vertices, s.triangles);
        Eigen::AlignedBox3d b;
        for (const auto& v : s.vertices) b.extend(v);
        ms.centre = b.center();
        ms.radius = b.sizes().norm() / 2;
      }
      solids_.push_back(std::move(ms));
    }
  }

  trunnion::Machine m_;
  double c_;
  std::vector<Peripheral> peripherals_;
  WorkpieceSolid wp_;
  std::vector<AxialPart> tool_, assembly_;
  std::vector<MachineSolid> solids_;
  std::vector<double> periph_radius_, part_reach_;
  int periph0_ = 0;
  double gauge_mm_ = 0, reach_ = 0, tool_reach_ = 0, e0_global_ = 0, e1_global_ = 0;
  int support_ = 0;
};

std::optional<std::pair<long, std::string>> TrunnionModel::prepare(std::vector<PathPose>& poses) const {
  // Shortest path over the inverse-kinematics solutions of every pose: cost the rotary travel
  // plus kFlipCost per flip. A singular pose (tool along the table's axis) keeps the table
  // where the pose before it left it.
  struct State {
    double cost = kInf;
    int pred = -1;
    double a = 0, c = 0;
    bool singular = false;
  };
  const std::size_t n = poses.size();
  std::vector<std::array<State, 2>> dp(n);
  std::vector<int> count(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<trunnion::Angles> sol = trunnion::solve_angles(m_, poses[i].axis);
    const bool singular = sol.size() == 1 && tilt_of(poses[i].axis) < 1e-9;
    std::vector<trunnion::Angles> ok;
    for (const auto& s : sol)
      if (m_.tilt.within(s.a_rad)) ok.push_back(s);
    if (ok.empty()) {
      const double tilt = tilt_of(poses[i].axis) / kDeg;
      return std::make_pair(static_cast<long>(i),
                            sol.empty() ? fmt::format("tool axis tilts {:.1f} deg from the rotary table's axis; this machine "
                                                      "cannot turn it onto its spindle",
                                                      tilt)
                                        : fmt::format("tool axis tilts {:.1f} deg; the {} axis would need {:.1f} deg, outside "
                                                      "its travel {:.0f} .. {:.0f} deg",
                                                      tilt, m_.tilt.name, sol.front().a_rad / kDeg, m_.tilt.min_rad / kDeg,
                                                      m_.tilt.max_rad / kDeg));
    }
    count[i] = static_cast<int>(ok.size());
    for (int j = 0; j < count[i]; ++j) {
      State& st = dp[i][j];
      st.a = ok[j].a_rad;
      st.singular = singular;
      if (i == 0) {
        st.cost = 0;
        st.c = ok[j].c_rad;
        continue;
      }
      for (int k = 0; k < count[i - 1]; ++k) {
        const State& pr = dp[i - 1][k];
        const double c = singular ? pr.c : pr.c + wrap(ok[j].c_rad - pr.c);
        const double dc = std::abs(c - pr.c);
        const double cost = pr.cost + std::abs(st.a - pr.a) + dc + (dc > kFlipRad ? kFlipCost : 0.0);
        if (cost < st.cost) st.cost = cost, st.pred = k, st.c = c;
      }
    }
  }
  if (n == 0) return std::nullopt;
  int j = 0;
  for (int k = 1; k < count[n - 1]; ++k)
    if (dp[n - 1][k].cost < dp[n - 1][j].cost) j = k;
  for (std::size_t i = n; i-- > 0;) {
    poses[i].a_rad = dp[i][j].a;
    poses[i].c_rad = dp[i][j].c;
    j = std::max(dp[i][j].pred, 0);
  }
  return std::nullopt;
}

std::optional<AxisPath> TrunnionModel::axis_path(const std::vector<PathPose>& poses, const std::vector<double>& feeds,
                                                 double rotation_rad) const {
  AxisPath ap;
  ap.names = {m_.linear[0].name, m_.linear[1].name, m_.linear[2].name, m_.tilt.name, m_.table.name};
  ap.speed << m_.linear[0].feed_mm_per_s, m_.linear[1].feed_mm_per_s, m_.linear[2].feed_mm_per_s, m_.tilt.feed_rad_per_s,
      m_.table.feed_rad_per_s;
  ap.rapid << m_.linear[0].rapid_mm_per_s, m_.linear[1].rapid_mm_per_s, m_.linear[2].rapid_mm_per_s, m_.tilt.rapid_rad_per_s,
      m_.table.rapid_rad_per_s;
  if (m_.dynamics_missing.empty()) {
    motion::AxisLimits l;
    l.names = ap.names;
    l.velocity.head<5>() = ap.speed;
    l.rapid_velocity.head<5>() = ap.rapid;
    l.acceleration = motion::five_axis(m_.linear[0].accel_mm_per_s2, m_.linear[1].accel_mm_per_s2,
                                       m_.linear[2].accel_mm_per_s2, m_.tilt.accel_rad_per_s2, m_.table.accel_rad_per_s2);
    l.jerk = motion::five_axis(m_.linear[0].jerk_mm_per_s3, m_.linear[1].jerk_mm_per_s3, m_.linear[2].jerk_mm_per_s3,
                               m_.tilt.jerk_rad_per_s3, m_.table.jerk_rad_per_s3);
    l.feed = m_.feed_on_axes ? motion::AxisLimits::Feed::axes : motion::AxisLimits::Feed::tip;
    ap.limits = l;
  }
  ap.feed_on_axes = m_.feed_on_axes;
  ap.dynamics_missing = m_.dynamics_missing;
  ap.dynamics_file = m_.source;
  ap.dynamics_line = m_.dynamics_missing_line;
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(rotation_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Matrix3d D;
  for (int k = 0; k < 3; ++k) D.row(k) = m_.linear[k].direction.transpose();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Isometry3d T = m_.table_pose(poses[i].a_rad, poses[i].c_rad - rotation_rad);
    ap.M.push_back(D * T.linear());
    ap.b.push_back(D * (T.linear() * (Rz * poses[i].tip) + T.translation() + gauge_mm_ * m_.spindle_direction - m_.nose_mm));
    ap.rotary_rad.push_back({poses[i].a_rad, poses[i].c_rad});
    ap.feed_mm_per_s.push_back(i < feeds.size() ? feeds[i] / 60.0 : 0.0);
    ap.tip_step_mm.push_back(i > 0 ? (poses[i].tip - poses[i - 1].tip).norm() : 0.0);
    if (i > 0 && std::abs(poses[i].c_rad - poses[i - 1].c_rad) > kFlipRad) {
      ++ap.flips;
      ap.flip_poses.push_back(static_cast<long>(i));
    }
  }
  // The branches were chosen with the fewest flips: every one left is forced by the limits.
  ap.forced_flips = ap.flips;
  return ap;
}

TrunnionEvaluator::TrunnionEvaluator(const TrunnionModel& model)
    : model_(model), workpiece_(model.workpiece().mesh()) {
  assembly_ = axial_shapes(model.assembly());
  tool_ = axial_shapes(model.tool());
  for (const auto& s : model.solids()) solids_.push_back(s.shape.copy());
  for (const auto& p : model.peripherals()) periph_.push_back(p.shape.copy());
}

Eigen::Isometry3d TrunnionEvaluator::solid_pose(const MachineSolid& s, const State& st) const {
  const trunnion::Machine& m = model_.machine();
  if (s.body == 0) return s.T_zero;
  if (s.body == 1) return st.T_tilt * s.T_zero;
  // The table body turns with both axes: the tilt, then the table about its own axis.
  Eigen::Isometry3d Rc = Eigen::Isometry3d::Identity();
  Rc.linear() = Eigen::AngleAxisd(st.c, m.table.direction).toRotationMatrix();
  Rc.translation() = m.table.point_mm - Rc.linear() * m.table.point_mm;
  return st.T_tilt * Rc * s.T_zero;
}

double TrunnionEvaluator::assembly_to(const State& st, const interference::Shape& shape, const Eigen::Isometry3d& T,
                                      const Eigen::Vector3d& centre, double radius, double enough, int* part) {
  const Eigen::Vector3d s = model_.machine().spindle_direction;
  double best = kInf;
  for (std::size_t k = 0; k < model_.assembly().size(); ++k) {
    const AxialPart& ap = model_.assembly()[k];
    const Eigen::Vector3d a = st.tip + s * ap.from_mm, b = st.tip + s * ap.to_mm;
    // Segment to sphere: a lower bound.
    const Eigen::Vector3d d = b - a;
    const double t = std::clamp((centre - a).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
    double dist = std::max(0.0, (a + t * d - centre).norm() - radius - ap.radius_mm);
    if (dist >= best) continue;
    if (dist < enough) dist = interference::distance(assembly_[k], interference::segment_pose(a, b), shape, T).distance_mm;
    if (dist < best) {
      best = dist;
      if (part) *part = static_cast<int>(k);
    }
  }
  return best;
}

void TrunnionEvaluator::limits(const State& st, const Where& where, double* v, Detail* d) const {
  const trunnion::Machine& m = model_.machine();
  const int n = model_.count();
  // Linear axes: the spindle nose at the tip plus the tool's gauge length.
  const Eigen::Vector3d q = m.axes_for_nose(st.tip + model_.gauge_mm() * m.spindle_direction);
  v[kLinear] = kInf;
  for (int k = 0; k < 3; ++k) {
    const double margin = std::min(q(k) - m.linear[k].min_mm, m.linear[k].max_mm - q(k));
    if (margin < v[kLinear]) {
      v[kLinear] = margin;
      if (d) d->what[kLinear] = fmt::format("{} {:.1f} mm from its end ({:.1f} mm)", m.linear[k].name, margin, q(k));
    }
  }
  v[kRotary] = m.tilt.continuous ? kInf : std::min(st.a - m.tilt.min_rad, m.tilt.max_rad - st.a);
  if (d) d->what[kRotary] = fmt::format("{} {:.1f} deg from its limit ({:.1f} deg)", m.tilt.name, v[kRotary] / kDeg, st.a / kDeg);
  if (!m.table.continuous) {
    const double cm = std::min(st.c - m.table.min_rad, m.table.max_rad - st.c);
    if (cm < v[kRotary]) {
      v[kRotary] = cm;
      if (d) d->what[kRotary] = fmt::format("{} {:.1f} deg from its limit ({:.1f} deg)", m.table.name, cm / kDeg, st.c / kDeg);
    }
  }
  // Extras: the tip's and the block's farthest distance from the rotary axes.
  v[n] = st.p.norm() + m.axes_offset_mm;
  double block = 0;
  for (int k = 0; k < 8; ++k) {
    const auto& b = model_.workpiece().bounds;
    const Eigen::Vector3d corner(k & 1 ? b.max().x() : b.min().x(), k & 2 ? b.max().y() : b.min().y(),
                                 k & 4 ? b.max().z() : -where.offset.z());
    block = std::max(block, (where.R * corner + where.offset).norm());
  }
  v[n + 1] = block + m.axes_offset_mm;
}

void TrunnionEvaluator::parts_to_machine(const State& st, Mask mask, double* v, Detail* d) {
  const trunnion::Machine& m = model_.machine();
  const double enough = model_.safe() + kSlack_mm;
  const auto& solids = model_.solids();
  // Each part of the tool assembly against the machine's solids.
  const Eigen::Vector3d sdir = m.spindle_direction;
  for (std::size_t k = 0; k < model_.assembly().size(); ++k) {
    const int ci = kFirstPart + static_cast<int>(k);
    v[ci] = kInf;
    if (!(mask & bit(ci))) continue;
    const AxialPart& ap = model_.assembly()[k];
    const Eigen::Vector3d a = st.tip + sdir * ap.from_mm, b = st.tip + sdir * ap.to_mm;
    for (std::size_t j = 0; j < solids.size(); ++j) {
      const Eigen::Isometry3d T = solid_pose(solids[j], st);
      const Eigen::Vector3d centre = T * (solids[j].T_zero.inverse() * solids[j].centre);
      // Segment to sphere: a lower bound first.
      const Eigen::Vector3d dd = b - a;
      const double t = std::clamp((centre - a).dot(dd) / std::max(dd.squaredNorm(), 1e-12), 0.0, 1.0);
      double dist = std::max(0.0, (a + t * dd - centre).norm() - solids[j].radius - ap.radius_mm);
      if (dist >= v[ci]) continue;
      if (dist < enough) dist = interference::distance(assembly_[k], interference::segment_pose(a, b), solids_[j], T).distance_mm;
      if (dist < v[ci]) {
        v[ci] = dist;
        if (d) d->what[ci] = ap.name + " / " + solids[j].name;
      }
    }
  }
}

void TrunnionEvaluator::workpiece_to_machine(const State& st, const Where& where, Mask mask, double* v, Detail* d) {
  const double enough = model_.safe() + kSlack_mm;
  const auto& solids = model_.solids();
  // The workpiece and its fixture against the cradle and the end supports.
  v[kWorkpiece] = kInf;
  const WorkpieceSolid& wp = model_.workpiece();
  if (mask & bit(kWorkpiece)) {
    const Eigen::Isometry3d T_block = st.T_table * wp.block_pose(where);
    const auto block_shape = interference::Shape::box(2 * wp.block_half(where.offset.z()));
    const double block_r = wp.block_half(where.offset.z()).norm();
    for (std::size_t k = 0; k < solids.size(); ++k) {
      if (solids[k].body == 2) continue;  // the table carries the fixture
      const Eigen::Isometry3d T = solid_pose(solids[k], st);
      const Eigen::Vector3d centre = T * (solids[k].T_zero.inverse() * solids[k].centre);
      double dist = std::max(0.0, (centre - T_block.translation()).norm() - solids[k].radius - block_r);
      if (dist < enough) dist = interference::distance(block_shape, T_block, solids_[k], T).distance_mm;
      // The block is a hull of the workpiece and its fixture: the real solids only when it comes
      // close (a mesh distance over a large flat face costs a millisecond).
      if (dist < model_.safe() + kMeshSlack_mm) {
        // The block is only a hull: the real solid and the fixture separately.
        Eigen::Isometry3d T_wp = Eigen::Isometry3d::Identity();
        T_wp.linear() = where.R;
        T_wp.translation() = where.offset;
        dist = interference::distance(workpiece_, st.T_table * T_wp, solids_[k], T).distance_mm;
        const double pad = where.offset.z();
        if (pad > 1e-9) {
          Eigen::Isometry3d Tp = Eigen::Isometry3d::Identity();
          Tp.linear() = where.R;
          Tp.translation() = where.R * Eigen::Vector3d(wp.bounds.center().x(), wp.bounds.center().y(), -pad / 2) + where.offset;
          const Eigen::Vector3d size(wp.bounds.sizes().x(), wp.bounds.sizes().y(), pad);
          dist = std::min(dist, interference::distance(interference::Shape::box(size), st.T_table * Tp, solids_[k], T).distance_mm);
        }
      }
      if (dist < v[kWorkpiece]) {
        v[kWorkpiece] = dist;
        if (d) d->what[kWorkpiece] = "workpiece and fixture / " + solids[k].name;
      }
    }
  }
}

void TrunnionEvaluator::peripherals_to_machine(const State& st, Mask mask, double* v, Detail* d) {
  const double enough = model_.safe() + kSlack_mm;
  const auto& solids = model_.solids();
  // Peripherals on the table: the tool assembly against each, each against the cradle.
  const auto& pers = model_.peripherals();
  for (std::size_t p = 0; p < pers.size(); ++p) {
    const int ci = model_.first_peripheral() + 2 * static_cast<int>(p);
    const Eigen::Isometry3d T = st.T_table * pers[p].T_table_peripheral;
    const Eigen::Vector3d centre = st.T_table * pers[p].bounds.center();
    const double radius = pers[p].bounds.sizes().norm() / 2;
    v[ci] = v[ci + 1] = kInf;
    if (mask & bit(ci)) {
      int part = -1;
      v[ci] = assembly_to(st, periph_[p], T, centre, radius, enough, &part);
      if (d && part >= 0) d->what[ci] = model_.assembly()[part].name + " / " + pers[p].name;
    }
    if (mask & bit(ci + 1))
      for (std::size_t k = 0; k < solids.size(); ++k) {
        if (solids[k].body == 2) continue;
        const Eigen::Isometry3d Ts = solid_pose(solids[k], st);
        const Eigen::Vector3d sc = Ts * (solids[k].T_zero.inverse() * solids[k].centre);
        double dist = std::max(0.0, (sc - centre).norm() - solids[k].radius - radius);
        if (dist < enough) dist = interference::distance(periph_[p], T, solids_[k], Ts).distance_mm;
        if (dist < v[ci + 1]) {
          v[ci + 1] = dist;
          if (d) d->what[ci + 1] = pers[p].name + " / " + solids[k].name;
        }
      }
  }
}

void TrunnionEvaluator::run(const PathPose& pose, const Where& where, Mask mask, double* v, Detail* d) {
  const trunnion::Machine& m = model_.machine();
  const double enough = model_.safe() + kSlack_mm;
  State st;
  st.a = pose.a_rad;
  st.c = pose.c_rad - where.rotation_rad;
  st.p = where.R * pose.tip + where.offset;
  st.T_table = m.table_pose(st.a, st.c);
  st.T_tilt = m.tilt_pose(st.a);
  st.tip = st.T_table * st.p;
  limits(st, where, v, d);
  parts_to_machine(st, mask, v, d);
  workpiece_to_machine(st, where, mask, v, d);
  peripherals_to_machine(st, mask, v, d);
  const WorkpieceSolid& wp = model_.workpiece();
  const int support = model_.support();
  int part = -1;
  v[support] = (mask & bit(support))
                   ? support_clearance(model_.tool(), tool_, wp, pose, where.offset.z(), false, enough, &part)
                   : kInf;
  if (d) d->what[support] = (part >= 0 ? model_.tool()[part].name : std::string("tool")) + " / fixture";
}

void TrunnionEvaluator::describe(int c, const PathPose& pose, const Where& where, double value, Finding& f) {
  Detail d;
  std::vector<double> v(model_.stride());
  run(pose, where, ~Mask{0}, v.data(), &d);
  f.what = d.what[c];
  f.evasion = Eigen::Vector2d::Zero();
}

double TrunnionEvaluator::placement_value(int k, const Where& where, double enough, Finding* f) {
  const Peripheral& per = model_.peripherals()[k];
  const WorkpieceSolid& wp = model_.workpiece();
  if (f) f->what = "workpiece and fixture / " + per.name;
  const double lower = aabb_distance(wp.block_bounds(where), per.bounds);
  if (lower >= enough) return lower;
  return interference::distance(interference::Shape::box(2 * wp.block_half(where.offset.z())), wp.block_pose(where), periph_[k],
                                per.T_table_peripheral)
      .distance_mm;
}

}  // namespace

std::shared_ptr<const MachineModel> make_trunnion_model(const trunnion::Machine& machine, const Scene& scene,
                                                       const Tooling& tooling) {
  return std::make_shared<TrunnionModel>(machine, scene, tooling);
}

}  // namespace machplan::placement
