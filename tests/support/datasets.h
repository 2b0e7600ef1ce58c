// Where the tests find the bundled data (the source tree's datasets/ folder), and the bundled
// machines they run on.
#pragma once

#include <string>

#include "engine/executor/machine_setup.h"
#include "models/cutting/machine_config.h"

namespace machplan::test {

inline const std::string kDatasets = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/";
inline const std::string kHexamPaper = kDatasets + "hexam-paper/";  // the paper's HexaM scene

// A bundled part program (datasets/parts/NAME).
inline std::string part(const std::string& name) { return kDatasets + "parts/" + name; }

// The bundled machines, as `--machine NAME` finds them.
inline cutting::MachineConfig gantry() { return cutting::load_machine(cutting::find_machine("thermal_gantry")); }
inline const executor::MachineSetup& xy_table_setup() {
  static const executor::MachineSetup s = cutting::load_machine(cutting::find_machine("xy_table")).setup();
  return s;
}

}  // namespace machplan::test
