#include "cli/json/stats.h"

namespace machplan::cli {

nlohmann::json to_json(const stats::Figures& f) {
  return {{"jobs", f.jobs},         {"pierces", f.pierces}, {"arc_on_s", f.arc_on_s},
          {"cycle_s", f.cycle_s},   {"cut_mm", f.cut_mm},     {"rapid_mm", f.rapid_mm}, {"probes", f.probes},
          {"probes_skipped", f.probes_skipped}, {"probe_s", f.probe_s}, {"faults", f.faults}};
}

nlohmann::json to_json(const stats::JobRecord& job) {
  return {{"id", job.id},
          {"machine", job.machine},
          {"program", job.program},
          {"program_hash", job.program_hash},
          {"started_utc", job.started_utc},
          {"status", job.status},
          {"fault", job.fault},
          {"figures", to_json(job.figures)}};
}

nlohmann::json to_json(const stats::MachineTotals& t) {
  nlohmann::json change = nullptr;
  if (t.last_change_utc) change = {{"utc", *t.last_change_utc}, {"who", t.last_change_who.value_or("")}};
  return {{"machine", t.machine},
          {"lifetime", to_json(t.lifetime)},
          {"since_change", to_json(t.since_change)},
          {"last_change", change}};
}

}  // namespace machplan::cli
