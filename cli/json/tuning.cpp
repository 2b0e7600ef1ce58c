#include "cli/json/tuning.h"

#include <cmath>

namespace machplan::cli {

nlohmann::json to_json(const tuning::Evaluation& e) {
  // A faulted run's errors are not measurements: null.
  auto measured = [](bool faulted, double v) { return faulted ? nlohmann::json(nullptr) : nlohmann::json(v); };
  using namespace tuning;
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json cs = nlohmann::json::array();
  for (const ContourScore& c : e.contours)
    cs.push_back({{"contour", c.contour},
                  {"samples", c.samples},
                  {"max_contour_error_mm", measured(c.faulted || c.samples == 0, c.max_mm)},
                  {"max_at", {{"t_s", c.max_at_s}, {"x_mm", c.max_at_x_mm}, {"y_mm", c.max_at_y_mm}, {"line", c.max_at_line}}},
                  {"rms_contour_error_mm", measured(c.faulted || c.samples == 0, c.rms_mm)},
                  {"itae_mm_s2", measured(c.faulted || c.samples == 0, c.itae_mm_s2)},
                  {"saturation_share", c.saturation_share},
                  {"max_following_error_mm", c.max_following_error_mm},
                  {"faulted", c.faulted},
                  {"fault", c.fault}});
  return {{"max_contour_error_mm", measured(e.faulted, e.max_mm)},
          {"rms_contour_error_mm", measured(e.faulted, e.rms_mm)},
          {"itae_mm_s2", measured(e.faulted, e.itae_mm_s2)},
          {"saturation_share", e.saturation_share},
          {"max_following_error_mm", e.max_following_error_mm},
          {"step_overshoot", num(e.overshoot)},
          {"margin_residual", num(e.margin_residual)},
          {"faulted", e.faulted},
          {"contours", cs}};
}

nlohmann::json to_json(const tuning::OptimizerResult& r) {
  auto stage = [](const tuning::StageReport& s) {
    return nlohmann::json{{"algorithm", s.algorithm}, {"evaluations", s.evaluations}, {"time_s", s.time_s},
                          {"stop_reason", s.stop_reason}};
  };
  return {{"evaluations", r.evaluations}, {"time_s", r.time_s}, {"feasible", r.feasible}, {"stopped", r.stopped()},
          {"objective", r.objective},     {"global", stage(r.global)}, {"local", stage(r.local)}};
}

nlohmann::json to_json(const tuning::AccTuningResult& result) {
  auto score = [](const tuning::AccScore& a) {
    nlohmann::json steps = nlohmann::json::array();
    for (const auto& r : a.steps)
      steps.push_back({{"settling_s", std::isfinite(r.settling_s) ? nlohmann::json(r.settling_s) : nlohmann::json(nullptr)},
                       {"overshoot", r.overshoot}});
    return nlohmann::json{{"worst_settling_s", a.worst_settling_s}, {"worst_overshoot", a.worst_overshoot}, {"steps", steps}};
  };
  return {{"law", result.variable_gain ? "variable_gain" : "fixed_gain"},
          {"gain_name", result.variable_gain ? "open_loop_gain" : "kc"},
          {"start_gain", result.start_gain},
          {"gain", result.gain},
          {"before", score(result.before)},
          {"after", score(result.after)},
          {"optimizer", to_json(result.optimizer)},
          {"status", to_string(result.summary.status)},
          {"usable", result.summary.usable_answer()}};
}

nlohmann::json to_json(const tuning::Comparison& c) {
  nlohmann::json j = {{"contours", c.contours}, {"baseline_faulted", c.faulted}};
  if (c.any() && c.tuned_max_mm > 0) {
    j["baseline_max_contour_error_mm"] = c.baseline_max_mm;
    j["tuned_max_contour_error_mm"] = c.tuned_max_mm;
    j["max_ratio"] = c.max_ratio();
    j["rms_ratio"] = c.rms_ratio();
  }
  return j;
}

nlohmann::json to_json(const tuning::TuneResult& r) {
  nlohmann::json g = nlohmann::json::object(), sg = nlohmann::json::object(), fx = nlohmann::json::array();
  for (const auto& [k, v] : r.gains) g[k] = v;
  for (const auto& [k, v] : r.fixed) fx.push_back(k);
  for (const auto& [k, v] : r.start_gains) sg[k] = v;
  nlohmann::json j = {{"machine", r.machine},
                      {"controller", r.kind},
                      {"objective", to_string(r.objective)},
                      {"gains", g},
                      {"start_gains", sg},
                      {"fixed", fx},
                      {"start_from", r.start_from},
                      {"baseline", to_json(r.baseline)},
                      {"start", to_json(r.start)},
                      {"tuned", to_json(r.tuned)},
                      {"optimizer", to_json(r.optimizer)},
                      {"status", to_string(r.summary.status)},
                      {"usable", r.summary.usable_answer()},
                      {"message", r.summary.message}};
  j["improvement"] = to_json(r.improvement);
  if (r.fresh_seed > 0)
    j["fresh"] = {{"first_seed", r.fresh_seed},
                  {"baseline", to_json(r.fresh_baseline)},
                  {"tuned", to_json(r.fresh_tuned)},
                  {"improvement", to_json(r.fresh_improvement)}};
  return j;
}

nlohmann::json to_json(const tuning::AccStudy& study) {
  const auto settled = [&](const std::vector<turning::AccSample>& run) {
    nlohmann::json a = nlohmann::json::array();
    for (const tuning::AccSettled& s : study.settled(run))
      a.push_back({{"t_s", s.t_s}, {"depth_mm", s.depth_mm}, {"feed_mm_per_rev", s.feed_mm_per_rev}, {"force_n", s.force_n}});
    return a;
  };
  nlohmann::json j;
  j["koren_fixed_kc_0_5"] = {{"settled", settled(study.koren)}};
  nlohmann::json t = nlohmann::json::array();
  for (std::size_t i = 0; i < study.tunings.size(); ++i) {
    nlohmann::json r = to_json(study.tunings[i]);
    r["settled"] = settled(study.tuned_runs[i]);
    t.push_back(r);
  }
  j["tunings"] = t;
  j["status"] = to_string(study.summary.status);
  return j;
}

}  // namespace machplan::cli
