#include "models/axis/plant.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::axis {

namespace {
void require(bool ok, const char* field, double value, const char* rule) {
  require_field(ok, field, value, rule);
}
int sgn(double x) { return (x > 0) - (x < 0); }
}  // namespace

void AxisPlantParams::validate() const {
  auto finite = [](double v) { return std::isfinite(v); };
  require(finite(motor_max_rpm) && motor_max_rpm > 0, "motor_max_rpm", motor_max_rpm, "must be > 0");
  require(finite(gear_ratio) && gear_ratio > 0, "gear_ratio", gear_ratio, "must be > 0");
  require(finite(mm_per_rev) && mm_per_rev > 0, "mm_per_rev", mm_per_rev, "must be > 0");
  require(finite(dac_full_scale_rpm) && dac_full_scale_rpm > 0, "dac_full_scale_rpm", dac_full_scale_rpm, "must be > 0");
  require(dac_bits >= 8 && dac_bits <= 24, "dac_bits", dac_bits, "must be 8 .. 24");
  require(finite(velocity_loop_time_constant_s) && velocity_loop_time_constant_s > 0, "velocity_loop_time_constant_s",
          velocity_loop_time_constant_s, "must be > 0");
  require(finite(max_acceleration_mm_per_s2) && max_acceleration_mm_per_s2 >= 0, "max_acceleration_mm_per_s2",
          max_acceleration_mm_per_s2, "must be >= 0 (0: unlimited)");
  require(finite(gain_factor) && gain_factor > 0 && gain_factor <= 2, "gain_factor", gain_factor, "must be in (0, 2]");
  require(finite(coulomb_friction_mm_per_s) && coulomb_friction_mm_per_s >= 0, "coulomb_friction_mm_per_s",
          coulomb_friction_mm_per_s, "must be >= 0");
  require(finite(viscous_friction_ratio) && viscous_friction_ratio >= 0, "viscous_friction_ratio", viscous_friction_ratio,
          "must be >= 0");
  require(finite(speed_noise_mm_per_s) && speed_noise_mm_per_s >= 0, "speed_noise_mm_per_s", speed_noise_mm_per_s,
          "must be >= 0");
  require(finite(backlash_mm) && backlash_mm >= 0, "backlash_mm", backlash_mm, "must be >= 0");
  require(finite(start_shock_mm_per_s) && start_shock_mm_per_s >= 0, "start_shock_mm_per_s", start_shock_mm_per_s,
          "must be >= 0");
  require(encoder_lines_per_rev > 0, "encoder_lines_per_rev", encoder_lines_per_rev, "must be > 0");
  require(finite(encoder_mm_per_rev) && encoder_mm_per_rev > 0, "encoder_mm_per_rev", encoder_mm_per_rev, "must be > 0");
  require(decoding == 1 || decoding == 2 || decoding == 4, "decoding", decoding, "must be 1, 2 or 4");
  require(counter_bits >= 8 && counter_bits <= 32, "counter_bits", counter_bits, "must be 8 .. 32");
  require(command_latency_ticks >= 0 && command_latency_ticks <= kMaxLatencyTicks, "command_latency_ticks",
          command_latency_ticks, "must be 0 .. 15");
  require(reading_latency_ticks >= 0 && reading_latency_ticks <= kMaxLatencyTicks, "reading_latency_ticks",
          reading_latency_ticks, "must be 0 .. 15");
  require(substeps >= 1 && substeps <= 1000, "substeps", substeps, "must be 1 .. 1000");
}

double uniform01(std::mt19937_64& rng) {
  // The top 53 bits of one 64-bit draw: exactly representable, in [0, 1).
  return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
}

double gaussian(std::mt19937_64& rng) {
  // Box-Muller; 1 - u is in (0, 1], so the logarithm is finite.
  const double u1 = 1.0 - uniform01(rng);
  const double u2 = uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

AxisPlant::AxisPlant(const AxisPlantParams& params, double position_mm, std::uint32_t counter_start) : p_(params) {
  p_.validate();
  q_mm_ = p_.mm_per_count();
  motor_mm_ = load_mm_ = position_mm;
  // The encoder's edges are referenced to the start position (the axis was homed there, on
  // an edge, as a reference run leaves it): the counter shows floor((x - start) / q) counts.
  grid_origin_mm_ = position_mm;
  count_pos_ = 0;
  counter_mask_ = p_.counter_bits == 32 ? 0xFFFFFFFFu : ((1u << p_.counter_bits) - 1u);
  counter_ = counter_start & counter_mask_;
  read_line_.fill(CounterReading{counter_, false});
}

void AxisPlant::glitch_counter(std::int32_t counts) {
  counter_ = static_cast<std::uint32_t>(static_cast<std::int64_t>(counter_) - counts) & counter_mask_;
}

void AxisPlant::step(std::int32_t dac_code, bool enabled, double dt_s, std::mt19937_64& rng) {
  constexpr int N = AxisPlantParams::kMaxLatencyTicks + 1;
  cmd_head_ = (cmd_head_ + 1) % N;
  const int lo = -(p_.dac_max_code() + 1), hi = p_.dac_max_code();
  cmd_line_[cmd_head_] = std::clamp(dac_code, lo, hi);
  const std::int32_t code = cmd_line_[(cmd_head_ - p_.command_latency_ticks + N) % N];

  if (enabled && !was_enabled_) first_command_pending_ = true;
  was_enabled_ = enabled;
  const double noise = p_.speed_noise_mm_per_s > 0 ? p_.speed_noise_mm_per_s * gaussian(rng) : 0.0;
  double target = 0.0;
  if (enabled) {
    const double u = static_cast<double>(code) / (p_.dac_max_code() + 1) * p_.dac_full_scale_mm_per_s();
    const double vmax = p_.max_speed_mm_per_s();
    target = std::clamp(p_.gain_factor * u + (code != 0 ? noise : 0.0), -vmax, vmax);
    if (first_command_pending_) {
      if (code != 0 && p_.start_shock_mm_per_s > 0 && !stuck_) {
        v_ += sgn(code) * p_.start_shock_mm_per_s;
        ++shock_count_;
      }
      first_command_pending_ = false;
    }
  }

  const double h = dt_s / p_.substeps;
  const double tau = p_.velocity_loop_time_constant_s;
  const double c = p_.coulomb_friction_mm_per_s;
  const double half_gap = 0.5 * p_.backlash_mm;
  for (int s = 0; s < p_.substeps; ++s) {
    if (stuck_) {
      v_ = 0.0;
    } else {
      double drive = target - v_ - p_.viscous_friction_ratio * v_;
      if (v_ == 0.0) {
        // Sticking: friction holds the axis while the drive's effort stays within it.
        drive = std::abs(drive) <= c ? 0.0 : drive - c * sgn(drive);
      } else {
        drive -= c * sgn(v_);
      }
      double dv = drive / tau * h;
      if (p_.max_acceleration_mm_per_s2 > 0) {
        const double lim = p_.max_acceleration_mm_per_s2 * h;
        dv = std::clamp(dv, -lim, lim);
      }
      const double v_new = v_ + dv;
      // Friction cannot reverse the motion by itself: crossing zero under friction stops.
      v_ = (v_ != 0.0 && sgn(v_new) != sgn(v_) && std::abs(target) <= c) ? 0.0 : v_new;
      motor_mm_ += v_ * h;
    }
    load_mm_ = std::clamp(load_mm_, motor_mm_ - half_gap, motor_mm_ + half_gap);
    const auto count = static_cast<std::int64_t>(std::floor((load_mm_ - grid_origin_mm_) / q_mm_));
    const std::int64_t edges = count - count_pos_;
    if (edges != 0) {
      const std::uint64_t n = static_cast<std::uint64_t>(edges > 0 ? edges : -edges);
      counter_ = static_cast<std::uint32_t>((counter_ - n) & counter_mask_);
      dir_negative_ = edges < 0;
      count_pos_ = count;
    }
  }

  read_head_ = (read_head_ + 1) % N;
  read_line_[read_head_] = CounterReading{counter_, dir_negative_};
}

CounterReading AxisPlant::read() const {
  constexpr int N = AxisPlantParams::kMaxLatencyTicks + 1;
  return read_line_[(read_head_ - p_.reading_latency_ticks + N) % N];
}

}  // namespace machplan::axis
