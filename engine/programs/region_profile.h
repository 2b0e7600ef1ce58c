// The prohibited region of a profile read from a DXF file: the reader's errors refused with the
// entities named, the contours named by their entities in the region's messages. It joins the
// DXF reader (engine/programs/dxf.h) to the region (engine/geometry/region.h), so it lives
// with the readers: geometry knows nothing of files.
#pragma once

#include <cstddef>
#include <string>

#include "engine/geometry/region.h"
#include "engine/programs/dxf.h"

namespace machplan {

// The region of a profile read from a DXF file: refuses a profile with errors (open chain,
// self-intersection, overlap...) with InputError("FILE", 0, "<kind> (entities H1, H2) at
// (x, y): <message>"), then builds with every contour named "contour K (entities H1, H2, ...)"
// in messages. DXF warnings are not repeated here; the caller prints profile.report() if it
// wants them.
ProhibitedRegion build_region(const ProfileReadResult& profile, const RegionOptions& options);

// "contour K (entities H1, H2, H3, ... N more)": how messages name a DXF contour.
std::string describe_contour(const ProfileReadResult& profile, std::size_t k);

}  // namespace machplan
