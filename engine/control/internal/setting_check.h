// Range checks of controller settings (gains, drive models): one message form for all of them,
// InputError::field("FIELD", "VALUE RULE") ("kp_per_s: -1 must be finite and >= 0").
#pragma once

#include <cmath>

#include "engine/common/error.h"

namespace machplan::control {

inline bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0; }

// The gains PidGains and ServoGains share: Kp, Ki, Kd >= 0, velocity feed-forward in [0, 3],
// acceleration feed-forward time in [0, 1] s, following-error limit > 0.
inline void require_pid_core(double kp, double ki, double kd, double velocity_ff, double acceleration_ff_s,
                             double following_error_limit_mm) {
  require_field(finite_nonneg(kp), "kp_per_s", kp, "must be finite and >= 0");
  require_field(finite_nonneg(ki), "ki_per_s2", ki, "must be finite and >= 0");
  require_field(finite_nonneg(kd), "kd", kd, "must be finite and >= 0");
  require_field(finite_nonneg(velocity_ff) && velocity_ff <= 3, "velocity_ff", velocity_ff, "must be in [0, 3]");
  require_field(finite_nonneg(acceleration_ff_s) && acceleration_ff_s <= 1, "acceleration_ff_s", acceleration_ff_s,
                "must be in [0, 1] s");
  require_field(std::isfinite(following_error_limit_mm) && following_error_limit_mm > 0, "following_error_limit_mm",
                following_error_limit_mm, "must be > 0");
}

}  // namespace machplan::control
