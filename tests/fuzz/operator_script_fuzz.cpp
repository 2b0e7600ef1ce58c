// Fuzz target: the scripted operator's CSV (engine/hardware/operator_input.h). Any input must
// end in a script or in machplan::InputError; anything else (another exception, a crash, a
// sanitizer report) is a bug. An accepted script has rows with finite values, rising times
// and speeds in range.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/hardware/operator_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto s = machplan::hardware::parse_operator_script(text, "fuzz.csv");
    if (s.rows.empty()) std::abort();
    for (std::size_t i = 0; i < s.rows.size(); ++i) {
      const auto& r = s.rows[i];
      if (!std::isfinite(r.t_s) || !std::isfinite(r.direction_deg) || !(r.speed_mm_per_s >= 0 && r.speed_mm_per_s <= 1e4)) std::abort();
      if (i > 0 && !(r.t_s > s.rows[i - 1].t_s)) std::abort();
      if (s.at(r.t_s) != &r) std::abort();
    }
  } catch (const machplan::InputError&) {
  }
  return 0;
}
