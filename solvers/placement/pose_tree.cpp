#include "solvers/placement/pose_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/task_group.h>

namespace machplan::placement {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// Subtrees at least this large are built as tasks of their own.
constexpr std::size_t kParallelIntervals = 4096;
}  // namespace

PoseTree::PoseTree(const MachineModel& model, std::vector<PathPose> poses)
    : model_(model), poses_(std::move(poses)), axis_w_(model.axis_weight_mm()), joint_w_(model.joint_weight_mm()) {
  const std::size_t n = poses_.size();
  for (const auto& p : poses_) radius_mm_ = std::max(radius_mm_, p.tip.head<2>().norm());
  steps_.resize(n > 0 ? n - 1 : 0);
  for (std::size_t i = 0; i + 1 < n; ++i) steps_[i] = model.motion_between(poses_[i], poses_[i + 1]);
  if (n < 2) return;
  // Key of an interval: its mid tip, its mid axis scaled so that an axis turn weighs what it
  // moves the rigid parts, and its mid rotary angles likewise.
  keys_.resize(8, static_cast<long>(n - 1));
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const PathPose &a = poses_[i], &b = poses_[i + 1];
    keys_.col(static_cast<long>(i)) << (a.tip + b.tip) / 2, axis_w_ * (a.axis + b.axis) / 2, joint_w_ * (a.a_rad + b.a_rad) / 2,
        joint_w_ * (a.c_rad + b.c_rad) / 2;
  }
  std::vector<long> intervals(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) intervals[i] = static_cast<long>(i);
  nodes_.resize(2 * (n - 1) - 1);
  build(intervals, 0, intervals.size(), 0, 0);
  keys_.resize(8, 0);
}

PathPose PoseTree::at(long i, double t) const {
  if (t <= 0) return poses_[i];
  if (t >= 1) return poses_[i + 1];
  return model_.interpolate(poses_[i], poses_[i + 1], t);
}

Motion PoseTree::step(long i, double fraction) const {
  const Motion& m = steps_[i];
  return {m.tip_mm * fraction, m.axis_rad * fraction, m.joints_rad * fraction, 0.0, 0.0, true};
}

void PoseTree::build(std::vector<long>& iv, std::size_t lo, std::size_t hi, int id, int depth) {
  Eigen::Matrix<double, 8, 1> kmin = Eigen::Matrix<double, 8, 1>::Constant(kInf), kmax = -kmin;
  for (std::size_t j = lo; j < hi; ++j) {
    kmin = kmin.cwiseMin(keys_.col(iv[j])), kmax = kmax.cwiseMax(keys_.col(iv[j]));
  }
  // Centre: the member pose nearest the middle of the keys' box.
  const Eigen::Matrix<double, 8, 1> mid = (kmin + kmax) / 2;
  auto key_of = [&](long i) {
    Eigen::Matrix<double, 8, 1> k;
    k << poses_[i].tip, axis_w_ * poses_[i].axis, joint_w_ * poses_[i].a_rad, joint_w_ * poses_[i].c_rad;
    return k;
  };
  long centre = iv[lo];
  double best = kInf;
  for (std::size_t j = lo; j < hi; ++j)
    for (long i : {iv[j], iv[j] + 1}) {
      const Eigen::Matrix<double, 8, 1> k = key_of(i);
      const double d = (k.head<3>() - mid.head<3>()).squaredNorm() + (k.tail<5>() - mid.tail<5>()).squaredNorm();
      if (d < best) best = d, centre = i;
    }
  double tip2 = 0, chord2 = 0, joints = 0;
  const PathPose& c = poses_[centre];
  for (std::size_t j = lo; j < hi; ++j)
    for (long i : {iv[j], iv[j] + 1}) {
      tip2 = std::max(tip2, (poses_[i].tip - c.tip).squaredNorm());
      chord2 = std::max(chord2, (poses_[i].axis - c.axis).squaredNorm());
      joints = std::max(joints, std::abs(poses_[i].a_rad - c.a_rad) + std::abs(poses_[i].c_rad - c.c_rad));
    }
  Node node;
  node.centre = centre;
  // Rounded up a little so the bound stays a bound in floating point.
  node.tip_mm = std::sqrt(tip2) * (1 + 1e-12) + 1e-9;
  node.angle_rad = 2 * std::asin(std::min(1.0, std::sqrt(chord2) / 2)) * (1 + 1e-12) + 1e-12;
  node.joints_rad = joints * (1 + 1e-12) + (joint_w_ > 0 ? 1e-12 : 0.0);
  if (hi - lo == 1) {
    node.left = static_cast<int>(iv[lo]);
    nodes_[id] = node;
    return;
  }
  int dim = 0;
  (kmax - kmin).maxCoeff(&dim);
  const std::size_t m = lo + (hi - lo) / 2;
  std::nth_element(iv.begin() + lo, iv.begin() + m, iv.begin() + hi,
                   [&](long a, long b) { return keys_(dim, a) < keys_(dim, b); });
  // Pre-order ids: the left subtree of k intervals holds 2k - 1 nodes.
  node.left = id + 1;
  node.right = id + 1 + 2 * static_cast<int>(m - lo) - 1;
  nodes_[id] = node;
  if (hi - lo >= kParallelIntervals) {
    tbb::task_group g;
    g.run([&] { build(iv, lo, m, node.left, depth + 1); });
    build(iv, m, hi, node.right, depth + 1);
    g.wait();
  } else {
    build(iv, lo, m, node.left, depth + 1);
    build(iv, m, hi, node.right, depth + 1);
  }
}

std::vector<int> PoseTree::frontier(int depth) const {
  std::vector<int> out;
  if (nodes_.empty()) return out;
  std::vector<std::pair<int, int>> stack{{0, 0}};
  while (!stack.empty()) {
    const auto [id, d] = stack.back();
    stack.pop_back();
    const Node& n = nodes_[id];
    if (n.leaf() || d >= depth) {
      out.push_back(id);
      continue;
    }
    stack.push_back({n.right, d + 1});
    stack.push_back({n.left, d + 1});
  }
  return out;
}

}  // namespace machplan::placement
