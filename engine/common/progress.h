// How long work says how far it has come: one type for every caller.
//
// The worker calls report(fraction) as it advances; a display (the CLI's progress bar, the
// web panel's status) reads share() from any thread. A report is one relaxed atomic store:
// it takes no lock and allocates nothing, so the executor's real-time tick may report every
// period. Shares only grow in the display's eyes: a report below the last one is kept as
// reported (work that re-plans may move back), clamped to [0, 1], and NaN is ignored.
//
// Work made of parts reports each part into a slice of its parent:
//
//     Progress overall;                         // read by the display
//     for (int i = 0; i < n; ++i) {
//       Progress part(&overall, double(i) / n, double(i + 1) / n);
//       search_one(..., &part);                 // reports 0 .. 1 of its own
//     }
//
// A part forwards every report, mapped into its slice, to its parent (and so on up); it must
// not outlive the parent. Workers take a `Progress*` that may be null (nobody is watching).
//
// Threading: report() from one worker thread at a time per object (several threads may each
// report into their own part of a common parent: the parent's store is atomic); share() from
// any thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>

namespace machplan {

class Progress {
 public:
  Progress() = default;
  // A slice [lo, hi] of `parent` (0 <= lo <= hi <= 1). `parent` may be null: then the part
  // only keeps its own share.
  Progress(Progress* parent, double lo, double hi) : parent_(parent), lo_(lo), hi_(hi) {}
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // The worker: `fraction` of this work is done (0 .. 1).
  void report(double fraction) noexcept {
    if (std::isnan(fraction)) return;
    fraction = std::clamp(fraction, 0.0, 1.0);
    share_.store(fraction, std::memory_order_relaxed);
    if (parent_) parent_->report(lo_ + (hi_ - lo_) * fraction);
  }
  // The work is over (whatever ended it): the share reads 1.
  void finish() noexcept { report(1.0); }

  // The display: the last share reported, 0 .. 1.
  double share() const noexcept { return share_.load(std::memory_order_relaxed); }

 private:
  static_assert(std::atomic<double>::is_always_lock_free);
  std::atomic<double> share_{0.0};
  Progress* parent_ = nullptr;
  double lo_ = 0.0, hi_ = 1.0;
};

// Reports into `p` when it is not null.
inline void report_progress(Progress* p, double fraction) noexcept {
  if (p) p->report(fraction);
}

}  // namespace machplan
