// Fuzz target for the DXF profile reader: any input must give a result or InputError.
// Anything else (a crash, a sanitizer report, another exception, a hang) is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/common/error.h"
#include "engine/programs/dxf.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto result = machplan::read_dxf_profile_text(text, "fuzz.dxf");
    (void)result.report();
  } catch (const machplan::InputError&) {
    // Clean rejection of a malformed file.
  }
  return 0;
}
