// Fuzz target: declared no-go zones (YAML through engine/config/yaml.h, then the polygon
// checks of engine/programs/zones.h). Any input must end in a list of zones or in
// machplan::InputError; anything else (another exception, a crash, a sanitizer report) is a
// bug. Accepted zones must be valid figures: finite non-zero area.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "engine/programs/zones.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto zones = machplan::zones_from_yaml(machplan::Yaml::load_string(text, "fuzz.yaml"));
    for (const auto& z : zones) {
      const double area = machplan::signed_area(z.contour);
      if (!std::isfinite(area) || area == 0.0 || z.contour.size() < 3) std::abort();
    }
  } catch (const machplan::InputError&) {
  }
  return 0;
}
