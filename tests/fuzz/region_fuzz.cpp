// Fuzz target: prohibited regions (engine/geometry/region.h). The input bytes become up to
// three contours of up to 12 vertices each (coordinates on a 0.1 mm grid within +-3.2 m,
// bulges in [-1, 1]), a tool radius, a machining side and an offset method. Any input must
// end in a region or in machplan::InputError (an empty, flat, self-crossing or overlapping
// profile, a pocket with nothing left); anything else is a bug. For a built region, queries at
// points taken from the input must be finite with a unit normal and, with the robust method,
// agree with the definition: outside, prohibited exactly when the point is in the material or
// within R of it; inside, when it is outside the pockets or within R of their walls.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include "engine/common/error.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/region.h"
#include "tests/fuzz/fuzz_bytes.h"

using machplan::fuzz::Bytes;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using machplan::Contour;
  Bytes b{data, size};
  const int contours = 1 + b.u8() % 3;
  machplan::RegionOptions o;
  o.tool_radius_mm = b.u8() * 0.25;  // 0 .. 63.75 mm
  const uint8_t flags = b.u8();
  o.side = flags & 1 ? machplan::MachiningSide::inside : machplan::MachiningSide::outside;
  o.method = flags & 2 ? machplan::OffsetMethod::paper : machplan::OffsetMethod::robust;
  std::vector<Contour> profile;
  try {
    for (int k = 0; k < contours; ++k) {
      const int count = 1 + b.u8() % 12;
      std::vector<Eigen::Vector2d> v;
      std::vector<double> bulge;
      for (int i = 0; i < count; ++i) {
        v.emplace_back(b.i16() * 0.1, b.i16() * 0.1);
        bulge.push_back(o.method == machplan::OffsetMethod::paper && (flags & 4) ? 0.0
                                                                                 : (static_cast<int>(b.u8()) - 128) / 128.0);
      }
      profile.emplace_back(v, bulge);
    }
  } catch (const machplan::InputError&) {
    return 0;  // cannot happen on this grid, but a Contour may refuse input
  }
  machplan::ProhibitedRegion region;
  try {
    region = machplan::ProhibitedRegion::build(profile, o);
  } catch (const machplan::InputError&) {
    return 0;
  }
  for (int q = 0; q < 8 && b.n >= 4; ++q) {
    const Eigen::Vector2d p(b.i16() * 0.1, b.i16() * 0.1);
    const machplan::RegionDistance r = region.query(p);
    if (!std::isfinite(r.signed_distance_mm) || std::abs(r.normal.norm() - 1.0) > 1e-9) std::abort();
    if (o.method != machplan::OffsetMethod::robust) continue;
    int inside = 0;
    double dist = std::numeric_limits<double>::infinity();
    for (const auto& c : profile) {
      inside += machplan::contains(c, p);
      dist = std::min(dist, machplan::distance(c, p));
    }
    const bool material = inside % 2 == 1;
    const bool expected = o.side == machplan::MachiningSide::outside ? (material || dist < o.tool_radius_mm)
                                                                     : (!material || dist < o.tool_radius_mm);
    // Away from the limit by more than the tolerances (of the offset and of this check).
    if (std::abs(dist - o.tool_radius_mm) > 1e-4 && dist > 1e-4 && std::abs(r.signed_distance_mm) > 1e-4 &&
        (r.signed_distance_mm < 0) != expected)
      std::abort();
  }
  return 0;
}
