#include "solvers/nesting/certificate.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/offset.h"
#include "solvers/nesting/outline.h"

namespace machplan::nesting {

namespace {

constexpr double kTolMm = 1e-6;

// One placed copy: its contours on the sheet and its material grown by spacing / 2.
struct Placed {
  Contour outer;
  std::vector<Contour> holes;
  Contour grown;                           // the outer grown (its outer boundary)
  std::vector<std::vector<Contour>> roomy;  // each hole shrunk: where a grown neighbour may lie
  Eigen::AlignedBox2d box;                 // of `grown`
  std::string name;
};

Placed place_copy(const NestPart& part, const Placement& p, double half) {
  Placed c;
  c.outer = place(part.outer, p);
  for (const Contour& h : part.holes) c.holes.push_back(place(h, p));
  c.grown = grown_outline(c.outer, half);
  for (const Contour& h : c.holes) c.roomy.push_back(half > 0 ? offset_contour(h, -half).contours : std::vector<Contour>{h});
  c.box = bounding_box(c.grown);
  c.name = fmt::format("{} copy {}", part.file, p.copy + 1);
  return c;
}

// `b` (grown) keeps the spacing from `a`: outside a's grown outline, or inside one of a's holes
// shrunk. The reason when it does not.
std::optional<std::string> too_close(const Placed& a, const Placed& b) {
  if (const auto meet = contour_intersections(a.grown, b.grown, kTolMm); !meet.empty())
    return fmt::format("{} and {} are closer than the spacing near ({:.3f}, {:.3f})", a.name, b.name, meet.front().x(),
                       meet.front().y());
  const Eigen::Vector2d probe = b.grown.vertices().front();
  if (!contains(a.grown, probe)) {
    if (contains(b.grown, a.grown.vertices().front())) return too_close(b, a);  // a inside b
    return std::nullopt;                                                        // apart
  }
  for (const std::vector<Contour>& room : a.roomy)
    for (const Contour& r : room)
      if (contains(r, probe)) {
        if (const auto meet = contour_intersections(r, b.grown, kTolMm); !meet.empty())
          return fmt::format("{} lies in a hole of {} closer than the spacing to its edge near ({:.3f}, {:.3f})", b.name,
                             a.name, meet.front().x(), meet.front().y());
        return std::nullopt;
      }
  return fmt::format("{} overlaps {} (or lies in a hole too small for it with the spacing)", b.name, a.name);
}

// Why copy `c` on remnant sheet `k` is off its usable region, if it is.
std::optional<std::string> off_remnant(const Placed& c, const RemnantRoom& room, int k) {
  const Eigen::Vector2d probe = c.outer.vertices().front();
  const auto in = std::find_if(room.inside.begin(), room.inside.end(), [&](const Contour& r) { return contains(r, probe); });
  if (in == room.inside.end() || !contour_intersections(*in, c.outer, kTolMm).empty())
    return fmt::format("{} on sheet {} (a remnant) reaches past its outline less the margin near ({:.3f}, {:.3f})", c.name, k + 1,
                       probe.x(), probe.y());
  for (const Contour& cut : room.cutouts) {
    const Eigen::Vector2d at = cut.vertices().front();
    bool clear = contour_intersections(cut, c.outer, kTolMm).empty() && !contains(cut, probe);
    if (clear && contains(c.outer, at))  // inside the part: only in one of its holes
      clear = std::any_of(c.holes.begin(), c.holes.end(),
                          [&](const Contour& h) { return contains(h, at) && contour_intersections(h, cut, kTolMm).empty(); });
    if (!clear)
      return fmt::format("{} on sheet {} (a remnant) comes nearer than the margin to its cut-out near ({:.3f}, {:.3f})", c.name,
                         k + 1, at.x(), at.y());
  }
  return std::nullopt;
}

}  // namespace

RemnantRoom remnant_room(const Sheet& s) {
  RemnantRoom r;
  if (!s.remnant) return r;
  r.inside = offset_contour(s.remnant->outer, -s.margin_mm).contours;  // a margin of 0: the outline itself
  for (const Contour& h : s.remnant->holes)
    for (Contour& c : offset_contour(h.reversed(), s.margin_mm).contours) r.cutouts.push_back(std::move(c));
  return r;
}

Certificate certify(const std::vector<NestPart>& parts, const std::vector<Placement>& placements, const std::vector<Sheet>& sheets,
                    double spacing_mm) {
  if (!(spacing_mm >= 0 && std::isfinite(spacing_mm)))
    throw InputError::field("spacing_mm", fmt::format("{} must be a distance >= 0", spacing_mm));
  Certificate out;
  std::vector<std::optional<RemnantRoom>> rooms(sheets.size());
  std::vector<Placed> placed;
  placed.reserve(placements.size());
  for (const Placement& p : placements) {
    if (p.part >= parts.size() || p.sheet < 0 || static_cast<std::size_t>(p.sheet) >= sheets.size())
      throw InputError::field("placements", fmt::format("part {} on sheet {}: no such part or sheet", p.part, p.sheet));
    placed.push_back(place_copy(parts[p.part], p, spacing_mm / 2));
    const Sheet& s = sheets[static_cast<std::size_t>(p.sheet)];
    const Eigen::AlignedBox2d usable(Eigen::Vector2d::Constant(s.margin_mm),
                                     Eigen::Vector2d(s.width_mm - s.margin_mm, s.height_mm - s.margin_mm));
    const Eigen::AlignedBox2d b = bounding_box(placed.back().outer);
    if (!(b.min().x() >= usable.min().x() - kTolMm && b.min().y() >= usable.min().y() - kTolMm &&
          b.max().x() <= usable.max().x() + kTolMm && b.max().y() <= usable.max().y() + kTolMm))
      out.violations.push_back(fmt::format("{} on sheet {} reaches past its usable area ({:.3f} .. {:.3f} x {:.3f} .. {:.3f} mm): "
                                           "the part spans {:.3f} .. {:.3f} x {:.3f} .. {:.3f} mm",
                                           placed.back().name, p.sheet + 1, usable.min().x(), usable.max().x(),
                                           usable.min().y(), usable.max().y(), b.min().x(), b.max().x(), b.min().y(),
                                           b.max().y()));
    auto& room = rooms[static_cast<std::size_t>(p.sheet)];
    if (s.remnant && !room) room = remnant_room(s);
    if (room)
      if (auto why = off_remnant(placed.back(), *room, p.sheet)) out.violations.push_back(*why);
  }
  // Pairs: boxes on different sheets are moved apart so that they never meet.
  std::vector<Eigen::AlignedBox2d> boxes;
  double far = 0.0;
  for (const Sheet& s : sheets) far = std::max({far, s.width_mm, s.height_mm});
  far = 4 * far + 4 * spacing_mm + 1.0;
  for (std::size_t i = 0; i < placed.size(); ++i)
    boxes.push_back(placed[i].box.translated(Eigen::Vector2d(far * placements[i].sheet, 0.0)));
  for_each_intersecting_pair(boxes, [&](std::size_t i, std::size_t j) {
    if (auto why = too_close(placed[std::min(i, j)], placed[std::max(i, j)])) out.violations.push_back(*why);
  });
  out.certified = out.violations.empty();
  return out;
}

}  // namespace machplan::nesting
