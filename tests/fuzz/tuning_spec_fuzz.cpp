// Fuzz target: the command-line specs of `machplan tune` and `run --gain`: a test contour
// (solvers/tuning/evaluate.h, parse_contour) on the first line, a gain NAME=VALUE
// (engine/control/controller_factory.h, parse_gain) on the second. Each must end in a value or
// in machplan::InputError naming its flag; anything else (another exception, a crash, a
// sanitizer report) is a bug. An accepted contour has a feed and a size in their ranges; an
// accepted gain a finite value.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "engine/control/controller_factory.h"
#include "solvers/tuning/evaluate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 4096) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto nl = text.find('\n');
  const std::string contour = text.substr(0, nl), gain = nl == std::string::npos ? "" : text.substr(nl + 1);
  using machplan::tuning::TestContour;
  try {
    const TestContour c = machplan::tuning::parse_contour(contour);
    if (c.spec != contour) std::abort();
    if (c.kind == TestContour::Kind::program) {
      if (c.path.empty()) std::abort();
    } else {
      if (!(c.feed_mm_per_min > 0 && c.feed_mm_per_min <= 600000)) std::abort();
      if (!std::isfinite(c.angle_deg) || !(c.radius_mm >= 0.5 && c.radius_mm <= 10000)) std::abort();
      if (c.kind == TestContour::Kind::square && !(c.length_mm >= 0.5 && c.length_mm <= 10000)) std::abort();
    }
  } catch (const machplan::InputError& e) {
    if (e.where() != "contours") std::abort();
  }
  try {
    machplan::control::Gains g;
    machplan::control::parse_gain(gain, g, "fixed");
    if (g.size() != 1 || !std::isfinite(g.begin()->second) || g.begin()->first.empty()) std::abort();
  } catch (const machplan::InputError& e) {
    if (e.where() != "fixed") std::abort();
  }
  return 0;
}
