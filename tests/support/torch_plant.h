// The torch sequencer's world for its own tests: a plasma torch with a height axis, and a
// plant that answers its outputs (a height axis, an arc, a plate with a float switch and an
// ohmic contact). Hand-made inputs, one servo period at a time.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "engine/executor/torch_sequencer.h"

namespace machplan::test {

// Plasma with a height axis, no probe (heights, tolerances and timeouts small enough for tests).
inline executor::TorchSetup plasma_with_height() {
  executor::TorchSetup t;
  t.kind = executor::TorchSetup::Kind::plasma;
  t.height_axis = true;
  t.pierce_height_mm = 3.8;
  t.cut_height_mm = 1.5;
  t.retract_height_mm = 15.0;
  t.height_tolerance_mm = 0.05;
  t.height_timeout_s = 1.0;
  t.arc_ok_timeout_s = 0.5;
  t.pierce_delay_s = 0.2;
  return t;
}

// The same with a probe: 5 mm probe height, 10 mm/s, 1.5 mm float travel, 5 mm depth, 3 periods.
inline executor::TorchSetup probing_torch(bool ohmic, bool float_switch) {
  executor::TorchSetup t = plasma_with_height();
  t.probe.ohmic = ohmic;
  t.probe.float_switch = float_switch;
  t.probe.probe_height_mm = 5.0;
  t.probe.probe_speed_mm_per_s = 10.0;
  t.probe.float_travel_mm = 1.5;
  t.probe.max_depth_mm = 5.0;
  t.probe.debounce_periods = 3;
  return t;
}

// A height axis at `speed` toward its target; an arc that lights `arc_delay` after firing
// (never, if negative); a plate at `plate` (none: no sheet) whose float switch closes once the
// torch is `travel` under its surface and whose ohmic contact closes at the surface while
// ohmic sensing is on (not on a `dirty` plate).
struct TorchPlant {
  std::optional<double> plate = 0.0;
  double height = 15.0, speed = 50.0, arc_delay = 0.1, travel = 1.5, fired_for = 0.0;
  bool dirty = false, float_stuck = false;
  double lowest = 15.0, height_at_fire = NAN;
  int glitch_at = -1, period = 0;  // one period in which the float switch reads closed
  void step(const hardware::Outputs& o, hardware::Inputs& in, double dt) {
    const double d = o.torch_height_target_mm - height;
    height += std::clamp(d, -speed * dt, speed * dt);
    lowest = std::min(lowest, height);
    if (o.torch_fire && fired_for == 0.0) height_at_fire = height;
    fired_for = o.torch_fire ? fired_for + dt : 0.0;
    in.torch_height_mm = height;
    in.arc_ok = o.torch_fire && arc_delay >= 0 && fired_for >= arc_delay;
    const double gap = plate ? height - *plate : 1e9;
    in.float_switch = float_stuck || gap <= -travel || period == glitch_at;
    in.ohmic_sense = o.ohmic_enable && !dirty && gap <= 0.0;
    ++period;
  }
};

// Runs until the sequencer is no longer busy; returns its status and the time taken.
inline std::pair<executor::TorchSequencer::Tick, double> run_torch(executor::TorchSequencer& seq, TorchPlant& p,
                                                                   hardware::Outputs& out, double limit_s = 10) {
  hardware::Inputs in;
  const double dt = 0.001;
  for (double t = 0; t < limit_s; t += dt) {
    p.step(out, in, dt);
    const executor::TorchSequencer::Tick s = seq.tick(in, out);
    if (s != executor::TorchSequencer::Tick::busy) return {s, t + dt};
  }
  return {executor::TorchSequencer::Tick::busy, limit_s};
}

}  // namespace machplan::test
