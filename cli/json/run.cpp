#include "cli/json/run.h"

#include <cmath>
#include <vector>

#include "cli/json/executor.h"

namespace machplan::cli {

nlohmann::json to_json(const motion::RunOutcome& run) {
  using namespace motion;
  nlohmann::json j = to_json(run.result, false);
  const double mt = run.result.max_true_contour_error_mm();
  j["controller"] = run.controller;
  j["summary"] = {{"status", to_string(run.summary.status)}, {"message", run.summary.message}, {"brief", run.summary.brief}};
  // No cut sample (a run that faulted before its first cut, a program without cuts): no figure
  // that could read as a measured zero. A run that faulted later gives the figures of what ran
  // up to the fault, beside its faulted status.
  std::size_t cut_samples = 0;
  for (const executor::CutError& c : run.result.cuts) cut_samples += c.samples;
  const auto measured = [&](double v) { return cut_samples == 0 ? nlohmann::json(nullptr) : nlohmann::json(v); };
  j["max_contour_error_mm"] = measured(run.result.max_contour_error_mm());
  j["rms_contour_error_mm"] = measured(run.rms_contour_error_mm);
  j["max_true_contour_error_mm"] = std::isnan(mt) ? nlohmann::json(nullptr) : nlohmann::json(mt);
  j["rms_true_contour_error_mm"] = std::isnan(run.rms_true_contour_error_mm) ? nlohmann::json(nullptr)
                                                                            : nlohmann::json(run.rms_true_contour_error_mm);
  j["lower_bound_s"] = run.lower_bound_s;
  j["motion_lower_bound_s"] = run.motion_lower_bound_s;
  j["process_time_s"] = run.process_time_s;
  j["planned_motion_s"] = run.planned_motion_s;
  j["cycle_ratio"] = run.cycle_ratio;
  j["motion_ratio"] = run.motion_ratio;
  j["motion_optimum_s"] = run.motion_optimum_s;
  j["optimum_ratio"] = run.optimum_ratio;
  j["origin_mm"] = {run.origin_mm.x(), run.origin_mm.y()};
  j["origin_from"] = run.origin_from;
  j["rotation_deg"] = run.rotation_deg;
  j["warnings"] = run.warnings;
  j["notes"] = run.notes;
  j["rapids"] = {{"count", run.rapids.rapids.size()},
                 {"re_routed", run.rapids.replaced},
                 {"blocked_straight", run.rapids.blocked},
                 {"without_clear_route", run.rapids.failed},
                 {"zones_from_cuts", run.rapids.cut_zones},
                 {"declared_zones", run.declared_zones.size()},
                 {"straight_length_mm", run.rapids.straight_length_mm},
                 {"programmed_length_mm", run.rapids.programmed_length_mm},
                 {"planned_length_mm", run.rapids.length_mm},
                 {"small_slugs_crossed", run.rapids.small_slugs},
                 {"detour_extra_mm", run.rapids.detour_extra_mm}};
  nlohmann::json detours = nlohmann::json::array();
  for (const RapidReport& r : run.rapids.rapids)
    if (!r.reason.empty())
      detours.push_back({{"source_line", r.source_line}, {"extra_length_mm", r.extra_length_mm}, {"reason", r.reason}});
  j["rapids"]["detours"] = detours;
  // The materials the cuts used (QtPlasmaC's material file or the program's material comments)
  // and, per cut, the index of its material in that list (null: the machine's torch settings).
  nlohmann::json materials = nlohmann::json::array();
  for (const CutParameters& c : run.job.materials)
    materials.push_back({{"number", c.number},
                         {"name", c.name},
                         {"cut_feed_mm_per_min", c.cut_feed_mm_per_s * 60.0},
                         {"pierce_height_mm", c.pierce_height_mm},
                         {"pierce_delay_s", c.pierce_delay_s},
                         {"cut_height_mm", c.cut_height_mm},
                         {"kerf_mm", c.kerf_mm},
                         {"thc", c.thc},
                         {"puddle_jump_height_pct", c.puddle_jump_height_pct},
                         {"puddle_jump_delay_s", c.puddle_jump_delay_s},
                         {"cut_amps", c.cut_amps},
                         {"cut_volts", c.cut_volts},
                         {"pause_at_end_s", c.pause_at_end_s}});
  j["materials"] = materials;
  std::vector<int> material_of(run.job.stretches.size(), -1);
  int lit = -1;
  for (const Step& st : run.job.steps) {
    if (st.kind == Step::Kind::torch_on) lit = st.material;
    if (st.kind == Step::Kind::move && st.stretch < material_of.size()) material_of[st.stretch] = lit;
  }
  for (auto& c : j["cuts"]) {
    const std::size_t k = c["stretch"].get<std::size_t>();
    const int m = k < material_of.size() ? material_of[k] : -1;
    c["material"] = m >= 0 ? nlohmann::json(m) : nlohmann::json(nullptr);
  }
  if (run.kerf) {
    nlohmann::json issues = nlohmann::json::array();
    for (const KerfIssue& i : run.kerf->issues)
      issues.push_back({{"kind", to_string(i.kind)}, {"source_line", i.source_line}, {"message", i.message}});
    j["kerf"] = {{"width_mm", run.kerf->kerf_width_mm},
                 {"from_materials", run.kerf->kerf_from_materials},
                 {"loops", run.kerf->loops.size()},
                 {"compensated", run.kerf->compensated_count()},
                 {"issues", issues}};
  }
  return j;
}

nlohmann::json frame_json(const motion::FramePlan& f) {
  const Eigen::AlignedBox2d& b = f.outline;
  return {{"x_mm", {b.min().x(), b.max().x()}},
          {"y_mm", {b.min().y(), b.max().y()}},
          {"from_cuts", f.from_cuts},
          {"feed_mm_per_s", f.options.feed_mm_per_s},
          {"margin_mm", f.options.margin_mm},
          {"pointer_offset_mm", {f.options.pointer_offset_mm.x(), f.options.pointer_offset_mm.y()}}};
}

}  // namespace machplan::cli
