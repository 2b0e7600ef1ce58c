#include "engine/interference/height_field.h"

#include <algorithm>
#include <cmath>

namespace machplan::interference {

namespace {
constexpr double kNone = -std::numeric_limits<double>::infinity();
}

HeightField::HeightField(const std::vector<Eigen::Vector3d>& v, const std::vector<Eigen::Vector3i>& t,
                         double cell_mm, const Eigen::AlignedBox2d& floor_rect, double floor_z)
    : cell_(cell_mm) {
  Eigen::AlignedBox2d b = floor_rect;
  for (const auto& p : v) b.extend(p.head<2>());
  origin_ = b.min() - Eigen::Vector2d::Constant(cell_);
  nx_ = static_cast<int>(std::ceil(b.sizes().x() / cell_)) + 3;
  ny_ = static_cast<int>(std::ceil(b.sizes().y() / cell_)) + 3;
  std::vector<double> base(static_cast<std::size_t>(nx_) * ny_, kNone);
  auto cell_range = [&](double lo, double hi, double o, int n, int& a, int& z) {
    a = std::clamp(static_cast<int>(std::floor((lo - o) / cell_)), 0, n - 1);
    z = std::clamp(static_cast<int>(std::floor((hi - o) / cell_)), 0, n - 1);
  };
  auto raise = [&](const Eigen::AlignedBox2d& r, double z) {
    int x0, x1, y0, y1;
    cell_range(r.min().x(), r.max().x(), origin_.x(), nx_, x0, x1);
    cell_range(r.min().y(), r.max().y(), origin_.y(), ny_, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double& c = base[static_cast<std::size_t>(y) * nx_ + x];
        c = std::max(c, z);
      }
  };
  if (!floor_rect.isEmpty()) raise(floor_rect, floor_z);
  for (const auto& f : t) {
    Eigen::AlignedBox2d r;
    double z = kNone;
    for (int k = 0; k < 3; ++k) {
      r.extend(v[f[k]].head<2>());
      z = std::max(z, v[f[k]].z());
    }
    raise(r, z);
  }
  levels_.push_back(std::move(base));
  level_nx_.push_back(nx_);
  level_ny_.push_back(ny_);
  while (level_nx_.back() > 1 || level_ny_.back() > 1) {
    const int px = level_nx_.back(), py = level_ny_.back();
    const int qx = (px + 1) / 2, qy = (py + 1) / 2;
    std::vector<double> next(static_cast<std::size_t>(qx) * qy, kNone);
    const auto& prev = levels_.back();
    for (int y = 0; y < py; ++y)
      for (int x = 0; x < px; ++x) {
        double& c = next[static_cast<std::size_t>(y / 2) * qx + x / 2];
        c = std::max(c, prev[static_cast<std::size_t>(y) * px + x]);
      }
    levels_.push_back(std::move(next));
    level_nx_.push_back(qx);
    level_ny_.push_back(qy);
  }
}

double HeightField::max_height(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const {
  const double fx0 = std::floor((lo.x() - origin_.x()) / cell_), fx1 = std::floor((hi.x() - origin_.x()) / cell_);
  const double fy0 = std::floor((lo.y() - origin_.y()) / cell_), fy1 = std::floor((hi.y() - origin_.y()) / cell_);
  if (fx1 < 0 || fy1 < 0 || fx0 >= nx_ || fy0 >= ny_) return kNone;
  int x0 = static_cast<int>(std::max(fx0, 0.0)), x1 = static_cast<int>(std::min(fx1, nx_ - 1.0));
  int y0 = static_cast<int>(std::max(fy0, 0.0)), y1 = static_cast<int>(std::min(fy1, ny_ - 1.0));
  // Climb until the rectangle spans at most 3 cells per side, then take the max of those.
  std::size_t k = 0;
  while (k + 1 < levels_.size() && (x1 - x0 > 2 || y1 - y0 > 2)) {
    x0 /= 2, x1 /= 2, y0 /= 2, y1 /= 2;
    ++k;
  }
  double m = kNone;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) m = std::max(m, levels_[k][static_cast<std::size_t>(y) * level_nx_[k] + x]);
  return m;
}

}  // namespace machplan::interference
