// Fuzz target: contour offsets (engine/geometry/offset.h), the geometry behind kerf
// compensation and tool-radius regions. The input bytes become a contour of up to 24 vertices
// (coordinates on a 0.1 mm grid within +-3.2 m, bulges in [-1, 1]) and an offset distance.
// Any input must end in an OffsetResult or in machplan::InputError (an empty, flat or
// self-crossing contour); anything else is a bug. Every vertex of an offset contour must lie
// at the offset distance from the input contour, and be finite.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "engine/common/error.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/offset.h"
#include "tests/fuzz/fuzz_bytes.h"

using machplan::fuzz::Bytes;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Bytes b{data, size};
  const int count = 1 + b.u8() % 24;
  const double d = (static_cast<int>(b.u8()) - 128) * 0.25;  // -32 .. +31.75 mm
  std::vector<Eigen::Vector2d> v;
  std::vector<double> bulge;
  for (int k = 0; k < count; ++k) {
    v.emplace_back(b.i16() * 0.1, b.i16() * 0.1);
    bulge.push_back((static_cast<int>(b.u8()) - 128) / 128.0);
  }
  try {
    const machplan::Contour c(v, bulge);
    const machplan::OffsetResult r = machplan::offset_contour(c, d);
    for (const machplan::Contour& o : r.contours) {
      for (std::size_t k = 0; k < o.size(); ++k) {
        const Eigen::Vector2d& p = o.vertices()[k];
        if (!p.allFinite()) std::abort();
        const double e = std::abs(machplan::distance(c, p) - std::abs(d));
        if (e > 1e-4 * (1.0 + std::abs(d))) std::abort();
      }
    }
  } catch (const machplan::InputError&) {
  }
  return 0;
}
