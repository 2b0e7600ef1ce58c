// Fuzz target: QtPlasmaC material files (engine/motion/materials.h). The first byte chooses the
// units (mm or inch); the rest is the file, also read as a material comment. Any input must end
// in a table or in machplan::InputError; anything else (another exception, a crash, a sanitizer
// report) is a bug. Accepted materials must be in range: finite, non-negative heights, a
// positive finite cut feed.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/motion/materials.h"

namespace {

void check(const machplan::motion::CutParameters& c) {
  const bool ok = std::isfinite(c.pierce_height_mm) && c.pierce_height_mm >= 0 && std::isfinite(c.cut_height_mm) &&
                  c.cut_height_mm >= 0 && std::isfinite(c.cut_feed_mm_per_s) && c.cut_feed_mm_per_s > 0 &&
                  std::isfinite(c.kerf_mm) && c.kerf_mm >= 0 && c.pierce_delay_s >= 0 && c.pierce_delay_s <= 60;
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0 || size > 64 * 1024) return 0;
  machplan::motion::MaterialReadOptions o;
  o.mm_per_unit = data[0] % 2 ? 25.4 : 1.0;
  o.max_materials = 200;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    const auto t = machplan::motion::read_materials(text, "fuzz.cfg", o);
    if (t.lines.size() != t.materials.size()) std::abort();
    for (const auto& c : t.materials) check(c);
  } catch (const machplan::InputError&) {
  }
  try {
    check(machplan::motion::read_material_comment(text, "fuzz.ngc", 1, o.mm_per_unit).material);
  } catch (const machplan::InputError&) {
  }
  return 0;
}
