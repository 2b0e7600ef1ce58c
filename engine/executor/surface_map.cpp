#include "engine/executor/surface_map.h"

#include <cmath>

#include <Eigen/Dense>

namespace machplan::executor {

void SurfaceMap::add(const Eigen::Vector2d& at_mm, double z_mm) noexcept {
  points_[next_] = {at_mm.x(), at_mm.y(), z_mm};
  next_ = (next_ + 1) % kCapacity;
  if (size_ < kCapacity) ++size_;
}

bool SurfaceMap::estimate(const Eigen::Vector2d& at_mm, double& z_mm) const noexcept {
  const double s2 = (radius_mm_ / 8.0) * (radius_mm_ / 8.0);
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double w_sum = 0.0, wz_sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < size_; ++i) {
    const Eigen::Vector2d d = points_[i].head<2>() - at_mm;
    const double d2 = d.squaredNorm();
    if (d2 > radius_mm_ * radius_mm_) continue;
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
  a(1, 1) += kRidgeMm * kRidgeMm * w_sum;
  a(2, 2) += kRidgeMm * kRidgeMm * w_sum;
  const Eigen::Vector3d x = a.ldlt().solve(b);
  if (std::isfinite(x.x())) z_mm = x.x();
  return true;
}

}  // namespace machplan::executor
