// Declared no-go zones: regions the torch-off moves (rapids) must keep away from, such as
// clamps or a weight lying on the sheet. Read from a small YAML file:
//
//   no_go:
//     - name: clamp left
//       polygon: [[-50, -20], [50, -20], [50, 20], [-50, 20]]
//     - name: magnet
//       polygon: [[400, 0], [420, 0], [420, 30]]
//
// Coordinates are mm in the job's (program's) frame. Each polygon is a closed ring of at least
// three [x, y] points, the last joined back to the first (do not repeat the first point); it
// must enclose a positive area and must not cross itself. Either orientation is accepted. A
// zone is the filled polygon; how far the tool keeps from it is the rapid planner's
// clearance, not part of the file. `no_go: []` declares no zone.
//
// Refused with "FILE:LINE: what" (InputError), naming the key: a missing or unknown key, a
// name that is empty or used twice, a point that is not two finite numbers or whose
// coordinate exceeds kMaxCoordinateMm, fewer than 3 points or more than kMaxZonePoints,
// repeated consecutive points, a polygon of zero area, a polygon that crosses itself (the
// first crossing point is named).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "engine/config/yaml.h"
#include "engine/geometry/contour.h"

namespace machplan {

// Largest number of points in one polygon (the self-crossing check is quadratic).
inline constexpr std::size_t kMaxZonePoints = 4096;

struct NoGoZone {
  std::string name;
  Contour contour;  // the polygon, bulges all 0, as written (not reoriented)
  int line = 0;     // 1-based line of the zone in its file, for messages
};

// Reads the `no_go` list of a parsed YAML document (see the file comment).
std::vector<NoGoZone> zones_from_yaml(const Yaml& root);

// Loads and reads a zones file.
std::vector<NoGoZone> load_zones(const std::string& path);

// The contours alone, in file order.
std::vector<Contour> zone_contours(const std::vector<NoGoZone>& zones);

}  // namespace machplan
