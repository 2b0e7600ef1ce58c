// Uses each installed layer once, through the <machplan/...> include scheme: reads a bundled
// part program (engine), the bundled gantry (models) and the bundled placement scene
// (solvers), all from the installed share folder that find_package(machplan) reports. Then
// calls into the libraries' private dependencies, which it links without seeing their
// headers: a distance query (FCL), a picture (Cairo) and a calibration store (SQLite), both
// written to the folder given as the first argument (yaml-cpp was read above). Prints what it
// did; exits 1 on any surprise so that the install test fails.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <machplan/engine/common/error.h>
#include <machplan/engine/interference/collision.h>
#include <machplan/engine/programs/gcode.h>
#include <machplan/engine/programs/program.h>
#include <machplan/models/cutting/machine_config.h>
#include <machplan/solvers/calibration/store.h>
#include <machplan/solvers/common/picture.h>
#include <machplan/solvers/placement/scene/scene.h>

int main(int argc, char** argv) {
  using namespace machplan;
  try {
    if (argc != 2) throw std::runtime_error("usage: downstream SCRATCH_FOLDER");
    const std::string data = MACHPLAN_DATADIR, scratch = argv[1];
    const Program program = read_gcode_file(data + "/datasets/parts/triangle_45.ngc");
    const std::string machine_file = cutting::find_machine(data + "/machines/thermal_gantry.yaml");
    const cutting::MachineConfig gantry = cutting::load_machine(machine_file);
    const placement::Scene scene = placement::load_scene(data + "/datasets/hexam-paper/scene.yaml");
    std::printf("program: %zu moves\nmachine: %s from %s\nscene: %s\n", program.moves.size(), gantry.name.c_str(),
                machine_file.c_str(), scene.source.c_str());
    if (program.moves.empty() || gantry.name != "thermal_gantry") return 1;

    const Eigen::Isometry3d at_origin = Eigen::Isometry3d::Identity();
    const Eigen::Isometry3d at_30(Eigen::Translation3d(30, 0, 0));
    using interference::Shape;
    const double gap = interference::distance(Shape::sphere(10), at_origin, Shape::sphere(5), at_30).distance_mm;
    std::printf("distance: %.3f mm between spheres of radius 10 and 5, 30 mm apart\n", gap);
    if (std::abs(gap - 15.0) > 0.01) return 1;

    const std::string picture = scratch + "/picture.png";
    write_picture(picture, "picture", 40, 30, [](Canvas& canvas) {
      canvas.set_source_rgb(0, 0, 0);
      canvas.move_to(5, 5);
      canvas.line_to(35, 25);
      canvas.stroke();
    });
    std::printf("picture: %s, %ju bytes\n", picture.c_str(), static_cast<std::uintmax_t>(std::filesystem::file_size(picture)));

    const calibration::CalibrationStore store(scratch + "/calibration.db");
    const std::size_t fits = store.history().size();
    std::printf("calibration store: %zu fits\n", fits);
    if (fits != 0) return 1;
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "downstream: %s\n", e.what());
    return 1;
  }
}
