// The sheet's surface as the probes found it: every probe is a measured point (x, y, z), and
// together they estimate the surface where no probe was taken. QtPlasmaC forgets each probe
// once the cut is done; machplan keeps the last kCapacity of them, so that
//
//   * a pierce the skip rule spares from probing takes the surface estimated there, not the
//     last probe's height wherever that was (on a warped sheet the two differ by the slope
//     times the distance);
//   * the next probe starts its slow descent at the probe height over the surface estimated
//     under it, not over the nominal surface.
//
// The estimate at p: the plane z = a + b (x - px) + c (y - py) fitted by least squares to the
// points within `radius_mm`, each weighted 1 / (d^2 + s^2) with d its distance from p and s =
// radius / 8, so that the near points decide and the far ones only steady the slope; a is the
// estimate. With fewer than three points, or points that lie on a line, the weighted mean of
// their heights.
//
// Real time: add() and estimate() are O(kCapacity), allocate nothing and never throw.
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Core>

namespace machplan::executor {

class SurfaceMap {
 public:
  static constexpr std::size_t kCapacity = 64;

  void clear() noexcept { size_ = next_ = 0; }
  // A measured point; the oldest goes once kCapacity are kept.
  void add(const Eigen::Vector2d& at_mm, double z_mm) noexcept;
  // The surface at `at_mm` from the points within `radius_mm`; false when there are none.
  bool estimate(const Eigen::Vector2d& at_mm, double radius_mm, double& z_mm) const noexcept;
  std::size_t size() const noexcept { return size_; }

 private:
  std::array<Eigen::Vector3d, kCapacity> points_{};
  std::size_t size_ = 0, next_ = 0;
};

}  // namespace machplan::executor
