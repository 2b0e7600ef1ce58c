// Fuzz target: the simulator's sheet height map (models/sim/sheet_map.h). Any input must end in
// a map or in machplan::InputError; anything else (another exception, a crash, a sanitizer
// report) is a bug. An accepted map is a grid of at least 2 x 2 ascending values whose surface
// lies within its limit everywhere.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "models/sim/sheet_map.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const machplan::sim::SheetMap m = machplan::sim::parse_sheet_map(text, "fuzz.csv");
    if (m.xs().size() < 2 || m.ys().size() < 2) std::abort();
    for (std::size_t i = 1; i < m.xs().size(); ++i)
      if (!(m.xs()[i] > m.xs()[i - 1])) std::abort();
    for (double x : {m.xs().front() - 1, m.xs().back(), 0.5 * (m.xs().front() + m.xs().back())})
      for (double y : {m.ys().front(), m.ys().back() + 1, 0.5 * (m.ys().front() + m.ys().back())})
        if (!(std::abs(m.z_mm(x, y)) <= machplan::sim::kSheetMapMaxZ)) std::abort();
  } catch (const machplan::InputError&) {
  }
  return 0;
}
