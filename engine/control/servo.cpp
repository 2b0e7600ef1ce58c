#include "engine/control/servo.h"

#include <cmath>

#include "engine/control/internal/setting_check.h"

namespace machplan::control {

void ServoGains::validate() const {
  require_pid_core(kp_per_s, ki_per_s2, kd, velocity_ff, acceleration_ff_s, following_error_limit_mm);
  require_field(finite_nonneg(ff_adaptation_per_s2) && ff_adaptation_per_s2 <= 1e5, "ff_adaptation_per_s2", ff_adaptation_per_s2,
          "must be in [0, 1e5]");
  require_field(std::isfinite(ff_adaptation_min_speed_mm_per_s) && ff_adaptation_min_speed_mm_per_s > 0,
          "ff_adaptation_min_speed_mm_per_s", ff_adaptation_min_speed_mm_per_s, "must be > 0");
  require_field(finite_nonneg(backlash_compensation_mm) && backlash_compensation_mm <= 5, "backlash_compensation_mm",
          backlash_compensation_mm, "must be in [0, 5] mm");
  require_field(std::isfinite(backlash_compensation_time_s) && backlash_compensation_time_s > 0, "backlash_compensation_time_s",
          backlash_compensation_time_s, "must be > 0");
}

}  // namespace machplan::control
