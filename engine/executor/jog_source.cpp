#include "engine/executor/jog_source.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::executor {

void JogOptions::validate() const {
  require_field(std::isfinite(speed_mm_per_s) && speed_mm_per_s > 0 && speed_mm_per_s <= 1e4, "speed_mm_per_s", speed_mm_per_s,
                "must be in (0, 1e4] mm/s");
  require_field(std::isfinite(acceleration_mm_per_s2) && acceleration_mm_per_s2 >= 0 && acceleration_mm_per_s2 <= 1e6,
                "acceleration_mm_per_s2", acceleration_mm_per_s2, "must be in [0, 1e6] mm/s^2 (0: the machine's)");
  require_field(std::isfinite(jerk_mm_per_s3) && jerk_mm_per_s3 >= 0 && jerk_mm_per_s3 <= 1e9, "jerk_mm_per_s3", jerk_mm_per_s3,
                "must be in [0, 1e9] mm/s^3 (0: the machine's)");
  require_field(std::isfinite(deadband) && deadband >= 0 && deadband < 1, "deadband", deadband, "must be in [0, 1)");
}

void JogSource::prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) {
  o_.validate();
  const MachineSetup& m = *ctx.machine;
  dt_ = ctx.period_s;
  A_ = o_.acceleration_mm_per_s2 > 0 ? o_.acceleration_mm_per_s2 : m.max_acceleration_mm_per_s2;
  J_ = o_.jerk_mm_per_s3 > 0 ? o_.jerk_mm_per_s3 : m.max_jerk_mm_per_s3;
  vmax_ = o_.speed_mm_per_s;
  for (int i = 0; i < control::kAxes; ++i) {
    vmax_ = std::min(vmax_, m.max_speed_mm_per_s[i]);
    read_latency_[i] = std::clamp(m.signals[i].reading_latency_ticks, 0, kHistory - 1);
    x_[i] = start_mm[i];
    v_[i] = a_[i] = 0.0;
  }
  for (auto& p : past_) p = x_;
  head_ = 0;
}

void JogSource::advance(const Eigen::Vector2d&, const hardware::OperatorInputs& op) noexcept {
  for (int i = 0; i < control::kAxes; ++i) {
    double jog = std::isfinite(op.jog[i]) ? std::clamp(op.jog[i], -1.0, 1.0) : 0.0;
    if (std::abs(jog) < o_.deadband) jog = 0.0;
    const double target = jog * vmax_;
    const double dv = target - v_[i];
    double& a = a_[i];
    if (std::abs(dv) <= J_ * dt_ * dt_ && std::abs(a) <= J_ * dt_) {
      a = 0.0;
      v_[i] = target;
    } else {
      const double coast = a * std::abs(a) / (2.0 * J_);  // speed still gained if a ramps to 0 now
      a = dv - coast > 0 ? std::min(a + J_ * dt_, A_) : std::max(a - J_ * dt_, -A_);
      const double v = v_[i] + a * dt_;
      if ((target - v_[i]) * (target - v) < 0) {
        // This period would pass the target speed: land on it (a is small by then).
        v_[i] = target;
        a = 0.0;
      } else {
        v_[i] = v;
      }
    }
    x_[i] += v_[i] * dt_;
  }
  head_ = (head_ + 1) % kHistory;
  past_[head_] = x_;
}

void JogSource::demand(Demand& d) const noexcept {
  d.kind = Demand::Kind::track;
  d.track.path = nullptr;
  for (int i = 0; i < control::kAxes; ++i) {
    d.track.r_mm[i] = past_[(head_ - read_latency_[i] + kHistory) % kHistory][i];
    d.track.v_ff_mm_per_s[i] = v_[i];
    d.track.a_ff_mm_per_s2[i] = a_[i];
  }
  d.commanded_mm = {x_[0], x_[1]};
}

}  // namespace machplan::executor
