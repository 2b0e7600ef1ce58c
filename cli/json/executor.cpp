#include "cli/json/executor.h"

#include <cmath>

namespace machplan::cli {

namespace {

nlohmann::json num(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }

// The holds, the cut recoveries among them, and the paused motions.
void add_holds(nlohmann::json& j, const executor::ExecutionResult& r) {
  using nlohmann::json;
  using namespace executor;
  j["holds"] = json::array();
  for (const executor::HoldReport& h : r.holds)
    j["holds"].push_back({{"t_s", h.t_s},
                          {"source_line", h.source_line},
                          {"in_cut", h.in_cut},
                          {"torch_off", h.torch_off},
                          {"in_rapid", h.in_rapid},
                          {"by_override", h.by_override},
                          {"by_arc_loss", h.by_arc_loss},
                          {"by_torch_disable", h.by_torch_disable},
                          {"recovered_mm", h.recovered_mm},
                          {"position_mm", {h.position_mm.x(), h.position_mm.y()}},
                          {"speed_mm_per_s", h.speed_mm_per_s},
                          {"stopped", h.stopped},
                          {"stop_s", h.stop_s},
                          {"stop_mm", {h.stop_mm.x(), h.stop_mm.y()}},
                          {"distance_to_stop_mm", h.distance_to_stop_mm},
                          {"jerk_limited_stop_mm", h.jerk_limited_stop_mm()},
                          {"tangential_acceleration_mm_per_s2", h.acceleration_mm_per_s2},
                          {"stop_limits", {{"acceleration_mm_per_s2", h.stop_acceleration_mm_per_s2},
                                           {"jerk_mm_per_s3", h.stop_jerk_mm_per_s3}}},
                          {"off_path_mm", h.off_path_mm},
                          {"off_path_measured_mm", h.off_path_measured_mm},
                          {"torch_off_before_rest", h.torch_off_before_rest},
                          {"resumed_at_s", num(h.resumed_at_s)},
                          {"repierce_s", h.repierce_s}});
  if (r.holds_dropped) j["holds_dropped"] = r.holds_dropped;
  // Cut recoveries: the holds a lost arc made, or in which the operator moved along the path.
  j["recoveries"] = json::array();
  for (const executor::HoldReport& h : r.holds)
    if (h.by_arc_loss || h.recovered_mm != 0.0)
      j["recoveries"].push_back({{"t_s", h.t_s},
                                 {"source_line", h.source_line},
                                 {"arc_lost", h.by_arc_loss},
                                 {"at_mm", {h.position_mm.x(), h.position_mm.y()}},
                                 {"stopped_after_mm", h.distance_to_stop_mm},
                                 {"moved_along_path_mm", h.recovered_mm},
                                 {"resumed_at_s", num(h.resumed_at_s)},
                                 {"repierce_s", h.repierce_s}});
  // Paused motions: each move along the path while held, with the distance moved.
  j["paused_motions"] = json::array();
  for (const executor::PausedMotionReport& p : r.paused_motions)
    j["paused_motions"].push_back({{"t_s", p.t_s},
                                   {"end_s", p.end_s},
                                   {"from_line", p.from_line},
                                   {"to_line", p.to_line},
                                   {"from_mm", {p.from_mm.x(), p.from_mm.y()}},
                                   {"to_mm", {p.to_mm.x(), p.to_mm.y()}},
                                   {"moved_mm", p.moved_mm},
                                   {"by_arc_loss", p.by_arc_loss}});
  j["paused_motions_dropped"] = r.paused_motions_dropped;
}

}  // namespace

nlohmann::json to_json(const executor::ExecutionResult& r, bool include_trace) {
  using nlohmann::json;
  using namespace executor;
  json j;
  j["source"] = r.source;
  j["machine"] = r.machine;
  j["mode"] = to_string(r.mode);
  j["backend"] = r.backend;
  j["status"] = to_string(r.summary.status);
  j["cycle_time_s"] = r.cycle_time_s;
  j["torch_on_s"] = r.torch_on_s;
  j["ramp_pierces"] = r.ramp_pierces;
  j["dry_pierces"] = r.dry_pierces;
  j["rapid_distance_mm"] = r.rapid_distance_mm;
  j["cut_distance_mm"] = r.cut_distance_mm;
  j["steps_completed"] = r.steps_completed;
  j["stopped_at_rest"] = r.stopped_at_rest;
  j["torch_off_at_end"] = r.torch_off_at_end;
  j["backend_notes"] = r.backend_notes;
  j["truth_available"] = r.truth_available;
  j["cuts"] = json::array();
  for (const CutError& c : r.cuts) {
    json cut = {{"stretch", c.stretch},
                {"source_line", c.source_line},
                {"samples", c.samples},
                {"complete", c.complete},
                {"max_contour_error_mm", c.max_mm},
                {"rms_contour_error_mm", c.rms_mm},
                {"max_true_contour_error_mm", num(c.max_true_mm)},
                {"rms_true_contour_error_mm", num(c.rms_true_mm)}};
    // The torch height while THC held it (null: no height axis, or THC never took hold).
    cut["thc"] = c.thc.samples == 0 ? json(nullptr)
                                    : json{{"samples", c.thc.samples},
                                           {"max_height_error_mm", num(c.thc.max_mm)},
                                           {"rms_height_error_mm", num(c.thc.rms_mm)},
                                           {"active_share", c.thc.active_share},
                                           {"target_v", c.thc.target_v},
                                           {"velocity_lock_height_change_mm", c.thc.velocity_lock_change_mm},
                                           {"void_lock_height_change_mm", c.thc.void_lock_change_mm},
                                           {"velocity_locked_s", c.thc.velocity_locked_s},
                                           {"void_locked_s", c.thc.void_locked_s}};
    j["cuts"].push_back(cut);
  }
  j["faults"] = json::array();
  for (const FaultReport& f : r.faults)
    j["faults"].push_back({{"kind", to_string(f.kind)},
                           {"time_s", f.time_s},
                           {"step", f.step},
                           {"source_line", f.source_line},
                           {"axis", f.axis < 0 ? json(nullptr) : json(f.axis == 0 ? "x" : f.axis == 1 ? "y" : "z")},
                           {"last_known_mm", {f.last_known_mm.x(), f.last_known_mm.y()}},
                           {"commanded_mm", {f.commanded_mm.x(), f.commanded_mm.y()}},
                           {"value", f.value},
                           {"message", f.message}});
  j["probes"] = json::array();
  for (const ProbeReport& p : r.probes)
    j["probes"].push_back({{"t_s", p.t_s},
                           {"source_line", p.source_line},
                           {"position_mm", {p.position_mm.x(), p.position_mm.y()}},
                           {"sensor", p.skipped ? json(nullptr) : json(p.sensor)},
                           {"skipped", p.skipped},
                           {"surface_mm", p.surface_mm},
                           {"duration_s", p.duration_s},
                           {"pierce_height_error_mm", num(p.pierce_height_error_mm)}});
  j["probes_dropped"] = r.probes_dropped;
  add_holds(j, r);
  if (include_trace) {
    json t = json::array();
    for (const TraceSample& s : r.trace)
      t.push_back({s.t_s, s.step, s.commanded_mm.x(), s.commanded_mm.y(), s.measured_mm.x(), s.measured_mm.y(),
                   num(s.true_mm.x()), num(s.true_mm.y()), s.dac_x, s.dac_y, s.drives_enabled, s.torch_fire, s.arc_ok});
    j["trace_columns"] = {"t_s",       "step",      "cmd_x_mm", "cmd_y_mm", "meas_x_mm", "meas_y_mm", "true_x_mm",
                          "true_y_mm", "dac_x",     "dac_y",    "enabled",  "torch_fire", "arc_ok"};
    j["trace"] = std::move(t);
  }
  return j;
}

}  // namespace machplan::cli
