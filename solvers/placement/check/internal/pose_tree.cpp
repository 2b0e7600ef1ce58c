#include "solvers/placement/check/internal/pose_tree.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

namespace machplan::placement {

namespace {
// Subtrees at least this large are built as tasks of their own.
constexpr std::size_t kParallelIntervals = 4096;
}  // namespace

PoseTree::PoseTree(const MachineModel& model, std::vector<PathPose> poses)
    : model_(model), poses_(std::move(poses)), axis_w_(model.axis_weight_mm()), joint_w_(model.joint_weight_mm()) {
  const std::size_t n = poses_.size();
  for (const auto& p : poses_) radius_mm_ = std::max(radius_mm_, p.tip.head<2>().norm());
  steps_.resize(n > 0 ? n - 1 : 0);
  if (n < 2) return;
  // Key of an interval: its mid tip, its mid axis scaled so that an axis turn weighs what it
  // moves the rigid parts, and its mid rotary angles likewise. Each interval on its own, so
  // on every thread.
  keys_.resize(8, static_cast<long>(n - 1));
  tbb::parallel_for(std::size_t{0}, n - 1, [&](std::size_t i) {
    const PathPose &a = poses_[i], &b = poses_[i + 1];
    steps_[i] = model.motion_between(a, b);
    keys_.col(static_cast<long>(i)) << (a.tip + b.tip) / 2, axis_w_ * (a.axis + b.axis) / 2, joint_w_ * (a.a_rad + b.a_rad) / 2,
        joint_w_ * (a.c_rad + b.c_rad) / 2;
  });
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
  // The passes over the node's intervals: on every thread for a large node (the root's alone
  // covers the whole path), the same results as in order.
  using Key = Eigen::Matrix<double, 8, 1>;
  const bool wide = hi - lo >= kParallelIntervals;
  struct Box {
    Key lo = Key::Constant(kInf), hi = Key::Constant(-kInf);
  };
  auto bounds = [&](const tbb::blocked_range<std::size_t>& r, Box b) {
    for (std::size_t j = r.begin(); j < r.end(); ++j) b.lo = b.lo.cwiseMin(keys_.col(iv[j])), b.hi = b.hi.cwiseMax(keys_.col(iv[j]));
    return b;
  };
  const tbb::blocked_range<std::size_t> all(lo, hi, kParallelIntervals);
  auto pass = [&](auto init, const auto& body, const auto& join) {
    return wide ? tbb::parallel_reduce(all, init, body, join) : body(all, init);
  };
  const Box kb = pass(Box{}, bounds, [](Box a, const Box& b) {
    a.lo = a.lo.cwiseMin(b.lo), a.hi = a.hi.cwiseMax(b.hi);
    return a;
  });
  const Key kmin = kb.lo, kmax = kb.hi;
  // Centre: the member pose nearest the middle of the keys' box (the first such, in order).
  const Key mid = (kmin + kmax) / 2;
  auto key_of = [&](long i) {
    Key k;
    k << poses_[i].tip, axis_w_ * poses_[i].axis, joint_w_ * poses_[i].a_rad, joint_w_ * poses_[i].c_rad;
    return k;
  };
  struct Nearest {
    double d = kInf;
    long pose = -1;
  };
  auto nearest = [&](const tbb::blocked_range<std::size_t>& r, Nearest n) {
    for (std::size_t j = r.begin(); j < r.end(); ++j)
      for (long i : {iv[j], iv[j] + 1}) {
        const Key k = key_of(i);
        const double d = (k.head<3>() - mid.head<3>()).squaredNorm() + (k.tail<5>() - mid.tail<5>()).squaredNorm();
        if (d < n.d) n = {d, i};
      }
    return n;
  };
  // Chunks join in order (left before right), so a tie keeps the earlier pose as a walk would.
  const Nearest nc = pass(Nearest{}, nearest, [](const Nearest& a, const Nearest& b) { return b.d < a.d ? b : a; });
  const long centre = nc.pose >= 0 ? nc.pose : iv[lo];
  const PathPose& c = poses_[centre];
  struct Reach {
    double tip2 = 0, chord2 = 0, joints = 0;
  };
  auto reach = [&](const tbb::blocked_range<std::size_t>& r, Reach m) {
    for (std::size_t j = r.begin(); j < r.end(); ++j)
      for (long i : {iv[j], iv[j] + 1}) {
        m.tip2 = std::max(m.tip2, (poses_[i].tip - c.tip).squaredNorm());
        m.chord2 = std::max(m.chord2, (poses_[i].axis - c.axis).squaredNorm());
        m.joints = std::max(m.joints, std::abs(poses_[i].a_rad - c.a_rad) + std::abs(poses_[i].c_rad - c.c_rad));
      }
    return m;
  };
  const Reach rc = pass(Reach{}, reach, [](Reach a, const Reach& b) {
    a.tip2 = std::max(a.tip2, b.tip2), a.chord2 = std::max(a.chord2, b.chord2), a.joints = std::max(a.joints, b.joints);
    return a;
  });
  const double tip2 = rc.tip2, chord2 = rc.chord2, joints = rc.joints;
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
