#include "engine/executor/thc.h"

#include <algorithm>
#include <cmath>

#include "engine/common/error.h"

namespace machplan::executor {

void ThcSettings::validate() const {
  require_field(std::isfinite(delay_s) && delay_s >= 0 && delay_s <= 60, "delay_s", delay_s, "must be in [0, 60] s");
  require_field(std::isfinite(sample_s) && sample_s > 0 && sample_s <= 10, "sample_s", sample_s, "must be in (0, 10] s");
  require_field(std::isfinite(threshold_v) && threshold_v >= 0 && threshold_v <= 50, "threshold_v", threshold_v,
                "must be in [0, 50] V");
  require_field(std::isfinite(speed_mm_per_s_per_v) && speed_mm_per_s_per_v > 0 && speed_mm_per_s_per_v <= 100,
                "speed_mm_per_s_per_v", speed_mm_per_s_per_v, "must be in (0, 100] mm/s per V");
  require_field(std::isfinite(max_speed_mm_per_s) && max_speed_mm_per_s > 0 && max_speed_mm_per_s <= 1000,
                "max_speed_mm_per_s", max_speed_mm_per_s, "must be in (0, 1000] mm/s");
  require_field(std::isfinite(velocity_anti_dive_pct) && velocity_anti_dive_pct >= 0 && velocity_anti_dive_pct <= 100,
                "velocity_anti_dive_pct", velocity_anti_dive_pct, "must be in [0, 100] %");
  require_field(std::isfinite(void_anti_dive_v_per_s) && void_anti_dive_v_per_s > 0 && void_anti_dive_v_per_s <= 1e6,
                "void_anti_dive_v_per_s", void_anti_dive_v_per_s, "must be in (0, 1e6] V/s");
  require_field(std::isfinite(max_correction_mm) && max_correction_mm >= 0 && max_correction_mm <= 50, "max_correction_mm",
                max_correction_mm, "must be in [0, 50] mm");
}

void ThcController::reset(double target_v) noexcept {
  z_ = 0.0;
  given_v_ = target_v;
  target_v_ = 0.0;
  at_feed_s_ = sampled_s_ = sum_v_ = 0.0;
  v_filtered_ = dv_filtered_ = void_lock_s_ = void_from_v_ = 0.0;
  void_rising_ = false;
  samples_ = 0;
  armed_ = active_ = velocity_lock_ = primed_ = holding_ = false;
}

void ThcController::shift(double dz) noexcept {
  if (std::isfinite(dz)) z_ = std::clamp(z_ + dz, -s_.max_correction_mm, s_.max_correction_mm);
}

double ThcController::update(const Input& in) noexcept {
  // The voltage's rise rate, filtered over about 10 ms, for the void anti-dive.
  const double a = std::min(1.0, dt_ / 0.01);
  if (!primed_) {
    v_filtered_ = in.voltage_v;
    primed_ = true;
  }
  const double v_prev = v_filtered_;
  v_filtered_ += a * (in.voltage_v - v_filtered_);
  dv_filtered_ += a * ((v_filtered_ - v_prev) / dt_ - dv_filtered_);
  if (dv_filtered_ > s_.void_anti_dive_v_per_s) {
    if (!void_rising_) void_from_v_ = v_prev;
    void_rising_ = true;
  } else if (void_rising_ && v_filtered_ <= void_from_v_ + s_.threshold_v) {
    void_rising_ = false;
  }
  if (void_rising_) void_lock_s_ = 0.05;
  else void_lock_s_ = std::max(0.0, void_lock_s_ - dt_);

  const bool at_feed = in.feed_mm_per_s > 0 && in.speed_mm_per_s >= 0.99 * in.feed_mm_per_s;
  velocity_lock_ = in.speed_mm_per_s < s_.velocity_anti_dive_pct / 100.0 * in.feed_mm_per_s;
  if (!armed_) {
    at_feed_s_ = at_feed ? at_feed_s_ + dt_ : 0.0;
    armed_ = at_feed_s_ >= s_.delay_s;
  }
  if (target_v_ == 0.0) {
    if (given_v_ > 0) {
      target_v_ = given_v_;
    } else if (void_lock_s_ == 0.0) {
      sum_v_ += in.voltage_v;
      sampled_s_ += dt_;
      ++samples_;
      if (sampled_s_ >= s_.sample_s) target_v_ = sum_v_ / static_cast<double>(samples_);
    }
  }
  if (armed_ && target_v_ > 0.0 && std::abs(in.voltage_v - target_v_) <= s_.threshold_v) holding_ = true;
  active_ = armed_ && target_v_ > 0.0 && in.allowed && !velocity_lock_ && void_lock_s_ == 0.0;
  if (active_) {
    const double e = in.voltage_v - target_v_;
    if (std::abs(e) > s_.threshold_v) {
      const double dz = -std::clamp(s_.speed_mm_per_s_per_v * e, -s_.max_speed_mm_per_s, s_.max_speed_mm_per_s);
      z_ = std::clamp(z_ + dz * dt_, -s_.max_correction_mm, s_.max_correction_mm);
    }
  }
  return z_;
}

}  // namespace machplan::executor
