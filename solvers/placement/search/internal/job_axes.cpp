#include "solvers/placement/search/internal/job_axes.h"

#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "engine/common/internal/numbers.h"
#include "solvers/placement/search/internal/objective.h"
#include "solvers/placement/search/internal/planned_time.h"
#include "solvers/placement/search/search.h"

namespace machplan::placement {

std::optional<AxisPath> job_axis_path(const Scene& scene, double rotation_rad) {
  // The rotary angles depend on the tool axis alone: taken along the whole path at once, so that
  // a tool change does not restart the table's turns.
  std::vector<PathPose> all(scene.tips_mm.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = {scene.tips_mm[i], scene.axes[i]};
  if (scene.model->prepare(all)) return std::nullopt;
  std::optional<AxisPath> job;
  for (const ToolRun& run : scene.runs) {
    const MachineModel& model = *scene.tools[run.tool].model;
    const std::vector<PathPose> poses(all.begin() + run.first, all.begin() + run.end);
    const std::vector<double> feeds(scene.feeds_mm_per_min.begin() + run.first, scene.feeds_mm_per_min.begin() + run.end);
    std::optional<AxisPath> part = model.axis_path(poses, feeds, rotation_rad);
    if (!part) return std::nullopt;
    if (!job) {
      job = std::move(part);
      continue;
    }
    const long offset = static_cast<long>(job->feed_mm_per_s.size());
    job->M.insert(job->M.end(), part->M.begin(), part->M.end());
    job->joints_mm.insert(job->joints_mm.end(), part->joints_mm.begin(), part->joints_mm.end());
    if (part->on_rails()) {
      const Eigen::Vector3d& a = scene.axes[run.first - 1], &b = scene.axes[run.first];
      part->turn_rad.front() = std::atan2(a.cross(b).norm(), a.dot(b));
    }
    job->turn_rad.insert(job->turn_rad.end(), part->turn_rad.begin(), part->turn_rad.end());
    job->b.insert(job->b.end(), part->b.begin(), part->b.end());
    job->rotary_rad.insert(job->rotary_rad.end(), part->rotary_rad.begin(), part->rotary_rad.end());
    job->feed_mm_per_s.insert(job->feed_mm_per_s.end(), part->feed_mm_per_s.begin(), part->feed_mm_per_s.end());
    part->tip_step_mm.front() = (scene.tips_mm[run.first] - scene.tips_mm[run.first - 1]).norm();
    job->tip_step_mm.insert(job->tip_step_mm.end(), part->tip_step_mm.begin(), part->tip_step_mm.end());
    job->flips += part->flips;
    job->forced_flips += part->forced_flips;
    for (long f : part->flip_poses) job->flip_poses.push_back(f + offset);
  }
  return job;
}

std::vector<AxisTravel> axis_travel(const Scene& scene, double rotation_deg, const std::vector<Eigen::Vector3d>& offsets) {
  std::optional<AxisPath> path = job_axis_path(scene, rotation_deg * kDeg);
  // A hexapod's sliders are reported with their limits only (their time is the planner's).
  if (!path || (path->on_rails() && !path->limits)) return {};
  AxisTravel base;
  base.axes = path->names;
  base.flips = path->flips;
  base.forced_flips = path->forced_flips;
  base.flip_poses = path->flip_poses;
  std::optional<AxisObjective> f;  // an affine path's travel and velocity-only time
  if (!path->on_rails()) f.emplace(*path, AxisObjective::Kind::travel);
  std::optional<PlannedTime> planner;
  if (path->limits) planner.emplace(std::move(*path));
  std::vector<AxisTravel> out;
  for (const Eigen::Vector3d& o : offsets) {
    AxisTravel t = base;
    if (f) {
      t.travel = f->travel_per_axis(o);
      t.linear_mm = t.travel[0] + t.travel[1] + t.travel[2];
      t.velocity_only_time_s = t.time_s = f->time_s(o);
    } else {
      // A hexapod's sliders, pose by pose.
      t.linear_axes = static_cast<int>(t.axes.size());
      t.travel.assign(t.axes.size(), 0.0);
      motion::JointVector q = planner->position(0, o);
      for (std::size_t i = 1; i < planner->poses(); ++i) {
        const motion::JointVector next = planner->position(i, o);
        for (std::size_t k = 0; k < t.travel.size(); ++k) t.travel[k] += std::abs(next[k] - q[k]);
        q = next;
      }
      for (double v : t.travel) t.linear_mm += v;
    }
    if (planner) {
      const motion::JointPlan plan = planner->plan(o);
      t.time_s = plan.duration_s();
      if (!f) t.velocity_only_time_s = plan.velocity_only_s();
      t.planned = true;
    }
    out.push_back(std::move(t));
  }
  return out;
}

std::optional<AxisTravel> axis_travel(const Scene& scene, const Placement& p) {
  std::vector<AxisTravel> t = axis_travel(scene, p.rotation_deg, {p.offset()});
  if (t.empty()) return std::nullopt;
  return std::move(t.front());
}

}  // namespace machplan::placement
