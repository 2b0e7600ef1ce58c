// Fuzz target for the STL reader: bytes from memory go through machplan's own reader (structure
// check, corners, weld). Bad input must come back as InputError; a crash, a leak or a
// sanitizer report is a finding.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/common/error.h"
#include "engine/programs/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  machplan::StlReadOptions options;
  options.max_triangles = 200000;
  try {
    machplan::MeshReport report;
    const machplan::Mesh mesh = machplan::read_stl_bytes(bytes, "fuzz.stl", &report, options);
    if (report.triangles != mesh.triangles.size() || report.vertices != mesh.vertices.size()) __builtin_trap();
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k)
        if (t[k] < 0 || static_cast<std::size_t>(t[k]) >= mesh.vertices.size()) __builtin_trap();
  } catch (const machplan::InputError&) {
  }
  return 0;
}
