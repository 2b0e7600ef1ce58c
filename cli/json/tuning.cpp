#include "cli/json/tuning.h"

#include <cmath>

namespace machplan::cli {

nlohmann::json to_json(const tuning::Evaluation& e) {
  using namespace tuning;
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json cs = nlohmann::json::array();
  for (const ContourScore& c : e.contours)
    cs.push_back({{"contour", c.contour},
                  {"samples", c.samples},
                  {"max_contour_error_mm", c.max_mm},
                  {"max_at", {{"t_s", c.max_at_s}, {"x_mm", c.max_at_x_mm}, {"y_mm", c.max_at_y_mm}, {"line", c.max_at_line}}},
                  {"rms_contour_error_mm", c.rms_mm},
                  {"itae_mm_s2", c.itae_mm_s2},
                  {"saturation_share", c.saturation_share},
                  {"max_following_error_mm", c.max_following_error_mm},
                  {"faulted", c.faulted},
                  {"fault", c.fault}});
  return {{"max_contour_error_mm", e.max_mm},
          {"rms_contour_error_mm", e.rms_mm},
          {"itae_mm_s2", e.itae_mm_s2},
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
  return {{"evaluations", r.evaluations}, {"time_s", r.time_s}, {"feasible", r.feasible}, {"stopped", r.stopped},
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
          {"status", result.status}};
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
                      {"status", r.status}};
  if (r.fresh_seed > 0)
    j["fresh"] = {{"first_seed", r.fresh_seed}, {"baseline", to_json(r.fresh_baseline)}, {"tuned", to_json(r.fresh_tuned)}};
  return j;
}

}  // namespace machplan::cli
