// Backends that do exactly what they are told, for tests and benchmarks of the executor itself.
//
//   IdealDacBackend       speed_dac: integrates the commanded speed (DAC code at the machine's
//                         nominal scaling) into position and counts like the gantry's down
//                         counters with a direction bit
//   IdealPositionBackend  position: the axes are wherever they were commanded (a drive with its
//                         own perfect position loop), as a LinuxCNC HAL connection would report
// Both honour the backend contract: watchdog on missed exchanges (miss_exchanges()), E-stop
// (set_estop()), operator inputs (set_operator()), and `lost` is final (lose()).
#pragma once

#include <cmath>
#include <cstdint>

#include "engine/hardware/backend.h"
#include "models/cutting/machine_config.h"

namespace machplan::test {

class IdealBackendBase : public hardware::Backend {
 public:
  explicit IdealBackendBase(const cutting::MachineConfig& m, Eigen::Vector2d start) : m_(m), pos_(start) {}
  double period_s() const override { return m_.servo_period_s; }
  int watchdog_periods() const override { return 20; }
  hardware::AxisSignals axis_signals(int a) const override {
    const auto& p = m_.axes[a].plant;
    // The machine's signals, without its latencies: an ideal drive acts in the period it is
    // commanded and its feedback is of that period (the contract suite checks that what a
    // backend declares is what it does).
    return {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), 0, 0};
  }
  hardware::Inputs initial_inputs() override {
    fill(in_);
    return in_;
  }
  hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& in) noexcept override {
    if (lost_) return hardware::Health::lost;
    enabled_ = o.drives_enabled && !estop_ && !watchdog_;
    if (enabled_) move(o);
    in_.estop = estop_;
    in_.watchdog_tripped = watchdog_;
    in_.torch_height_mm = o.torch_height_target_mm;
    // A flat sheet at the nominal surface, with the gantry's probe sensors (1.5 mm of float).
    in_.ohmic_sense = o.ohmic_enable && in_.torch_height_mm <= 0.0;
    in_.float_switch = in_.torch_height_mm <= -1.5;
    in_.arc_ok = o.torch_fire && !estop_ && !watchdog_;
    fill(in_);
    in = in_;
    return hardware::Health::ok;
  }
  bool true_position(Eigen::Vector2d& p) const noexcept override {
    p = pos_;
    return true;
  }
  void miss_exchanges(int n) {
    if (n > watchdog_periods()) watchdog_ = true;
  }
  void set_estop(bool e) { estop_ = e; }
  void set_operator(const hardware::OperatorInputs& op) { in_.op = op; }
  void lose() { lost_ = true; }
  bool drives_enabled() const { return enabled_; }

 protected:
  virtual void move(const hardware::Outputs& o) = 0;
  virtual void fill(hardware::Inputs& in) = 0;
  const cutting::MachineConfig& m_;
  Eigen::Vector2d pos_;
  hardware::Inputs in_{};
  bool enabled_ = false, estop_ = false, watchdog_ = false, lost_ = false;
};

class IdealDacBackend final : public IdealBackendBase {
 public:
  IdealDacBackend(const cutting::MachineConfig& m, Eigen::Vector2d start) : IdealBackendBase(m, start) {
    for (int i = 0; i < 2; ++i) count_pos_[i] = static_cast<std::int64_t>(std::floor(pos_[i] / q(i)));
    in_.counter = {1000u, 2000u};
  }
  const char* name() const override { return "ideal_dac"; }
  hardware::CommandKind command_kind() const override { return hardware::CommandKind::speed_dac; }

 private:
  double q(int i) const { return m_.axes[i].plant.mm_per_count(); }
  void move(const hardware::Outputs& o) override {
    for (int i = 0; i < 2; ++i) {
      const auto& p = m_.axes[i].plant;
      pos_[i] += o.dac_code[i] / double(p.dac_max_code() + 1) * p.dac_full_scale_mm_per_s() * period_s();
    }
  }
  void fill(hardware::Inputs& in) override {
    const std::uint32_t mask = 0xFFFFu;
    for (int i = 0; i < 2; ++i) {
      const auto c = static_cast<std::int64_t>(std::floor(pos_[i] / q(i)));
      const std::int64_t d = c - count_pos_[i];
      if (d != 0) {
        in.counter[i] = static_cast<std::uint32_t>(in.counter[i] - (d > 0 ? d : -d)) & mask;
        in.counter_direction_negative[i] = d < 0;
        count_pos_[i] = c;
      }
    }
  }
  std::array<std::int64_t, 2> count_pos_{};
};

class IdealPositionBackend final : public IdealBackendBase {
 public:
  using IdealBackendBase::IdealBackendBase;
  const char* name() const override { return "ideal_position"; }
  hardware::CommandKind command_kind() const override { return hardware::CommandKind::position; }

 private:
  void move(const hardware::Outputs& o) override {
    for (int i = 0; i < 2; ++i) pos_[i] = o.position_command_mm[i];
  }
  void fill(hardware::Inputs& in) override {
    for (int i = 0; i < 2; ++i) in.position_feedback_mm[i] = pos_[i];
  }
};

}  // namespace machplan::test
