#include "engine/executor/blu_vector_source.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/common/error.h"

namespace machplan::executor {

void BluVectorOptions::validate() const {
  require_field(std::isfinite(blu_mm) && blu_mm >= 0.01 && blu_mm <= 1000, "blu_mm", blu_mm,
                "is out of range: must be in [0.01, 1000] mm");
  require_field(std::isfinite(calibration_factor) && calibration_factor > 0.1 && calibration_factor <= 10,
                "calibration_factor", calibration_factor, "is out of range: must be in (0.1, 10]");
  require_field(std::isfinite(compute_s) && compute_s >= 0 && compute_s <= 10, "compute_s", compute_s,
                "is out of range: must be in [0, 10] s");
  require_field(std::isfinite(settle_s) && settle_s >= 0 && settle_s <= 60, "settle_s", settle_s,
                "is out of range: must be in [0, 60] s");
}

void BluVectorSource::prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) {
  const motion::Job& job = *ctx.job;
  dt_ = ctx.period_s;
  pts_.clear();
  pt_feed_.clear();
  pt_line_.clear();
  step_first_pt_.assign(job.steps.size(), 0);
  step_last_pt_.assign(job.steps.size(), 0);
  estimate_s_ = 0.0;
  std::size_t n_vectors = 0;
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const motion::Step& st = job.steps[i];
    if (st.kind != motion::Step::Kind::move) continue;
    const motion::Stretch& s = job.stretches[st.stretch];
    double L = 0, fmin = std::numeric_limits<double>::infinity();
    for (const Segment& seg : s.segments) L += length(seg);
    for (double f : s.feed_mm_per_s) fmin = std::min(fmin, f);
    estimate_s_ += L / (fmin * std::min(1.0, o_.calibration_factor * 0.5)) + o_.settle_s + 0.01;
    step_first_pt_[i] = pts_.size();
    pts_.push_back(s.segments.front().start);
    pt_feed_.push_back(s.feed_mm_per_s.front());
    pt_line_.push_back(s.source_lines.front());
    for (std::size_t g = 0; g < s.segments.size(); ++g) {
      const Segment& seg = s.segments[g];
      // Equal vectors of at most blu_mm along the segment (chords for arcs).
      const int n = std::max(1, static_cast<int>(std::ceil(length(seg) / o_.blu_mm - 1e-9)));
      for (int j = 1; j <= n; ++j) {
        pts_.push_back(j == n ? seg.end : point_at(seg, static_cast<double>(j) / n));
        pt_feed_.push_back(s.feed_mm_per_s[g]);
        pt_line_.push_back(s.source_lines[g]);
      }
      n_vectors += static_cast<std::size_t>(std::ceil(length(seg) / o_.blu_mm)) + 1;
    }
    step_last_pt_[i] = pts_.size() - 1;
  }
  estimate_s_ += static_cast<double>(n_vectors) * (o_.compute_s + 2 * dt_);
  hold_mm_ = start_mm;
  u_.setZero();
  active_ = settling_ = false;
  done_ = true;
}

void BluVectorSource::begin_move(std::size_t step, const Eigen::Vector2d&) noexcept {
  step_ = step;
  pk_ = step_first_pt_[step];
  u_.setZero();
  zero_pending_ = o_.zero_first;
  start_pending_ = !o_.zero_first;
  computing_ = false;
  T_s_ = left_s_ = 0.0;
  origin_ = pts_[pk_];
  active_ = true;
  settling_ = false;
  done_ = false;
}

void BluVectorSource::start_vector(std::size_t k, const Eigen::Vector2d& origin) noexcept {
  pk_ = k;
  origin_ = origin;
  const Eigen::Vector2d d = pts_[k + 1] - origin;
  const double L = d.norm();
  const double F = pt_feed_[k + 1];
  if (L < 1e-9) {
    T_s_ = left_s_ = 0.0;
    return;
  }
  u_ = o_.calibration_factor * F * d / L;
  T_s_ = L / F;
  left_s_ += T_s_;  // open loop carries the remainder of the previous vector's time
}

void BluVectorSource::vector_tick(const Eigen::Vector2d& measured_mm) noexcept {
  if (zero_pending_) {
    u_.setZero();
    zero_pending_ = false;
    start_pending_ = true;
    return;
  }
  if (start_pending_) {
    start_pending_ = false;
    left_s_ = 0.0;
    start_vector(pk_, o_.closed_loop ? measured_mm : pts_[pk_]);
    return;
  }
  if (computing_) {
    compute_left_s_ -= dt_;
    if (compute_left_s_ <= 1e-12) {
      computing_ = false;
      left_s_ = 0.0;
      start_vector(pk_, latched_);
    }
    return;
  }
  left_s_ -= dt_;
  if (left_s_ > 1e-12) return;
  if (pk_ + 1 >= step_last_pt_[step_]) {
    u_.setZero();
    settling_ = true;
    settle_t_ = 0.0;
    return;
  }
  if (!o_.closed_loop) {
    start_vector(pk_ + 1, pts_[pk_ + 1]);
  } else {
    // Read the counters now; the re-aimed command goes out after the computation time.
    latched_ = measured_mm;
    pk_ = pk_ + 1;
    if (o_.compute_s > 0) {
      computing_ = true;
      compute_left_s_ = o_.compute_s;
    } else {
      left_s_ = 0.0;
      start_vector(pk_, latched_);
    }
  }
}

void BluVectorSource::advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs&) noexcept {
  if (!active_) return;
  if (settling_) {
    u_.setZero();
    settle_t_ += dt_;
    if (settle_t_ >= o_.settle_s) {
      hold_mm_ = pts_[step_last_pt_[step_]];
      active_ = settling_ = false;
      done_ = true;
    }
    return;
  }
  vector_tick(measured_mm);
}

void BluVectorSource::demand(Demand& d) const noexcept {
  d.kind = Demand::Kind::speed;
  d.speed_mm_per_s = u_;
  if (active_ && !settling_) {
    // The commanded point of the vector in progress.
    const double f = T_s_ > 0 ? std::clamp(1.0 - left_s_ / T_s_, 0.0, 1.0) : 1.0;
    d.commanded_mm = origin_ + f * (pts_[pk_ + 1] - origin_);
  } else {
    d.commanded_mm = active_ ? pts_[pk_ + 1] : hold_mm_;
  }
}

int BluVectorSource::source_line() const noexcept {
  return active_ && !settling_ && pk_ + 1 < pt_line_.size() ? pt_line_[pk_ + 1] : 0;
}

}  // namespace machplan::executor
