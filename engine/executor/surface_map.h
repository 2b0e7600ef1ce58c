// The sheet's surface as the machine found it: every probe is a measured point (x, y, z), and
// so is every stretch of a cut where torch height control held the torch at its cut height
// (the surface lies a cut height, corrected by the arc voltage's error, under the torch).
// Together they estimate the surface where nothing was measured. QtPlasmaC forgets each probe
// once the cut is done; machplan keeps the last kCapacity points, so that
//
//   * a pierce the skip rule spares from probing takes the surface estimated there, not the
//     last probe's height wherever that was (on a warped sheet the two differ by the slope
//     times the distance);
//   * the next probe starts its slow descent at the probe height over the surface estimated
//     under it, not over the nominal surface;
//   * where THC may not act (before it arms after a pierce, under an anti-dive lock at a corner
//     or over a kerf), the torch follows the estimated surface instead of holding its height
//     (the executor's feed-forward, engine/executor/executor.cpp).
//
// The estimate at p: the plane z = a + b (x - px) + c (y - py) fitted by least squares to the
// points within the map's radius R, each weighted 1 / (d^2 + s^2) with d its distance from p
// and s = R / 8, so that the near points decide and the far ones only steady the slope; a is
// the estimate. The slopes carry a small ridge term (as if every point were spread kRidgeMm
// more in each direction): a slope the points cannot tell (points along one line, the torch's
// track along a straight cut) stays near 0 instead of taking any value, and a slope they do
// tell is kept. With fewer than three points, the weighted mean of their heights.
//
// Real time: add() and estimate() are O(kCapacity), allocate nothing and never throw.
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Core>

namespace machplan::executor {

class SurfaceMap {
 public:
  static constexpr std::size_t kCapacity = 128;
  static constexpr double kRidgeMm = 2.0;
  // Points farther than `radius_mm` from a point say nothing about it.
  explicit SurfaceMap(double radius_mm) : radius_mm_(radius_mm) {}

  void clear() noexcept { size_ = next_ = 0; }
  // A measured point; the oldest goes once kCapacity are kept.
  void add(const Eigen::Vector2d& at_mm, double z_mm) noexcept;
  // The surface at `at_mm` from the points within the radius; false when there are none.
  bool estimate(const Eigen::Vector2d& at_mm, double& z_mm) const noexcept;
  std::size_t size() const noexcept { return size_; }

 private:
  std::array<Eigen::Vector3d, kCapacity> points_{};
  std::size_t size_ = 0, next_ = 0;
  double radius_mm_;
};

}  // namespace machplan::executor
