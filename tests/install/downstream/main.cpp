// Uses each installed layer once, through the <machplan/...> include scheme: reads a bundled
// part program (engine), the bundled gantry (models) and the bundled placement scene
// (solvers), all from the installed share folder that find_package(machplan) reports. Prints what it read; exits 1 on any
// surprise so that the install test fails.
#include <cstdio>
#include <exception>
#include <string>

#include <machplan/engine/common/error.h>
#include <machplan/engine/programs/gcode.h>
#include <machplan/engine/programs/program.h>
#include <machplan/models/cutting/machine_config.h>
#include <machplan/solvers/placement/scene.h>

int main() {
  using namespace machplan;
  try {
    const std::string data = MACHPLAN_DATADIR;
    const Program program = read_gcode_file(data + "/datasets/parts/triangle_45.ngc");
    const std::string machine_file = cutting::find_machine(data + "/machines/thermal_gantry.yaml");
    const cutting::MachineConfig gantry = cutting::load_machine(machine_file);
    const placement::Scene scene = placement::load_scene(data + "/datasets/hexam-paper/scene.yaml");
    std::printf("program: %zu moves\nmachine: %s from %s\nscene: %s\n", program.moves.size(), gantry.name.c_str(),
                machine_file.c_str(), scene.source.c_str());
    if (program.moves.empty() || gantry.name != "thermal_gantry") return 1;
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "downstream: %s\n", e.what());
    return 1;
  }
}
