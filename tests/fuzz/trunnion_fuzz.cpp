// Fuzz target: the table-tilting machine's YAML kinematic chain (models/trunnion), and its
// inverse kinematics on a few tool axes. Any input must end in a machine or in
// machplan::InputError; anything else is a bug. Seeds in tests/fuzz/corpus/trunnion_fuzz/.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "models/trunnion/trunnion.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Meshes are named by path: keep each run away from the machine's files.
  if (text.find("mesh") != std::string::npos) return 0;
  using namespace machplan;
  try {
    const trunnion::Machine m = trunnion::machine_from_yaml(Yaml::load_string(text, "fuzz.yaml"));
    // The reader's promises: unit directions, ordered limits, the table's origin on its axis.
    if (std::abs(m.tilt.direction.norm() - 1) > 1e-9 || std::abs(m.table.direction.norm() - 1) > 1e-9) std::abort();
    if (!m.tilt.continuous && !(m.tilt.max_rad > m.tilt.min_rad)) std::abort();
    // Accelerations and jerks: positive where given, and an axis without them is named.
    for (const auto& a : m.linear)
      if (a.accel_mm_per_s2 < 0 || a.jerk_mm_per_s3 < 0 || (a.accel_mm_per_s2 == 0) != (a.jerk_mm_per_s3 == 0)) std::abort();
    if ((m.linear[0].accel_mm_per_s2 == 0) && m.dynamics_missing.empty()) std::abort();
    for (const Eigen::Vector3d& a : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.2, 0.9).normalized(),
                                     Eigen::Vector3d(-0.7, 0.1, 0.7).normalized()})
      for (const auto& s : trunnion::solve_angles(m, a))
        if ((trunnion::axis_at(m, s.a_rad, s.c_rad) - a).norm() > 1e-6) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
