// How long a job's torch process and dwells keep the axes at rest, whatever the motion does.
//
// The executor holds the axes still while the torch pierces and retracts and during every
// dwell (engine/executor/executor.h), so a job's machine time is its motion plus this. Per
// torch_on step: `torch_on_s` (descent to pierce height, arc start or preheat, move to cut
// height; with a height axis its moves and the probe for the sheet), the arc start or preheat `start_s` and the pierce delay `pierce_s`, unless a dwell follows (a programmed
// G4 is the pierce delay; it is counted as a dwell); per torch_off step: `torch_off_s` (the
// retract); each dwell: its seconds. With `use_materials`, a torch_on with a material
// (Step::material) takes the material's pierce and cut heights, its pierce delay plus puddle
// jump delay instead of `pierce_s` (and the puddle jump height move), and its cut's torch_off
// first waits its pause at end; a ramp pierce (with a height axis, a cut following) counts the
// part of its delay (the G4's, when one follows) before the torch moves and what its gouge and
// creep speeds cost over the plan, not its descent to cut height, which overlaps the motion.
//
// One function, two callers with their own numbers: the run's expected time takes the machine
// file's nominal delays and speeds (solvers/motion/run.h), the executor's upper estimate (for
// its trace buffer) takes the timeouts it would wait at most.
#pragma once

#include <cstddef>
#include <optional>

#include "engine/motion/job.h"

namespace machplan::motion {

struct TorchTimes {
  // A torch height axis: each torch_on probes for the plate (when a probe is fitted), goes down
  // from where the torch waits to the pierce height and, after the pierce, to the cut height; each torch_off goes up to
  // the retract height, or to its own step's height when that is higher (a rapid over cut
  // parts follows), where the torch then waits; a torch_off with no cut lit (a second M5, an
  // M6 before the first cut) goes there from where the torch waits. Moves within
  // `tolerance_mm` of their target cost nothing.
  struct Height {
    double retract_mm = 0.0, pierce_mm = 0.0, cut_mm = 0.0, speed_mm_per_s = 1.0, tolerance_mm = 0.0;
  };
  std::optional<Height> height;
  // The probe on a nominal (flat) sheet, as engine/executor/torch_sequencer.h runs it: at the
  // height axis' speed from where the torch waits to `height_mm`, at `speed_mm_per_s` down to
  // the contact (the surface for an ohmic contact, `contact_below_mm` under it for a float
  // switch alone) and `debounce_s` on, then at the axis' speed up to the pierce height. A
  // torch_on within `skip_distance_mm` (in x and y) of the last probed point does not probe.
  // An offset probe (`offset`) probes in the job's probe steps instead: `offset_delay_s` to
  // deploy, the probe down as above, then up to `height_mm` over the surface while it is stowed
  // (at least `offset_delay_s`); the torch_on after it goes from there to pierce height, and a
  // torch_on without one does not probe.
  struct Probe {
    double height_mm = 5.0, speed_mm_per_s = 10.0, contact_below_mm = 0.0, debounce_s = 0.0, skip_distance_mm = 0.0;
    bool offset = false;
    double offset_delay_s = 0.0;
  };
  std::optional<Probe> probe;  // with `height` only
  double torch_on_s = 0.0;   // a torch_on step's own time without a height axis (the executor: timeouts)
  double start_s = 0.0;      // then the arc start (plasma) or the preheat (oxy-fuel)
  double pierce_s = 0.0;     // the pierce delay when no dwell follows the torch_on
  double torch_off_s = 0.0;  // a torch_off step without a height axis
  // Take each cut's material (Job::materials) for its heights and delays, as an executor that
  // applies the materials at each torch_on does.
  bool use_materials = false;
};

double process_time_s(const Job& job, const TorchTimes& times);

// The cutting move a ramp pierce at torch_on step `i` moves along: the step after it, or after
// the dwell that follows it (the pierce delay); 0 when that is not a cutting move. The
// executor and process_time_s take the same one.
std::size_t ramp_cut(const Job& job, std::size_t i);

}  // namespace machplan::motion
