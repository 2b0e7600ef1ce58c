#include "engine/executor/surface_map.h"

#include <cmath>

#include <Eigen/Dense>

namespace machplan::executor {

void SurfaceMap::add(const Eigen::Vector2d& at_mm, double z_mm) noexcept {
  points_[next_] = {at_mm.x(), at_mm.y(), z_mm};
  next_ = (next_ + 1) % kCapacity;
  if (size_ < kCapacity) ++size_;
}

bool SurfaceMap::estimate(const Eigen::Vector2d& at_mm, double radius_mm, double& z_mm) const noexcept {
  const double s2 = (radius_mm / 8.0) * (radius_mm / 8.0);
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double w_sum = 0.0, wz_sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < size_; ++i) {
    const Eigen::Vector2d d = points_[i].head<2>() - at_mm;
    const double d2 = d.squaredNorm();
    if (d2 > radius_mm * radius_mm) continue;
    const double w = 1.0 / (d2 + s2);
    const Eigen::Vector3d row(1.0, d.x(), d.y());
    a.noalias() += w * row * row.transpose();
    b += w * points_[i].z() * row;
    w_sum += w;
    wz_sum += w * points_[i].z();
    ++n;
  }
  if (n == 0) return false;
  z_mm = wz_sum / w_sum;
  if (n < 3) return true;
  // Points on a line leave the slope across it unknown: the mean then. The smallest spread of
  // the points' positions (the weighted covariance's smaller eigenvalue) tells.
  const Eigen::Vector2d mean = a.block<2, 1>(1, 0) / w_sum;
  const Eigen::Matrix2d cov = a.bottomRightCorner<2, 2>() / w_sum - mean * mean.transpose();
  const double half = 0.5 * (cov(0, 0) + cov(1, 1)), diff = 0.5 * (cov(0, 0) - cov(1, 1));
  const double smallest = half - std::sqrt(diff * diff + cov(0, 1) * cov(0, 1));
  if (!(smallest > 1e-4 * radius_mm * radius_mm)) return true;
  const Eigen::Vector3d x = a.ldlt().solve(b);
  if (std::isfinite(x.x())) z_mm = x.x();
  return true;
}

}  // namespace machplan::executor
