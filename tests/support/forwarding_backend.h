// A backend that passes everything to another one, for tests that need to watch or disturb the
// exchanges (count allocations between them, request a stop at a given time, ...). Override
// exchange() and call ForwardingBackend::exchange() inside.
#pragma once

#include "engine/hardware/backend.h"

namespace machplan::test {

class ForwardingBackend : public hardware::Backend {
 public:
  explicit ForwardingBackend(hardware::Backend& inner) : inner_(inner) {}
  const char* name() const override { return inner_.name(); }
  hardware::CommandKind command_kind() const override { return inner_.command_kind(); }
  double period_s() const override { return inner_.period_s(); }
  hardware::AxisSignals axis_signals(int a) const override { return inner_.axis_signals(a); }
  int watchdog_periods() const override { return inner_.watchdog_periods(); }
  bool realtime() const override { return inner_.realtime(); }
  int plays_ahead_periods() const override { return inner_.plays_ahead_periods(); }
  hardware::Inputs initial_inputs() override { return inner_.initial_inputs(); }
  hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& i) noexcept override {
    return inner_.exchange(o, i);
  }
  bool true_position(Eigen::Vector2d& p) const noexcept override { return inner_.true_position(p); }

 protected:
  hardware::Backend& inner_;
};

}  // namespace machplan::test
