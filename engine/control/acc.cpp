#include "engine/control/acc.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::control {
void AccOptions::validate() const {
  require_field(std::isfinite(sample_s) && sample_s >= 0.001 && sample_s <= 10, "sample_s", sample_s, "must be in [0.001, 10]");
  require_field(std::isfinite(reference_force_n) && reference_force_n > 0, "reference_force_n", reference_force_n, "must be > 0");
  require_field(std::isfinite(kc) && kc >= 0 && kc <= 100, "kc", kc, "must be in [0, 100]");
  require_field(std::isfinite(feed_step_mm_per_rev) && feed_step_mm_per_rev > 0, "feed_step_mm_per_rev", feed_step_mm_per_rev,
          "must be > 0");
  require_field(std::isfinite(open_loop_gain) && open_loop_gain >= 0 && open_loop_gain <= 10, "open_loop_gain", open_loop_gain,
          "must be in [0, 10]");
  require_field(std::isfinite(max_feed_mm_per_rev) && max_feed_mm_per_rev > 0, "max_feed_mm_per_rev", max_feed_mm_per_rev,
          "must be > 0");
  require_field(std::isfinite(min_feed_mm_per_rev) && min_feed_mm_per_rev > 0 && min_feed_mm_per_rev < max_feed_mm_per_rev,
          "min_feed_mm_per_rev", min_feed_mm_per_rev, "must be > 0 and < max_feed_mm_per_rev");
  require_field(std::isfinite(min_force_for_estimate_n) && min_force_for_estimate_n > 0, "min_force_for_estimate_n",
          min_force_for_estimate_n, "must be > 0");
}

double AccController::update(double fc) noexcept {
  const double e = o_.reference_force_n - fc;
  double step;
  if (o_.variable_gain && fc >= o_.min_force_for_estimate_n)
    step = o_.open_loop_gain * e * feed_ / (beta_ * fc);
  else
    step = o_.kc * (e / o_.reference_force_n) * o_.feed_step_mm_per_rev;
  feed_ = std::clamp(feed_ + step, o_.min_feed_mm_per_rev, o_.max_feed_mm_per_rev);
  return feed_;
}

double AccController::open_loop_gain(double f) const {
  if (o_.variable_gain) return o_.open_loop_gain;
  return o_.kc * beta_ * o_.feed_step_mm_per_rev / f;
}

}  // namespace machplan::control
