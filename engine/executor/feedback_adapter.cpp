#include "engine/executor/feedback_adapter.h"

#include <algorithm>
#include <cmath>

namespace machplan::executor {

void FeedbackAdapter::configure(const MachineSetup& m, hardware::CommandKind kind, double period_s,
                                double velocity_filter_s) {
  m_ = m;
  kind_ = kind;
  dt_ = period_s;
  vel_alpha_ = std::min(1.0, period_s / std::max(velocity_filter_s, period_s));
  for (int i = 0; i < hardware::kAxes; ++i) {
    const hardware::AxisSignals& sig = m.signals[i];
    if (kind_ == hardware::CommandKind::speed_dac) {
      // A calibrated encoder scale decodes the counts; the declared one only sets the limits.
      const double scale = m.calibrated_mm_per_count[i] > 0 ? m.calibrated_mm_per_count[i] : sig.mm_per_count;
      max_counts_[i] = static_cast<std::int64_t>(std::ceil(1.5 * m.max_speed_mm_per_s[i] * dt_ / sig.mm_per_count)) + 2;
      dec_[i].configure(scale, sig.counter_bits, max_counts_[i]);
      quantum_[i] = scale;
    } else {
      max_counts_[i] = 0;
      quantum_[i] = 1e-3;
    }
  }
}

void FeedbackAdapter::reset(const hardware::Inputs& initial, const Eigen::Vector2d& start_mm) {
  for (int i = 0; i < hardware::kAxes; ++i)
    if (kind_ == hardware::CommandKind::speed_dac) dec_[i].reset(initial.counter[i], start_mm[i]);
  pos_ = cmd_mm_ = start_mm;
  vel_.setZero();
  trusted_ = true;
}

FeedbackAdapter::Verdict FeedbackAdapter::update(const hardware::Inputs& in, int& bad_axis, double& jump) noexcept {
  if (!trusted_) return Verdict::ok;
  Eigen::Vector2d p = pos_;
  for (int i = 0; i < hardware::kAxes; ++i) {
    if (kind_ == hardware::CommandKind::speed_dac) {
      const auto v = dec_[i].update(in.counter[i], in.counter_direction_negative[i]);
      if (v != control::CounterDecoder::Verdict::ok) {
        trusted_ = false;
        bad_axis = i;
        jump = static_cast<double>(dec_[i].last_jump_counts());
        return v == control::CounterDecoder::Verdict::byte_carry_misread ? Verdict::counter_wrap_misread
                                                                          : Verdict::encoder_glitch;
      }
      p[i] = dec_[i].position_mm();
    } else {
      const double y = in.position_feedback_mm[i];
      const double reach = 1.5 * m_.max_speed_mm_per_s[i] * dt_ + 0.01;
      if (!std::isfinite(y) || std::abs(y - pos_[i]) > reach) {
        trusted_ = false;
        bad_axis = i;
        jump = std::isfinite(y) ? (y - pos_[i]) / quantum_[i] : 0.0;
        return Verdict::encoder_glitch;
      }
      p[i] = y;
    }
  }
  vel_ += vel_alpha_ * ((p - pos_) / dt_ - vel_);
  pos_ = p;
  return Verdict::ok;
}

bool FeedbackAdapter::write(const Eigen::Vector2d& u, const Eigen::Vector2d& setpoint_mm, bool integrate,
                            hardware::Outputs& out) noexcept {
  bool clipped = false;
  for (int i = 0; i < hardware::kAxes; ++i) {
    if (kind_ == hardware::CommandKind::speed_dac) {
      const hardware::AxisSignals& s = m_.signals[i];
      const double full = static_cast<double>(std::int64_t{1} << (s.dac_bits - 1));
      const double code = std::round(u[i] / s.dac_full_scale_mm_per_s * full);
      const double c = std::clamp(code, -full, full - 1);
      clipped = clipped || c != code;
      out.dac_code[i] = static_cast<std::int32_t>(c);
    } else {
      const double vmax = m_.max_speed_mm_per_s[i];
      const double v = std::clamp(u[i], -vmax, vmax);
      clipped = clipped || v != u[i];
      cmd_mm_[i] = integrate ? cmd_mm_[i] + v * dt_ : setpoint_mm[i];
      out.position_command_mm[i] = cmd_mm_[i];
    }
  }
  return clipped;
}

}  // namespace machplan::executor
