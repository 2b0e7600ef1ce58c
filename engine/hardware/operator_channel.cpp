#include "engine/hardware/operator_channel.h"

namespace machplan::hardware {

OperatorInputs merge_operator(const OperatorInputs& backend, const OperatorInputs& channel) {
  OperatorInputs m = backend;
  bool deflected = false;
  for (double j : channel.jog) deflected = deflected || j != 0.0;
  if (deflected) m.jog = channel.jog;
  m.feed_hold = backend.feed_hold || channel.feed_hold;
  m.cycle_start = backend.cycle_start || channel.cycle_start;
  return m;
}

void OperatorChannel::set(const OperatorInputs& inputs) {
  const std::lock_guard<std::mutex> lock(write_);
  slots_[back_] = inputs;
  back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & 0x3;
}

const OperatorInputs& OperatorChannel::latest() noexcept {
  if (middle_.load(std::memory_order_relaxed) & kFresh)
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & 0x3;
  return slots_[front_];
}

Inputs OperatorMerge::initial_inputs() {
  Inputs in = inner_.initial_inputs();
  in.op = merge_operator(in.op, channel_.latest());
  return in;
}

Health OperatorMerge::exchange(const Outputs& out, Inputs& in) noexcept {
  const Health h = inner_.exchange(out, in);
  in.op = merge_operator(in.op, channel_.latest());
  return h;
}

}  // namespace machplan::hardware
