#include "engine/control/pid_controller.h"

#include <fmt/format.h>

#include "engine/control/internal/setting_check.h"

namespace machplan::control {

void PidGains::validate() const {
  require_pid_core(kp_per_s, ki_per_s2, kd, velocity_ff, acceleration_ff_s, following_error_limit_mm);
  require_field(finite_nonneg(friction_ff_mm_per_s) && friction_ff_mm_per_s <= 100, "friction_ff_mm_per_s", friction_ff_mm_per_s,
          "must be in [0, 100] mm/s");
  require_field(std::isfinite(friction_ff_band_mm_per_s) && friction_ff_band_mm_per_s > 0, "friction_ff_band_mm_per_s",
          friction_ff_band_mm_per_s, "must be > 0");
  require_field(finite_nonneg(tracking_time_s), "tracking_time_s", tracking_time_s, "must be finite and >= 0 (0: Kp / Ki)");
  require_field(std::isfinite(derivative_filter_s) && derivative_filter_s > 0, "derivative_filter_s", derivative_filter_s,
          "must be > 0");
  require_field(finite_nonneg(backlash_ff_mm) && backlash_ff_mm <= 1, "backlash_ff_mm", backlash_ff_mm, "must be in [0, 1] mm");
  require_field(finite_nonneg(observer_per_s), "observer_per_s", observer_per_s, "must be finite and >= 0 (0: off)");
  require_field(!(ki_per_s2 > 0 && tracking_time_s == 0 && kp_per_s == 0), "kp_per_s", kp_per_s,
          "must be > 0 when Ki > 0 and the tracking time is Kp / Ki (or give tracking_time_s)");
}

void AxialPid::configure(const PidGains& g, double output_limit_mm_per_s, double period_s, ObserverModel observer) {
  g.validate();
  require_field(std::isfinite(output_limit_mm_per_s) && output_limit_mm_per_s > 0, "output_limit_mm_per_s",
                output_limit_mm_per_s, "must be > 0 mm/s");
  require_field(std::isfinite(period_s) && period_s > 0, "period_s", period_s, "must be > 0 s");
  g_ = g;
  u_max_ = output_limit_mm_per_s;
  T_ = period_s;
  tt_ = g.tracking_time_s > 0 ? g.tracking_time_s : (g.ki_per_s2 > 0 ? g.kp_per_s / g.ki_per_s2 : 1.0);
  observer.period_s = period_s;
  observer.speed_limit_mm_per_s = output_limit_mm_per_s;
  delay_ticks_ = observer.delay_ticks;
  observer_.configure(observer, g.observer_per_s);
  reset();
}

}  // namespace machplan::control
