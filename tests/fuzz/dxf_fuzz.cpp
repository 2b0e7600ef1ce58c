// Fuzz target for the DXF profile reader: any input must give a result or InputError.
// Anything else (a crash, a sanitizer report, another exception, a hang) is a bug.
//
// The reader's work is bounded by its limits, and at the defaults (250 000 entities, 250 000
// fitted arcs: about a second each to reach) the inputs that reach one, which the fuzzer
// finds at once (an ellipse of 1e9 mm, an INSERT array of 500 x 500), take nearly all of its
// time. Small limits take the same paths, a thousand times sooner.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/common/error.h"
#include "engine/programs/dxf.h"

namespace {

machplan::DxfOptions fuzz_options() {
  machplan::DxfOptions o;
  o.max_entities = 2000;
  o.max_fitted_spans = 2000;
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const machplan::DxfOptions options = fuzz_options();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto result = machplan::read_dxf_profile_text(text, "fuzz.dxf", options);
    (void)result.report();
  } catch (const machplan::InputError&) {
    // Clean rejection of a malformed file.
  }
  return 0;
}
