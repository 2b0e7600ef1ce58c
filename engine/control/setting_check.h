// Range checks of controller settings (gains, drive models): one message form for all of them,
// std::invalid_argument("TYPE::FIELD = VALUE: RULE").
#pragma once

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace machplan::control {

inline void require_setting(bool ok, const char* type, const char* field, double value, const char* rule) {
  if (!ok) throw std::invalid_argument(fmt::format("{}::{} = {}: {}", type, field, value, rule));
}

inline bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0; }

// The gains PidGains and ServoGains share: Kp, Ki, Kd >= 0, velocity feed-forward in [0, 3],
// acceleration feed-forward time in [0, 1] s, following-error limit > 0.
inline void require_pid_core(const char* type, double kp, double ki, double kd, double velocity_ff,
                             double acceleration_ff_s, double following_error_limit_mm) {
  require_setting(finite_nonneg(kp), type, "kp_per_s", kp, "must be finite and >= 0");
  require_setting(finite_nonneg(ki), type, "ki_per_s2", ki, "must be finite and >= 0");
  require_setting(finite_nonneg(kd), type, "kd", kd, "must be finite and >= 0");
  require_setting(finite_nonneg(velocity_ff) && velocity_ff <= 3, type, "velocity_ff", velocity_ff, "must be in [0, 3]");
  require_setting(finite_nonneg(acceleration_ff_s) && acceleration_ff_s <= 1, type, "acceleration_ff_s",
                  acceleration_ff_s, "must be in [0, 1] s");
  require_setting(std::isfinite(following_error_limit_mm) && following_error_limit_mm > 0, type,
                  "following_error_limit_mm", following_error_limit_mm, "must be > 0");
}

}  // namespace machplan::control
