#include "models/sim/sim_backend.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace machplan::sim {

SimBackend::SimBackend(const cutting::MachineConfig& machine, const SimOptions& options)
    : m_(machine), opt_(options), period_s_(machine.servo_period_s), rng_(options.seed) {
  for (int i = 0; i < 2; ++i)
    plants_[i] = std::make_unique<axis::AxisPlant>(m_.axes[i].plant, opt_.start_mm[i], opt_.counter_start[i]);
  height_mm_ = height_target_mm_ = m_.torch_height.fitted ? m_.torch_height.retract_height_mm : 0.0;
  pending_.reserve(16);
  fired_.reserve(16);
}

void SimBackend::inject(const FaultInjection& f) {
  pending_.push_back(f);
  fired_.push_back(0);
}

hardware::AxisSignals SimBackend::axis_signals(int axis) const {
  const auto& p = m_.axes[axis].plant;
  return {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), p.command_latency_ticks,
          p.reading_latency_ticks};
}

hardware::Inputs SimBackend::sample() {
  hardware::Inputs in;
  for (int i = 0; i < 2; ++i) {
    const axis::CounterReading r = plants_[i]->read();
    std::uint32_t v = r.value;
    if (misread_[i] != 0) {
      const std::uint32_t mask = m_.axes[i].plant.counter_bits == 32 ? 0xFFFFFFFFu : ((1u << m_.axes[i].plant.counter_bits) - 1u);
      v = static_cast<std::uint32_t>(static_cast<std::int64_t>(v) + misread_[i]) & mask;
      misread_[i] = 0;
    }
    in.counter[i] = v;
    in.counter_direction_negative[i] = r.direction_negative;
  }
  in.arc_ok = m_.torch.kind == executor::TorchSetup::Kind::oxy_fuel ? fire_ : arc_burning_;
  in.estop = estop_;
  in.torch_height_mm = height_mm_;
  return in;
}

hardware::Inputs SimBackend::initial_inputs() { return sample(); }

void SimBackend::advance(const hardware::Outputs& out) {
  const double dt = period_s_;
  // Injected faults due at the start of this period.
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    if (fired_[k] || time_s_ + 0.5 * dt < pending_[k].at_s) continue;
    fired_[k] = 1;
    const FaultInjection& f = pending_[k];
    switch (f.kind) {
      case FaultInjection::Kind::encoder_glitch: plants_[f.axis]->glitch_counter(f.counts); break;
      case FaultInjection::Kind::counter_wrap_misread: misread_[f.axis] = (ticks_ % 2 == 0) ? 256 : -256; break;
      case FaultInjection::Kind::estop: estop_ = true; break;
      case FaultInjection::Kind::lost_backend: lost_ = true; break;
      case FaultInjection::Kind::stuck_axis: plants_[f.axis]->set_stuck(true); break;
      case FaultInjection::Kind::arc_loss: arc_lost_ = true; break;
    }
  }
  // The watchdog (lost link) and the E-stop chain cut drives and torch in hardware too.
  const bool alive = !lost_;
  enabled_ = alive && !estop_ ? out.drives_enabled : false;
  const bool fire = alive && !estop_ && out.torch_fire;

  for (int i = 0; i < 2; ++i) plants_[i]->step(enabled_ ? out.dac_code[i] : 0, enabled_, dt, rng_);

  // Torch.
  if (fire && !fire_) {
    ++arc_starts_;
    arc_timer_s_ = 0.0;
    arc_fails_ = uniform_fail();
  }
  fire_ = fire;
  if (!fire_) {
    arc_burning_ = false;
  } else if (m_.torch.kind == executor::TorchSetup::Kind::plasma) {
    arc_timer_s_ += dt;
    arc_burning_ = !arc_fails_ && !arc_lost_ && arc_timer_s_ >= m_.torch.plasma.arc_start_delay_s;
  } else {
    arc_burning_ = true;
  }

  // Torch height axis.
  if (m_.torch_height.fitted) {
    const double target = alive ? out.torch_height_target_mm : m_.torch_height.retract_height_mm;
    if (target < height_target_mm_ - 1e-9 && height_retracted_) {
      ihs_left_s_ = m_.torch_height.initial_height_sense_s;
      height_retracted_ = false;
    }
    if (target >= m_.torch_height.retract_height_mm - 1e-9) height_retracted_ = true;
    height_target_mm_ = target;
    if (ihs_left_s_ > 0) {
      ihs_left_s_ -= dt;
    } else {
      const double step = m_.torch_height.speed_mm_per_s * dt;
      height_mm_ += std::clamp(height_target_mm_ - height_mm_, -step, step);
    }
  }
  time_s_ += dt;
  ++ticks_;
}

hardware::Health SimBackend::exchange(const hardware::Outputs& out, hardware::Inputs& in) noexcept {
  if (opt_.realtime) {
    if (!started_) {
      t0_ = std::chrono::steady_clock::now();
      started_ = true;
    }
  }
  advance(out);
  in = sample();
  if (opt_.realtime) {
    const auto deadline = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(time_s_));
    std::this_thread::sleep_until(deadline);
  }
  return lost_ ? hardware::Health::lost : hardware::Health::ok;
}

bool SimBackend::true_position(Eigen::Vector2d& out_mm) const noexcept {
  out_mm = {plants_[0]->load_position_mm(), plants_[1]->load_position_mm()};
  return true;
}

void SimBackend::coast(double seconds) {
  hardware::Outputs off;
  off.torch_height_target_mm = m_.torch_height.retract_height_mm;
  const long n = std::lround(seconds / period_s_);
  for (long i = 0; i < n; ++i) advance(off);
}

}  // namespace machplan::sim
