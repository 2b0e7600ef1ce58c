#include "engine/programs/zones.h"

#include <cmath>
#include <set>

#include <fmt/format.h>

namespace machplan {

std::vector<NoGoZone> zones_from_yaml(const Yaml& root) {
  root.reject_unknown_keys({"no_go"});
  const Yaml list = root.at("no_go");
  std::vector<NoGoZone> out;
  std::set<std::string> names;
  for (const Yaml& item : list.items()) {
    item.reject_unknown_keys({"name", "polygon"});
    NoGoZone zone;
    zone.line = item.line();
    const Yaml name = item.at("name");
    zone.name = name.string();
    if (zone.name.empty()) name.fail("must not be empty");
    if (!names.insert(zone.name).second) name.fail("'" + excerpt(zone.name) + "' names another zone already");

    const Yaml poly = item.at("polygon");
    const std::vector<Yaml> points = poly.items();
    if (points.size() < 3) poly.fail(fmt::format("must hold at least 3 points, got {}", points.size()));
    if (points.size() > kMaxZonePoints) poly.fail(fmt::format("holds {} points, more than {}", points.size(), kMaxZonePoints));
    std::vector<Eigen::Vector2d> vertices;
    for (const Yaml& p : points) {
      const std::vector<double> xy = p.numbers(2, {.min = -kMaxCoordinateMm, .max = kMaxCoordinateMm});
      const Eigen::Vector2d v(xy[0], xy[1]);
      if (!vertices.empty() && v == vertices.back())
        p.fail(fmt::format("repeats the previous point ({}, {})", v.x(), v.y()));
      vertices.push_back(v);
    }
    if (vertices.back() == vertices.front())
      points.back().fail("repeats the first point; the polygon closes by itself, leave it out");
    const std::size_t n = vertices.size();
    zone.contour = Contour(std::move(vertices), std::vector<double>(n, 0.0));
    const auto crossings = self_intersections(zone.contour);
    if (!crossings.empty())
      poly.fail(fmt::format("of zone '{}' crosses itself at ({:.6g}, {:.6g}) (edges {} and {})", excerpt(zone.name),
                            crossings.front().point.x(), crossings.front().point.y(), crossings.front().span_a,
                            crossings.front().span_b));
    const double area = std::abs(signed_area(zone.contour));
    const Eigen::AlignedBox2d box = bounding_box(zone.contour);
    // Zero area relative to the polygon's size (a flat polygon's shoelace sum is rounding).
    if (!(area > 1e-9 * std::max(1.0, box.sizes().squaredNorm())))
      poly.fail(fmt::format("of zone '{}' encloses no area", excerpt(zone.name)));
    out.push_back(std::move(zone));
  }
  return out;
}

std::vector<NoGoZone> load_zones(const std::string& path) { return zones_from_yaml(Yaml::load_file(path)); }

std::vector<Contour> zone_contours(const std::vector<NoGoZone>& zones) {
  std::vector<Contour> out;
  out.reserve(zones.size());
  for (const NoGoZone& z : zones) out.push_back(z.contour);
  return out;
}

}  // namespace machplan
