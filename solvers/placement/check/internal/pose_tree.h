// The tool path as the certifier walks it: its poses in the workpiece frame (with the rotary
// angles the machine reaches them with), a bound of the motion over each interval between two
// poses, and a bounding-volume tree over the intervals built on pose proximity.
//
// The tree is built on pose proximity (tip position, tool axis and rotary angles), not on path
// order: a node holds a set of intervals, one of their poses as its centre, and how far (tip
// distance, axis angle, rotary turn) any pose of its intervals, including poses inside them,
// lies from that centre. A raster path's neighbouring rows share nodes, so a node's motion
// bound is far smaller than that of a path stretch of as many poses. Distances and angles do
// not change when the workpiece turns about z, so one tree serves every rotation.
//
// Immutable once built; shared by every thread.
#pragma once

#include <vector>

#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

// The certifier and the class-1 walk split an interval between two poses in halves at most this
// many times.
inline constexpr int kMaxIntervalDepth = 12;

class PoseTree {
 public:
  struct Node {
    long centre = 0;
    double tip_mm = 0, angle_rad = 0, joints_rad = 0;  // largest distances of a member pose from the centre
    int left = -1, right = -1;  // children; a leaf has right = -1 and left = its interval
    bool leaf() const { return right < 0; }
  };

  // Builds the tree (in parallel when threads are available; the tree is the same either way).
  PoseTree(const MachineModel& model, std::vector<PathPose> poses);

  long size() const { return static_cast<long>(poses_.size()); }
  const PathPose& pose(long i) const { return poses_[i]; }
  const std::vector<PathPose>& poses() const { return poses_; }
  // The pose at fraction t of the interval from pose i to pose i + 1.
  PathPose at(long i, double t) const;
  // Motion bound over the interval from pose i to i + 1, scaled by `fraction` of it.
  Motion step(long i, double fraction = 1.0) const;
  Motion node_motion(const Node& n) const { return {n.tip_mm, n.angle_rad, n.joints_rad, 0.0, 0.0, true}; }

  const std::vector<Node>& nodes() const { return nodes_; }  // nodes()[0] is the root (none for one pose)
  // Node ids whose subtrees cover the tree exactly once, in depth-first order: the nodes at
  // `depth`, or leaves above it. The same for any thread count.
  std::vector<int> frontier(int depth) const;
  // Largest distance of a tip from the workpiece frame's z axis (bounds what a rotation moves).
  double radius_mm() const { return radius_mm_; }
  double tip_radius_mm(long i) const { return poses_[i].tip.head<2>().norm(); }

 private:
  void build(std::vector<long>& iv, std::size_t lo, std::size_t hi, int id, int depth);

  const MachineModel& model_;
  std::vector<PathPose> poses_;
  std::vector<Motion> steps_;
  std::vector<Node> nodes_;
  Eigen::Matrix<double, 8, Eigen::Dynamic> keys_;  // while building: one key per interval
  double axis_w_ = 0, joint_w_ = 0, radius_mm_ = 0;
};

}  // namespace machplan::placement
