// Putting a stored calibration to work in the executor's view of a machine.
//
// The executor takes its machine as an executor::MachineSetup; a calibration changes it
// before the run, so the executor itself needs no knowledge of the store:
//   * feed factor k -> servo.velocity_ff = 1 / k: the feed-forward's starting gain (the
//     servo's on-line adaptation still learns from there, see engine/control/servo.h);
//   * backlash b    -> servo.backlash_compensation_mm = b (a pulse carrying b at reversals);
//   * the paper modes' open-loop factor for a feed comes from open_loop_factor() (store.h).
// The encoder scale is not written into the setup: the executor checks the setup's
// mm_per_count against what the backend declares, and on a real controller that declaration
// is where a fitted scale belongs (a changed scale means a changed backend configuration).
#pragma once

#include "engine/executor/machine_setup.h"
#include "solvers/calibration/store.h"

namespace machplan::calibration {

// Returns `setup` with the calibration applied. Throws InputError("--db", ...) when the stored
// fit lacks a factor or holds one no drive could have (feed factor outside (0.05, 20)).
executor::MachineSetup apply_calibration(executor::MachineSetup setup, const StoredFit& calibration);

}  // namespace machplan::calibration
