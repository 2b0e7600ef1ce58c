// The operator's inputs from outside the servo loop: a keyboard thread, the web panel, a
// scripted test. They reach the executor the way every other signal does: merged into the
// backend's Inputs at each exchange, sampled once per period.
//
//   OperatorChannel   a mailbox of the newest OperatorInputs (a Latest, engine/common/latest.h):
//                     writers (any thread; they serialise among themselves) set() whole
//                     states, the servo loop reads the newest one.
//   OperatorMerge     a Backend that wraps another and merges a channel into its inputs after
//                     each exchange. Everything else passes through unchanged.
//
// Merge rule (OperatorMerger): buttons (feed hold, cycle start, stop) are pressed when either
// side presses them, and the operator's E-stop is open when either side opens it; the jog is
// the channel's while the channel deflects any axis, else the backend's own (a pendant, a HAL
// pin, the simulator's timeline), and so is the paused-motion speed; a level (the overrides, THC and torch on/off) is the one that changed
// last, as when a panel's knob and a HAL pin both set the same override; paused-motion distances
// of both sides add up.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>

#include "engine/common/latest.h"
#include "engine/hardware/backend.h"

namespace machplan::hardware {

class OperatorMerger {
 public:
  // The merged inputs of this period. Real time: no allocation.
  OperatorInputs merge(const OperatorInputs& backend, const OperatorInputs& channel) noexcept;

 private:
  OperatorInputs last_backend_{}, last_channel_{}, levels_{};
};

// The operator's inputs from any thread (the newest set wins), read by the tick.
class OperatorChannel {
 public:
  // Any thread; not real time.
  void set(const OperatorInputs& inputs) {
    const std::lock_guard<std::mutex> lock(write_);
    latest_.publish(inputs);
  }
  // The servo loop only: lock-free (the only reader), allocation-free.
  const OperatorInputs& latest() noexcept { return latest_.read_single(); }

 private:
  Latest<OperatorInputs> latest_;
  std::mutex write_;
};

class OperatorMerge final : public Backend {
 public:
  // Neither is owned; both must outlive this.
  OperatorMerge(Backend& inner, OperatorChannel& channel) : inner_(inner), channel_(channel) {}
  const char* name() const override { return inner_.name(); }
  CommandKind command_kind() const override { return inner_.command_kind(); }
  double period_s() const override { return inner_.period_s(); }
  AxisSignals axis_signals(int axis) const override { return inner_.axis_signals(axis); }
  int watchdog_periods() const override { return inner_.watchdog_periods(); }
  bool realtime() const override { return inner_.realtime(); }
  int plays_ahead_periods() const override { return inner_.plays_ahead_periods(); }
  Inputs initial_inputs() override;
  Health exchange(const Outputs& out, Inputs& in) noexcept override;
  bool true_position(Eigen::Vector2d& out_mm) const noexcept override { return inner_.true_position(out_mm); }
  std::vector<std::string> notes() const override { return inner_.notes(); }
  bool true_torch_gap(double& gap_mm) const noexcept override { return inner_.true_torch_gap(gap_mm); }
  Backend& inner() { return inner_; }

 private:
  Backend& inner_;
  OperatorChannel& channel_;
  OperatorMerger merger_;
};

}  // namespace machplan::hardware
