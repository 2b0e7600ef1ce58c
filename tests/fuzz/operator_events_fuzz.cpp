// Fuzz target: the operator-events timeline (engine/hardware/operator_events.h). Any input must
// end in a timeline or in machplan::InputError; anything else (another exception, a crash, a
// sanitizer report) is a bug. An accepted timeline has rows in time order with values in
// range, and states in time order that release every button.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/hardware/operator_events.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  using K = machplan::hardware::OperatorEventRow::Kind;
  try {
    const auto tl = machplan::hardware::parse_operator_events(text, "fuzz.csv");
    for (std::size_t i = 0; i < tl.rows.size(); ++i) {
      const auto& r = tl.rows[i];
      if (!std::isfinite(r.t_s) || r.t_s < 0 || (i > 0 && r.t_s < tl.rows[i - 1].t_s)) std::abort();
      if (r.kind == K::feed_override && !(r.value >= 0 && r.value <= 200)) std::abort();
      if (r.kind == K::rapid_override && !(r.value >= 1 && r.value <= 100)) std::abort();
    }
    for (std::size_t i = 1; i < tl.states.size(); ++i)
      if (!(tl.states[i].at_s > tl.states[i - 1].at_s)) std::abort();
    if (!tl.states.empty()) {
      const auto& last = tl.states.back().inputs;
      if (last.feed_hold || last.cycle_start || last.stop) std::abort();  // every press is released
    }
  } catch (const machplan::InputError&) {
  }
  return 0;
}
