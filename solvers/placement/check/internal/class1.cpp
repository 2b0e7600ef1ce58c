#include "solvers/placement/check/internal/class1.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include <tbb/parallel_for.h>

#include "solvers/placement/machines/internal/bounds.h"

namespace machplan::placement {

namespace {
// The walk is split into the subtrees at this depth of the pose tree (32 of them).
constexpr int kSplitDepth = 5;
}  // namespace

Class1Check::Class1Check(const MachineModel& model, const PoseTree& tree, const WorkpieceSolid& workpiece, double safe_mm)
    : model_(model), tree_(tree), wp_(workpiece), safe_(safe_mm), parts_(model.class1_parts()), ring_(model.plate_ring()) {
  height_field_ = std::make_unique<interference::HeightField>(
      wp_.vertices, wp_.triangles, 2.0, Eigen::AlignedBox2d(wp_.bounds.min().head<2>(), wp_.bounds.max().head<2>()), 0.0);
}

Class1Check::Shapes Class1Check::make_shapes() const {
  Shapes s{axial_shapes(parts_), interference::Shape::sphere(1.0), wp_.mesh()};
  if (ring_) {
    s.parts.push_back(interference::Shape::cylinder(ring_->radius_mm() + ring_->sphere_radius_mm, 2 * ring_->sphere_radius_mm));
    s.hinge = interference::Shape::sphere(ring_->sphere_radius_mm);
  }
  return s;
}

// One subtree's walk, with its own record.
struct Class1Check::Walk {
  const Class1Check& c;
  std::optional<double> rotation;
  Termination& term;
  Shapes& shapes;
  std::vector<AxialPart> parts;  // the axial parts, and the ring when checking every rotation
  std::size_t shape0 = 0;        // parts[k]'s collision object is shapes.parts[shape0 + k]
  std::vector<Eigen::Vector3d> hinges;  // plate frame, turned by -rotation (exact mode)
  Finding f;
  CheckCounts counts;
  std::unordered_map<long, double> values;

  double threshold() const {
    // What a pose or stretch must be shown to clear: the safe distance until an interference
    // is known; after that only a smaller clearance can change the finding.
    const double best = f.clearance_mm;
    return best < c.safe_ ? best - report_margin(best, c.safe_, 0.25) : c.safe_;
  }

  // The part's box swept by sweep_mm stays at least threshold_mm from the workpiece: the
  // solid under the swept box (grown by the threshold sideways) stays that far below it.
  bool box_clear(Eigen::AlignedBox3d b, double sweep, double threshold_mm) const {
    b.min().array() -= sweep;
    b.max().array() += sweep;
    const double grow = std::max(threshold_mm, 0.0);
    const double h = c.height_field_->max_height(b.min().head<2>() - Eigen::Vector2d::Constant(grow),
                                                 b.max().head<2>() + Eigen::Vector2d::Constant(grow));
    return b.min().z() - h >= threshold_mm;
  }

  Eigen::AlignedBox3d hinge_box(const PathPose& pose) const {
    const Eigen::Matrix3d R = c.model_.plate_rotation(pose.axis);
    Eigen::AlignedBox3d hb;
    for (const auto& p : hinges) hb.extend(pose.tip + pose.axis * c.ring_->height_mm + R * p);
    hb.min().array() -= c.ring_->sphere_radius_mm;
    hb.max().array() += c.ring_->sphere_radius_mm;
    return hb;
  }

  // Exact clearance at one pose (infinity when the height field proves every part at least
  // `threshold` away); `who` names the closest part.
  double value(const PathPose& pose, std::string* who) {
    term.charge(1);
    if (term.should_end()) throw WorkEnded{term.reason()};
    ++counts.exact_queries;
    const double t = threshold();
    const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
    double best = kInf;
    for (std::size_t k = 0; k < parts.size(); ++k) {
      const AxialPart& p = parts[k];
      const Eigen::Vector3d a = pose.tip + pose.axis * p.from_mm, b = pose.tip + pose.axis * p.to_mm;
      if (box_clear(cylinder_box(a, b, p.radius_mm), 0.0, t)) continue;
      const double dist =
          interference::distance(shapes.parts[shape0 + k], interference::segment_pose(a, b), shapes.workpiece, I).distance_mm;
      if (dist < best) {
        best = dist;
        if (who) *who = p.name;
      }
    }
    if (hinges.empty()) return best;
    const Eigen::Matrix3d R = c.model_.plate_rotation(pose.axis);
    for (std::size_t s = 0; s < hinges.size(); ++s) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = pose.tip + pose.axis * c.ring_->height_mm + R * hinges[s];
      Eigen::AlignedBox3d hb(T.translation(), T.translation());
      hb.min().array() -= c.ring_->sphere_radius_mm;
      hb.max().array() += c.ring_->sphere_radius_mm;
      if (box_clear(hb, 0.0, t)) continue;
      const double dist = interference::distance(shapes.hinge, T, shapes.workpiece, I).distance_mm;
      if (dist < best) {
        best = dist;
        if (who) *who = fmt::format("plate hinge {}", s + 1);
      }
    }
    return best;
  }

  bool stretch_clear(const PathPose& pose, double sweep) const {
    const double t = threshold();
    for (const auto& p : parts)
      if (!box_clear(cylinder_box(pose.tip + pose.axis * p.from_mm, pose.tip + pose.axis * p.to_mm, p.radius_mm), sweep, t))
        return false;
    return hinges.empty() || box_clear(hinge_box(pose), sweep, t);
  }

  void note(double v, long i, double t, const std::string& who) {
    if (v < f.clearance_mm) f.clearance_mm = v, f.pose = i, f.t = t, f.what = who + " / workpiece";
  }

  double value_at(long i) {
    const auto it = values.find(i);
    if (it != values.end()) return it->second;
    std::string who;
    const double v = value(tree_pose(i), &who);
    values.emplace(i, v);
    note(v, i, 0, who);
    return v;
  }
  const PathPose& tree_pose(long i) const { return c.tree_.pose(i); }

  // Interval between poses i and i+1 over [t0, t1], with exact values at its ends.
  void interval(long i, double t0, double t1, double v0, double v1, int depth) {
    const double d = c.model_.assembly_motion_mm(c.tree_.step(i, t1 - t0));
    if ((v0 + v1 - d) / 2 >= threshold() || threshold() <= 0) return;
    if (depth >= kMaxIntervalDepth) {
      note((v0 + v1 - d) / 2, i, (t0 + t1) / 2, "unproven interval");
      return;
    }
    const double tm = (t0 + t1) / 2;
    std::string who;
    ++counts.interpolated_poses;
    const double vm = value(c.tree_.at(i, tm), &who);
    note(vm, i, tm, who);
    if (vm < c.safe_) return;  // the interference is found; deeper search only refines it
    interval(i, t0, tm, v0, vm, depth + 1);
    interval(i, tm, t1, vm, v1, depth + 1);
  }

  // With `frontier`, nodes at kSplitDepth are collected there instead of walked.
  void node(int id, int depth = 0, std::vector<int>* frontier = nullptr) {
    if (frontier && depth >= kSplitDepth) {
      frontier->push_back(id);
      return;
    }
    // Distances are never below 0: once the threshold is, nothing left can change the finding.
    if (threshold() <= 0) return;
    ++counts.stretches;
    const PoseTree::Node& nd = c.tree_.nodes()[id];
    const double travel = c.model_.assembly_motion_mm(c.tree_.node_motion(nd));
    // A node is left alone when the height field shows every part clears the threshold over
    // it, or, once an interference is known, when the exact value at its centre less its
    // travel does (the value is 1-Lipschitz in the rigid travel; infinity only says the centre
    // clears, and proves nothing about the rest).
    if (stretch_clear(tree_pose(nd.centre), travel) ||
        (f.clearance_mm < c.safe_ && std::isfinite(value_at(nd.centre)) && value_at(nd.centre) - travel >= threshold())) {
      ++counts.proven_by_bound;
      return;
    }
    if (nd.leaf()) {
      interval(nd.left, 0.0, 1.0, value_at(nd.left), value_at(nd.left + 1), 0);
      return;
    }
    node(nd.left, depth + 1, frontier);
    node(nd.right, depth + 1, frontier);
  }
};

Class1Check::Walk Class1Check::make_walk(std::optional<double> rotation_rad, Termination& term, Shapes& s,
                                         Parts which) const {
  Walk w{*this, rotation_rad, term, s, which == Parts::plate ? std::vector<AxialPart>{} : parts_, 0, {}, {}, {}, {}};
  w.f.clearance_mm = kInf;
  if (which == Parts::plate) w.shape0 = parts_.size();
  if (!ring_ || which == Parts::axial) return w;
  if (rotation_rad) {
    const Eigen::Matrix3d back = Eigen::AngleAxisd(-*rotation_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    for (const auto& p : ring_->points) w.hinges.push_back(*rotation_rad == 0.0 ? p : Eigen::Vector3d(back * p));
  } else {
    w.parts.push_back({"plate hinges (any rotation)", ring_->height_mm - ring_->sphere_radius_mm,
                       ring_->height_mm + ring_->sphere_radius_mm, ring_->radius_mm() + ring_->sphere_radius_mm, false,
                       ToolPart::Class::class1});
  }
  return w;
}

Class1Result Class1Check::run(std::optional<double> rotation_rad, Termination& term,
                              const std::function<Shapes&()>& shapes, Parts which) const {
  auto make_walk = [&](Shapes& s) { return this->make_walk(rotation_rad, term, s, which); };
  Class1Result out;
  out.finding.clearance_mm = kInf;
  if (tree_.size() == 0) return out;
  // The top of the tree in order, as one walk would; the subtrees below it in parallel, each
  // starting from the top's record. When nothing interferes the poses looked at, and so the
  // finding, are those of a single walk.
  Walk top = make_walk(shapes());
  top.value_at(0);
  std::vector<int> roots;
  if (tree_.size() > 1) top.node(0, 0, &roots);
  std::vector<Finding> found(roots.size(), top.f);
  std::vector<CheckCounts> counts(roots.size());
  tbb::parallel_for(std::size_t{0}, roots.size(), [&](std::size_t k) {
    Walk w = make_walk(shapes());
    w.f = top.f;
    w.node(roots[k]);
    found[k] = w.f;
    counts[k] = w.counts;
  });
  out.finding = top.f;
  out.counts = top.counts;
  for (std::size_t k = 0; k < roots.size(); ++k) {
    if (found[k].clearance_mm < out.finding.clearance_mm) out.finding = found[k];
    out.counts.add(counts[k]);
  }
  out.finding.interferes = out.finding.clearance_mm < safe_;
  return out;
}

double Class1Check::exact(const PathPose& pose, std::optional<double> rotation_rad, Shapes& shapes,
                          std::string* who) const {
  Termination unlimited;
  Walk w = make_walk(rotation_rad, unlimited, shapes);
  return w.value(pose, who);
}

double PlateRing::radius_mm() const {
  double r = 0;
  for (const auto& p : points) r = std::max(r, p.head<2>().norm());
  return r;
}

}  // namespace machplan::placement
