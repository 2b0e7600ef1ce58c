#include "cli/json/placement_json.h"

#include <cmath>

namespace machplan::cli {

using namespace machplan::placement;

namespace {
// JSON has no infinity: a clearance nothing bounds is written as a large number.
double finite_or(double v, double big = 1e9) { return std::isfinite(v) ? v : big; }

nlohmann::json travel_json(const AxisTravel& t) {
  nlohmann::json axes;
  for (std::size_t k = 0; k < t.axes.size(); ++k) axes[t.axes[k] + (static_cast<int>(k) < t.linear_axes ? "_mm" : "_deg")] = t.travel[k];
  return {{"axes", axes},
          {"linear_mm", t.linear_mm},
          {"time_s", t.time_s},
          {"timed_by", t.planned ? "feed planner" : "speed limits"},
          {"velocity_only_time_s", t.velocity_only_time_s},
          {"flips", t.flips},
          {"forced_flips", t.forced_flips},
          {"flip_pose_indices", t.flip_poses}};
}
}  // namespace

nlohmann::json finding_json(const Finding& f) {
  nlohmann::json j{{"interferes", f.interferes}, {"clearance_mm", finite_or(f.clearance_mm)}, {"where", f.what}};
  if (f.pose >= 0) j["pose_index"] = f.pose, j["interval_fraction"] = f.t;
  if (f.line > 0) j["line"] = f.line;
  return j;
}

// Per tool of the job: its tightest clearance, of which kind, where.
nlohmann::json tools_json(const CheckReport& r) {
  nlohmann::json tools = nlohmann::json::array();
  for (const ToolClearance& t : r.tools)
    tools.push_back({{"tool", t.tool}, {"poses", t.poses}, {"kind", kind_name(t.kind)}, {"tightest", finding_json(t.tightest)}});
  return tools;
}

nlohmann::json check_report_json(const CheckReport& r) {
  nlohmann::json kinds, clear;
  for (int k = 0; k < kKindCount; ++k) {
    kinds[kind_name(static_cast<Kind>(k))] = finding_json(r.kinds[k]);
    clear[kind_name(static_cast<Kind>(k))] = finite_or(r.kinds[k].clearance_mm);
  }
  return {{"placement",
           {{"x_mm", r.placement.x_mm}, {"y_mm", r.placement.y_mm}, {"pad_mm", r.placement.pad_mm},
            {"rotation_deg", r.placement.rotation_deg}}},
          {"free", r.free()},
          {"min_clearance_mm", clear},
          {"interference", kinds},
          {"stroke_margin_mm", finite_or(r.stroke_margin_mm)},
          {"joint_margin_deg", finite_or(r.joint_margin_deg)},
          {"tools", tools_json(r)}};
}

nlohmann::json counts_json(const CheckCounts& c, std::size_t poses) {
  return {{"tool_poses", poses},
          {"stretches", c.stretches},
          {"exact_pose_queries", c.exact_queries},
          {"interpolated_poses", c.interpolated_poses},
          {"stretches_proven_by_bound", c.proven_by_bound}};
}

nlohmann::json summary_json(const Summary& s) {
  return {{"status", to_string(s.status)}, {"message", s.message}, {"brief", s.brief}};
}

nlohmann::json scene_json(const Scene& s) {
  const Eigen::Vector3d& o = s.origin_in_cam_mm;
  nlohmann::json j{{"machine", {{"name", s.machine.name}, {"kind", s.machine.kind}, {"file", s.machine.source}}},
                   {"workpiece_frame",
                    {{"origin_in_cam_mm", {o.x(), o.y(), o.z()}}, {"from_mesh", s.origin_from_mesh},
                     {"moved_by_mm", {-o.x(), -o.y(), -o.z()}}}},
                   {"spoilboard_mm", s.spoilboard_mm},
                   {"below_bottom", {{"poses", s.below_bottom.poses}, {"deepest_mm", s.below_bottom.deepest_mm}}}};
  if (s.below_bottom.deepest_pose >= 0)
    j["below_bottom"]["pose_index"] = s.below_bottom.deepest_pose, j["below_bottom"]["line"] = s.below_bottom.deepest_line;
  j["tools"] = nlohmann::json::array();
  for (const SceneTool& t : s.tools) {
    const Tooling& g = t.tooling;
    nlohmann::json tj = {{"name", t.name}, {"diameter_mm", g.tool_diameter_mm}, {"corner_radius_mm", g.corner_radius_mm},
                         {"flute_length_mm", g.flute_length_mm}, {"stick_out_mm", g.stick_out_mm},
                         {"holder_diameter_mm", g.chuck_diameter_mm}, {"holder_length_mm", g.chuck_length_mm},
                         {"line", t.line}};
    tj["number"] = t.number >= 0 ? nlohmann::json(t.number) : nlohmann::json(nullptr);
    j["tools"].push_back(tj);
  }
  j["tool_changes"] = nlohmann::json::array();
  for (std::size_t k = 1; k < s.runs.size(); ++k)
    j["tool_changes"].push_back({{"to", s.tools[s.runs[k].tool].name}, {"pose_index", s.runs[k].first},
                                 {"line", s.lines[s.runs[k].first]}});
  j["warnings"] = s.warnings;
  return j;
}

nlohmann::json placement_result_json(const Scene& scene, const PlacementResult& r, const std::string& strategy) {
  nlohmann::json j = check_report_json(r.report);
  j["message"] = r.summary.message;
  j["summary"] = summary_json(r.summary);
  j["strategy"] = strategy;
  j["objective"] = to_string(r.objective);
  j["verified"] = r.verified;
  j["scene"] = scene_json(scene);
  j["rotations_searched"] = r.rotations;
  j["rotation_tolerance_deg"] = r.rotation_tolerance_deg;
  j["threads"] = r.threads;
  if (r.summary.done()) {
    const WorkOffset& w = r.work_offset;
    j["work_offset"] = {{"x_mm", w.xyz_mm.x()}, {"y_mm", w.xyz_mm.y()}, {"z_mm", w.xyz_mm.z()},
                        {"rotation_deg", w.rotation_deg}, {"rotation_axis", w.rotation_axis}, {"frame", w.frame}};
    if (r.objective != PlacementOptions::Objective::lowest) j["objective_value"] = r.objective_value;
  }
  if (r.travel) {
    j["axis_travel"] = travel_json(*r.travel);
    j["time_s"] = r.travel->time_s;
  }
  if (r.centre_travel) {
    j["table_centre_travel"] = travel_json(*r.centre_travel);
    j["centre_time_s"] = r.centre_travel->time_s;
    j["linear_travel_saving_percent"] = 100.0 * (1.0 - r.travel->linear_mm / r.centre_travel->linear_mm);
    j["machining_time_saving_percent"] = 100.0 * (1.0 - r.travel->time_s / r.centre_travel->time_s);
  }
  j["checks"] = counts_json(r.counts, scene.tips_mm.size());
  j["checks"]["placements_examined"] = r.placements_examined;
  j["checks"]["certifications"] = r.certifications;
  j["seconds"] = r.seconds;
  if (!r.trail.empty()) {
    nlohmann::json t = nlohmann::json::array();
    for (const auto& p : r.trail) t.push_back({p.x_mm, p.y_mm, p.pad_mm});
    j["trail"] = t;
  }
  return j;
}

nlohmann::json check_result_json(const Scene& scene, const CheckResult& r) {
  nlohmann::json j = check_report_json(r.report);
  j["on_table"] = r.report.on_table;
  j["summary"] = summary_json(r.summary);
  j["scene"] = scene_json(scene);
  j["checks"] = counts_json(r.counts, r.poses);
  j["method"] = r.dense ? "dense" : "certified";
  return j;
}

}  // namespace machplan::cli
