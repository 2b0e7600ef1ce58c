// The machine's axes along a whole job, each run of moves with the model of the tool that makes
// it (machines/machine_model.h AxisPath), for the travel and time objectives and the reports.
#pragma once

#include <optional>

#include "solvers/placement/machines/machine_model.h"
#include "solvers/placement/scene/scene.h"

namespace machplan::placement {

// The axes along the whole job at a rotation, the runs joined in path order; nullopt when the
// machine gives no axis path or refuses a pose.
std::optional<AxisPath> job_axis_path(const Scene& scene, double rotation_rad);

}  // namespace machplan::placement
