#include "solvers/placement/machines/machine_model.h"

#include <cmath>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "solvers/placement/machines/hexam_model.h"
#include "solvers/placement/machines/trunnion_model.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

Where Where::of(const Placement& p) {
  Where w;
  w.offset = p.offset();
  w.rotation_rad = p.rotation_deg * M_PI / 180.0;
  w.R = Eigen::AngleAxisd(w.rotation_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return w;
}

double TableShape::margin(const Eigen::Vector2d& p) const {
  if (round) return half_mm.x() - p.norm();
  return std::min(half_mm.x() - std::abs(p.x()), half_mm.y() - std::abs(p.y()));
}

Eigen::Matrix3d MachineModel::plate_rotation(const Eigen::Vector3d& axis) const {
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
}

std::shared_ptr<const MachineModel> make_machine_model(const Scene& scene, int tooling_line) {
  const Yaml root = Yaml::load_file(scene.machine.source);
  const std::string kind = root.has("kind") ? root.string("kind") : "hexapod";
  if (kind == "hexapod") {
    hexam::Machine m = hexam::machine_from_yaml(root);
    try {
      hexam::attach_tooling(m, scene.tooling);
    } catch (const InputError& e) {
      throw InputError(scene.source, tooling_line, "tooling does not fit machine " + m.source + ": " + e.message());
    }
    return make_hexapod_model(m, scene);
  }
  if (kind == "table_tilting") return make_trunnion_model(trunnion::machine_from_yaml(root), scene);
  root.at("kind").fail(fmt::format("'{}' is not a machine kind placement knows (hexapod, table_tilting)", kind.substr(0, 40)));
}

}  // namespace machplan::placement
