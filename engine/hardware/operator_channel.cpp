#include "engine/hardware/operator_channel.h"

namespace machplan::hardware {

OperatorInputs OperatorMerger::merge(const OperatorInputs& backend, const OperatorInputs& channel) noexcept {
  OperatorInputs m = backend;
  bool deflected = false;
  for (double j : channel.jog) deflected = deflected || j != 0.0;
  if (deflected) m.jog = channel.jog;
  m.feed_hold = backend.feed_hold || channel.feed_hold;
  m.cycle_start = backend.cycle_start || channel.cycle_start;
  m.stop = backend.stop || channel.stop;
  m.estop = backend.estop || channel.estop;  // either side's E-stop stops the machine
  // Levels: whichever side changed last.
  const auto level = [](double b, double c, double& last_b, double& last_c, double& held) {
    if (b != last_b) held = b;
    if (c != last_c) held = c;
    last_b = b, last_c = c;
    return held;
  };
  m.feed_override_pct = level(backend.feed_override_pct, channel.feed_override_pct, last_backend_.feed_override_pct,
                              last_channel_.feed_override_pct, levels_.feed_override_pct);
  m.rapid_override_pct = level(backend.rapid_override_pct, channel.rapid_override_pct, last_backend_.rapid_override_pct,
                               last_channel_.rapid_override_pct, levels_.rapid_override_pct);
  const auto switch_level = [&](bool OperatorInputs::*f) {
    if (backend.*f != last_backend_.*f) levels_.*f = backend.*f;
    if (channel.*f != last_channel_.*f) levels_.*f = channel.*f;
    last_backend_.*f = backend.*f;
    last_channel_.*f = channel.*f;
    m.*f = levels_.*f;
  };
  switch_level(&OperatorInputs::thc_enabled);
  switch_level(&OperatorInputs::torch_enabled);
  m.paused_motion_mm = backend.paused_motion_mm + channel.paused_motion_mm;
  if (channel.paused_motion_speed != 0.0) m.paused_motion_speed = channel.paused_motion_speed;
  return m;
}

Inputs OperatorMerge::initial_inputs() {
  Inputs in = inner_.initial_inputs();
  in.op = merger_.merge(in.op, channel_.latest());
  return in;
}

Health OperatorMerge::exchange(const Outputs& out, Inputs& in) noexcept {
  const Health h = inner_.exchange(out, in);
  in.op = merger_.merge(in.op, channel_.latest());
  return h;
}

}  // namespace machplan::hardware
