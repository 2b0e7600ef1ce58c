#include "solvers/placement/machines/machine_model.h"

#include <cmath>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "models/trunnion/trunnion.h"
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

std::shared_ptr<const MachineModel> make_machine_model(const Scene& scene, const Yaml& root, const Tooling& tooling,
                                                       const ToolingOrigin& origin) {
  const std::string kind = root.has("kind") ? root.string("kind") : "hexapod";
  if (kind == "hexapod") {
    hexam::Machine m = hexam::machine_from_yaml(root);
    try {
      hexam::attach_tooling(m, tooling);
    } catch (const InputError& e) {
      throw InputError(origin.file, origin.line,
                       fmt::format("{} does not fit machine {}: {}", origin.tool, m.source, e.message()));
    }
    return make_hexapod_model(m, scene);
  }
  if (kind == "table_tilting") {
    const trunnion::Machine m = trunnion::machine_from_yaml(root);
    // The tip on the table's top at the centre, the rotary axes at zero: an axis the tool's
    // length pushes beyond its travel there is beyond it wherever the tip is on or above the
    // table (a higher tip only pushes it further).
    const double gauge = tooling.stick_out_mm + tooling.chuck_length_mm;
    const Eigen::Vector3d q0 = m.axes_for_nose(m.table_origin_mm);
    const Eigen::Vector3d q = m.axes_for_nose(m.table_origin_mm + gauge * m.spindle_direction);
    for (int k = 0; k < 3; ++k)
      if ((q[k] > m.linear[k].max_mm + 1e-9 && q[k] > q0[k]) || (q[k] < m.linear[k].min_mm - 1e-9 && q[k] < q0[k]))
        throw InputError(origin.file, origin.line,
                         fmt::format("{} does not fit machine {}: {:.1f} mm from its tip to the spindle nose (out of "
                                     "the holder {:.1f} + holder {:.1f}) puts {} at {:.1f} mm with the tip on the table, "
                                     "beyond its travel {:.1f} .. {:.1f} mm",
                                     origin.tool, m.source, gauge, tooling.stick_out_mm, tooling.chuck_length_mm,
                                     m.linear[k].name, q[k], m.linear[k].min_mm, m.linear[k].max_mm));
    return make_trunnion_model(m, scene, tooling);
  }
  root.at("kind").fail(fmt::format("'{}' is not a machine kind placement knows (hexapod, table_tilting)", kind.substr(0, 40)));
}

}  // namespace machplan::placement
