#include "cli/json/guard.h"

namespace machplan::cli {

nlohmann::json to_json(const guard::GuardRunResult& r) {
  using namespace guard;
  nlohmann::json j;
  j["profile"] = r.profile_source;
  j["machine"] = r.machine;
  j["side"] = to_string(r.options.region.side);
  j["tool_radius_mm"] = r.options.region.tool_radius_mm;
  j["offset_method"] = to_string(r.options.region.method);
  j["strategy"] = executor::to_string(r.options.guard.strategy);
  j["tolerance_mm"] = r.options.guard.tolerance_mm;
  j["latency_s"] = r.options.guard.latency_s;
  j["feed_mm_per_s"] = r.options.feed_mm_per_s;
  j["operator"] = to_string(r.options.op.kind);
  j["seed"] = r.options.seed;
  j["attempts"] = r.attempts.size();
  j["strokes"] = r.strokes;
  j["successes"] = r.successes;
  j["invasions"] = r.invasions;
  j["success_percent"] = r.success_percent();
  j["max_invasion_mm"] = r.max_invasion_mm;
  j["mean_undercut_mm"] = r.mean_undercut_mm;
  j["max_undercut_mm"] = r.max_undercut_mm;
  j["time_s"] = r.roughing_time_s + r.finishing_time_s;
  j["roughing_time_s"] = r.roughing_time_s;
  j["finishing_time_s"] = r.finishing_time_s;
  j["guard_failsafe_ticks"] = r.guard_failsafe_ticks;
  j["guard_emergency_ticks"] = r.guard_emergency_ticks;
  j["warnings"] = r.warnings;
  nlohmann::json per = nlohmann::json::array();
  for (const Attempt& a : r.attempts)
    per.push_back({{"attempt", a.index + 1},
                   {"start_mm", {a.start_mm.x(), a.start_mm.y()}},
                   {"aim_mm", {a.aim_mm.x(), a.aim_mm.y()}},
                   {"closest_at_mm", {a.closest_at_mm.x(), a.closest_at_mm.y()}},
                   {"speed_mm_per_s", a.speed_mm_per_s},
                   {"closest_mm", a.closest_mm},
                   {"success", a.success},
                   {"invasion_mm", a.invasion_mm},
                   {"undercut_mm", a.undercut_mm},
                   {"time_s", a.time_s}});
  j["per_attempt"] = per;
  nlohmann::json fin = nlohmann::json::array();
  for (const FinishPass& f : r.finish)
    fin.push_back({{"allowance_mm", f.allowance_mm},
                   {"completed", f.completed},
                   {"fault", f.fault},
                   {"time_s", f.time_s},
                   {"max_deviation_mm", f.max_deviation_mm},
                   {"rms_deviation_mm", f.rms_deviation_mm},
                   {"samples", f.samples}});
  j["finish"] = fin;
  return j;
}

}  // namespace machplan::cli
