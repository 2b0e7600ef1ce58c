// The controllers' view of a machine file: the executor's setup (servo gains, DAC range,
// latencies, period) plus what only the machine model knows, the drive's velocity-loop time
// constant, gain, Coulomb friction and backlash (models/axis/plant.h), which model-based controllers (ZPETC) and the
// feed-forward defaults are built from.
#pragma once

#include "engine/control/controller_factory.h"
#include "engine/executor/machine_setup.h"
#include "models/cutting/machine_config.h"

namespace machplan::cutting {

inline control::ControllerPlant controller_plant(const MachineConfig& m) {
  control::ControllerPlant p = executor::plant_from_setup(m.setup());
  for (int i = 0; i < control::kAxes; ++i) {
    p.drive_time_constant_s[i] = m.axes[i].plant.velocity_loop_time_constant_s;
    p.gain_factor[i] = m.axes[i].plant.gain_factor;
    p.coulomb_friction_mm_per_s[i] = m.axes[i].plant.coulomb_friction_mm_per_s;
    p.backlash_mm[i] = m.axes[i].plant.backlash_mm;
  }
  return p;
}

}  // namespace machplan::cutting
