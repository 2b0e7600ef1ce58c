// Putting a stored calibration to work in the executor's view of a machine.
//
// The executor takes its machine as an executor::MachineSetup; a calibration changes it
// before the run, so the executor itself needs no knowledge of the store:
//   * feed factor k -> servo.velocity_ff = 1 / k: the feed-forward's starting gain (the
//     servo's on-line adaptation still learns from there, see engine/control/servo.h);
//   * backlash b    -> servo.backlash_compensation_mm = b (a pulse carrying b at reversals);
//   * encoder scale -> calibrated_mm_per_count: the executor's feedback adapter decodes the
//     counters with it (the backend's declared scale stays what it checks the machine file
//     against);
//   * the paper modes' open-loop factor for a feed comes from open_loop_factor() (store.h).
#pragma once

#include "engine/executor/machine_setup.h"
#include "solvers/calibration/store.h"

namespace machplan::calibration {

// Returns `setup` with the calibration applied. Throws InputError::field("calibration", ...)
// when the stored fit lacks a factor or holds one no drive could have (feed factor outside
// (0.05, 20), an encoder scale more than 10 % from the machine file's).
executor::MachineSetup apply_calibration(executor::MachineSetup setup, const StoredFit& calibration);

}  // namespace machplan::calibration
