#include "engine/control/servo.h"

#include <stdexcept>

#include <fmt/format.h>

namespace machplan::control {

namespace {
void require(bool ok, const char* field, double value, const char* rule) {
  if (!ok) throw std::invalid_argument(fmt::format("ServoGains::{} = {}: {}", field, value, rule));
}
}  // namespace

void ServoGains::validate() const {
  auto nonneg = [](double v) { return std::isfinite(v) && v >= 0; };
  require(nonneg(kp_per_s), "kp_per_s", kp_per_s, "must be finite and >= 0");
  require(nonneg(ki_per_s2), "ki_per_s2", ki_per_s2, "must be finite and >= 0");
  require(nonneg(kd), "kd", kd, "must be finite and >= 0");
  require(nonneg(velocity_ff) && velocity_ff <= 3, "velocity_ff", velocity_ff, "must be in [0, 3]");
  require(nonneg(acceleration_ff_s) && acceleration_ff_s <= 1, "acceleration_ff_s", acceleration_ff_s,
          "must be in [0, 1] s");
  require(nonneg(ff_adaptation_per_s2) && ff_adaptation_per_s2 <= 1e5, "ff_adaptation_per_s2", ff_adaptation_per_s2,
          "must be in [0, 1e5]");
  require(std::isfinite(ff_adaptation_min_speed_mm_per_s) && ff_adaptation_min_speed_mm_per_s > 0,
          "ff_adaptation_min_speed_mm_per_s", ff_adaptation_min_speed_mm_per_s, "must be > 0");
  require(std::isfinite(following_error_limit_mm) && following_error_limit_mm > 0, "following_error_limit_mm",
          following_error_limit_mm, "must be > 0");
  require(nonneg(backlash_compensation_mm) && backlash_compensation_mm <= 5, "backlash_compensation_mm",
          backlash_compensation_mm, "must be in [0, 5] mm");
  require(std::isfinite(backlash_compensation_time_s) && backlash_compensation_time_s > 0, "backlash_compensation_time_s",
          backlash_compensation_time_s, "must be > 0");
}

}  // namespace machplan::control
