#include "solvers/placement/search/internal/objective.h"

#include <algorithm>
#include <cmath>

namespace machplan::placement {

AxisObjective::AxisObjective(const AxisPath& path, Kind kind) : kind_(kind) {
  const std::size_t n = path.M.size();
  for (std::size_t i = 1; i < n; ++i) {
    D_.push_back(path.M[i] - path.M[i - 1]);
    e_.push_back(path.b[i] - path.b[i - 1]);
    const Eigen::Vector2d dr = (path.rotary_rad[i] - path.rotary_rad[i - 1]).cwiseAbs();
    rotary_travel_rad_ += dr;
    const bool rapid = path.feed_mm_per_s[i] <= 0;
    const auto& speed = rapid ? path.rapid : path.speed;
    double fixed = std::max(dr.x() / speed(3), dr.y() / speed(4));
    // A cutting move runs at most at its programmed feed along the tip's path.
    if (!rapid && !path.feed_on_axes) fixed = std::max(fixed, path.tip_step_mm[i] / path.feed_mm_per_s[i]);
    inv_feed_.push_back(!rapid && path.feed_on_axes ? 1.0 / path.feed_mm_per_s[i] : 0.0);
    rotary_deg2_.push_back((dr * 180.0 / M_PI).squaredNorm());
    fixed_s_.push_back(fixed);
    inv_speed_.push_back(Eigen::Vector3d(1.0 / speed(0), 1.0 / speed(1), 1.0 / speed(2)));
  }
}

double AxisObjective::evaluate(const Eigen::Vector3d& o, Kind kind, Eigen::Vector3d* g) const {
  double sum = 0;
  if (g) g->setZero();
  for (std::size_t i = 0; i < D_.size(); ++i) {
    const Eigen::Vector3d d = D_[i] * o + e_[i];
    if (kind == Kind::travel) {
      sum += d.cwiseAbs().sum();
      if (g)
        for (int k = 0; k < 3; ++k) *g += (d(k) >= 0 ? 1.0 : -1.0) * D_[i].row(k).transpose();
      continue;
    }
    double t = fixed_s_[i];
    int arg = -1;
    for (int k = 0; k < 3; ++k) {
      const double tk = std::abs(d(k)) * inv_speed_[i](k);
      if (tk > t) t = tk, arg = k;
    }
    // Feed on the axes: the combined step over the feed.
    const double combined = std::sqrt(d.squaredNorm() + rotary_deg2_[i]);
    const bool feed_term = inv_feed_[i] > 0.0 && combined * inv_feed_[i] > t;
    if (feed_term) t = combined * inv_feed_[i];
    sum += t;
    if (g && feed_term && combined > 0.0) {
      *g += inv_feed_[i] / combined * (D_[i].transpose() * d);
    } else if (g && arg >= 0) {
      *g += (d(arg) >= 0 ? 1.0 : -1.0) * inv_speed_[i](arg) * D_[i].row(arg).transpose();
    }
  }
  return sum;
}

double AxisObjective::value(const Eigen::Vector3d& offset) const { return evaluate(offset, kind_, nullptr); }

double AxisObjective::lower_bound(const Eigen::Vector3d& c, const Eigen::Vector3d& h) const {
  Eigen::Vector3d g;
  const double fc = evaluate(c, kind_, &g);
  const double plane = fc - g.cwiseAbs().dot(h);
  double terms = 0;
  for (std::size_t i = 0; i < D_.size(); ++i) {
    const Eigen::Vector3d d = D_[i] * c + e_[i];
    const Eigen::Vector3d slack = D_[i].cwiseAbs() * h;
    const Eigen::Vector3d low = (d.cwiseAbs() - slack).cwiseMax(0.0);
    if (kind_ == Kind::travel) {
      terms += low.sum();
    } else {
      terms += std::max({fixed_s_[i], low.cwiseProduct(inv_speed_[i]).maxCoeff(),
                         std::sqrt(low.squaredNorm() + rotary_deg2_[i]) * inv_feed_[i]});
    }
  }
  return std::max(plane, terms);
}

std::vector<double> AxisObjective::travel_per_axis(const Eigen::Vector3d& o) const {
  Eigen::Vector3d lin = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < D_.size(); ++i) lin += (D_[i] * o + e_[i]).cwiseAbs();
  return {lin(0), lin(1), lin(2), rotary_travel_rad_(0) * 180.0 / M_PI, rotary_travel_rad_(1) * 180.0 / M_PI};
}

double AxisObjective::time_s(const Eigen::Vector3d& offset) const { return evaluate(offset, Kind::time, nullptr); }

double AxisObjective::linear_travel_mm(const Eigen::Vector3d& offset) const {
  return evaluate(offset, Kind::travel, nullptr);
}

}  // namespace machplan::placement
