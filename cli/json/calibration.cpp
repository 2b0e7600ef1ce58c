#include "cli/json/calibration.h"

namespace machplan::cli {

nlohmann::json to_json(const calibration::StoredFit& f) {
  const auto xy = [](const double (&v)[2]) { return nlohmann::json::array({v[0], v[1]}); };
  return {{"fit_id", f.fit_id},
          {"session_id", f.session_id},
          {"machine", f.machine},
          {"status", f.status},
          {"who", f.who},
          {"created_utc", f.created_utc},
          {"log_path", f.log_path},
          {"log_hash", f.log_hash},
          {"active", f.active},
          {"feed_factor", xy(f.feed_factor)},
          {"dead_band_mm_per_s", xy(f.dead_band_mm_per_s)},
          {"mm_per_count", xy(f.mm_per_count)},
          {"backlash_mm", xy(f.backlash_mm)},
          {"fit", nlohmann::json::parse(f.fit_json, nullptr, false)}};
}

}  // namespace machplan::cli
