#include "engine/executor/contour_monitor.h"

#include <algorithm>
#include <limits>

namespace machplan::executor {

void ContourMonitor::seek(std::size_t k, const Eigen::Vector2d& p) noexcept {
  const std::vector<Segment>& segs = job_->stretches[k].segments;
  double best = std::numeric_limits<double>::infinity();
  cursor_ = 0;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const double d = (closest_point(segs[i], p) - p).squaredNorm();
    if (d < best) best = d, cursor_ = i;
  }
}

double ContourMonitor::account(std::size_t k, const Eigen::Vector2d& meas, bool has_truth,
                               const Eigen::Vector2d& truth) noexcept {
  const std::vector<Segment>& segs = job_->stretches[k].segments;
  const std::size_t lo = cursor_ > 0 ? cursor_ - 1 : 0;
  const std::size_t hi = std::min(segs.size(), cursor_ + 9);
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_i = cursor_;
  for (std::size_t i = lo; i < hi; ++i) {
    const double d = (closest_point(segs[i], meas) - meas).norm();
    if (d < best) best = d, best_i = i;
  }
  if (best_i > cursor_) {
    double skipped = 0.0;
    for (std::size_t i = cursor_ + 1; i < best_i; ++i) skipped += length(segs[i]);
    if (skipped <= 2.0) cursor_ = best_i;
  } else {
    cursor_ = best_i;
  }
  Acc& a = acc_[k];
  ++a.n;
  a.max = std::max(a.max, best);
  a.sum2 += best * best;
  if (has_truth) {
    double bt = std::numeric_limits<double>::infinity();
    for (std::size_t i = lo; i < hi; ++i) bt = std::min(bt, (closest_point(segs[i], truth) - truth).norm());
    ++a.n_true;
    a.max_true = std::max(a.max_true, bt);
    a.sum2_true += bt * bt;
  }
  last_mm_ = best;
  return best;
}

}  // namespace machplan::executor
