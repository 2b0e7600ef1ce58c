// Contour error bookkeeping: while the torch burns on a cutting stretch, the distance from the
// measured position (and from the backend's truth, when it knows it) to the stretch's
// programmed XY path, accumulated per stretch as a maximum and a sum of squares.
//
// Bounded work per period: the nearest segment is searched in a window of ten segments around
// a cursor. The tool moves far less than one segment per period, so the window always holds
// the nearest piece; the cursor advances only over segments the tool can have passed (never
// over a long one: a closed contour ends where it starts, and a tool wobbling behind its start
// is nearest to the END of the contour, which it has not reached yet).
//
// Real time: begin() and account() allocate nothing and never throw; prepare() allocates.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "engine/motion/job.h"

namespace machplan::executor {

class ContourMonitor {
 public:
  struct Acc {
    std::size_t n = 0, n_true = 0;
    double max = 0, sum2 = 0, max_true = 0, sum2_true = 0;
    bool complete = false, touched = false;
  };

  void prepare(const motion::Job& job) {
    job_ = &job;
    acc_.assign(job.stretches.size(), Acc{});
    cursor_ = 0;
    last_mm_ = 0.0;
  }
  // A move on stretch k starts.
  void begin(std::size_t k) noexcept {
    cursor_ = 0;
    acc_[k].touched = true;
  }
  void complete(std::size_t k) noexcept { acc_[k].complete = true; }
  // The tool was moved along stretch k by other means (a paused motion, either way): the
  // cursor goes to the segment nearest `p`, the first of equals (the whole stretch is searched,
  // once).
  void seek(std::size_t k, const Eigen::Vector2d& p) noexcept;
  // One sample on stretch k; `true_mm` is used when `has_truth`. Returns the measured distance.
  double account(std::size_t k, const Eigen::Vector2d& measured_mm, bool has_truth, const Eigen::Vector2d& true_mm) noexcept;
  // The last measured distance (0 outside cuts).
  double last_mm() const noexcept { return last_mm_; }
  void clear_last() noexcept { last_mm_ = 0.0; }
  // The segment of the stretch the tool is on (the cursor).
  std::size_t segment() const noexcept { return cursor_; }
  const std::vector<Acc>& accumulators() const { return acc_; }

 private:
  const motion::Job* job_ = nullptr;
  std::vector<Acc> acc_;
  std::size_t cursor_ = 0;
  double last_mm_ = 0.0;
};

}  // namespace machplan::executor
