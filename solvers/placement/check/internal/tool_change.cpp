#include "solvers/placement/check/internal/tool_change.h"

#include <algorithm>

namespace machplan::placement {

namespace {

double gauge_mm(const Tooling& t) { return t.stick_out_mm + t.chuck_length_mm; }

// The pose drawn back along its axis until the spindle nose reaches the height `nose_z` (its
// rotary angles kept), or the pose itself when it is there already.
PathPose drawn_back(const MachineModel& model, const PathPose& pose, const Where& w, double gauge, double nose_z) {
  const MachineModel::NoseHeight h = model.nose_height(pose, w, gauge);
  const double rise = nose_z - h.height_mm;
  if (rise <= 0.0) return pose;
  PathPose p = pose;
  p.tip += std::min(rise / std::max(h.rise_per_mm, 0.2), kMaxRetractMm) * pose.axis;
  return p;
}

// The change position for a tool of `gauge`, in the workpiece frame, the rotary axes at zero
// (the table's C is where the placement's rotation puts it on a rotary table).
PathPose at_change(const Scene& scene, const Where& w, double gauge) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  PathPose p{w.R.transpose() * (scene.tool_change->nose_mm - gauge * up - w.offset), w.R.transpose() * up};
  p.c_rad = scene.machine.kind == "table_tilting" ? w.rotation_rad : 0.0;
  return p;
}

void append(std::vector<PathPose>& to, const std::vector<PathPose>& more) {
  for (const PathPose& p : more)
    if (to.empty() || !(to.back().tip.isApprox(p.tip, 1e-12) && to.back().axis.isApprox(p.axis, 1e-12))) to.push_back(p);
}
}  // namespace

ChangeMoves change_moves(const Scene& scene, std::size_t k, const Where& where, const PathPose& last,
                         const PathPose& first) {
  const ToolChange& c = *scene.tool_change;
  const SceneTool& from = scene.tools[scene.runs[k - 1].tool];
  const SceneTool& to = scene.tools[scene.runs[k].tool];
  const double g_old = gauge_mm(from.tooling), g_new = gauge_mm(to.tooling);
  ChangeMoves m;
  const PathPose up_old = drawn_back(*from.model, last, where, g_old, c.nose_mm.z());
  append(m.out, {last, up_old});
  append(m.out, from.model->axis_move(up_old, at_change(scene, where, g_old), where, g_old));
  const PathPose up_new = drawn_back(*to.model, first, where, g_new, c.nose_mm.z());
  append(m.in, to.model->axis_move(at_change(scene, where, g_new), up_new, where, g_new));
  append(m.in, {up_new, first});
  return m;
}

}  // namespace machplan::placement
