#include "cli/json/cut_order_json.h"

namespace machplan::cli {

nlohmann::json cut_order_json(const motion::CutOrderReport& r) {
  nlohmann::json lines = nlohmann::json::array();
  for (int k : r.sequence) lines.push_back(r.cut_lines[static_cast<std::size_t>(k)]);
  nlohmann::json j = {{"order", motion::to_string(r.order)},
                      {"reordered", r.reordered},
                      {"status", to_string(r.summary.status)},
                      {"cuts", r.cuts},
                      {"closed_cuts", r.closed_cuts},
                      {"with_lead_in", r.with_lead_in},
                      {"moved_pierces", r.moved_pierces},
                      {"sequence_lines", lines},
                      {"programmed_travel_mm", r.programmed_travel_mm},
                      {"nearest_travel_mm", r.nearest_travel_mm},
                      {"travel_mm", r.travel_mm},
                      {"lower_bound_mm", r.lower_bound_mm},
                      {"warnings", r.warnings}};
  j["outer_first"] = r.outer_first ? nlohmann::json{{"outer_line", r.outer_first->first}, {"inner_line", r.outer_first->second}}
                                   : nlohmann::json(nullptr);
  return j;
}

}  // namespace machplan::cli
