#include "engine/geometry/region.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/paper_offset.h"

namespace machplan {

using Eigen::Vector2d;

namespace {
constexpr Spelling kSideNames[] = {{"outside"}, {"inside"}};
constexpr Spelling kOffsetNames[] = {{"paper"}, {"robust"}};
}  // namespace

const char* to_string(MachiningSide s) { return kSideNames[static_cast<std::size_t>(s)].name.data(); }

Parsed<MachiningSide> parse_machining_side(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kSideNames, text, "side", "machining side");
  return {static_cast<MachiningSide>(p.value), p.note};
}

const char* to_string(OffsetMethod m) { return kOffsetNames[static_cast<std::size_t>(m)].name.data(); }

Parsed<OffsetMethod> parse_offset_method(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kOffsetNames, text, "method", "offset method");
  return {static_cast<OffsetMethod>(p.value), p.note};
}

void RegionOptions::validate() const {
  if (!std::isfinite(tool_radius_mm) || tool_radius_mm < 0.0 || tool_radius_mm > 1e6)
    throw InputError::field("tool_radius_mm", fmt::format("is {}, must be finite, >= 0 and <= 1e6 mm", tool_radius_mm));
  if (!std::isfinite(tolerance_mm) || !(tolerance_mm > 0.0) || tolerance_mm > 0.1)
    throw InputError::field("tolerance_mm", fmt::format("is {}, must be finite, > 0 and <= 0.1 mm", tolerance_mm));
  if (!std::isfinite(paper_chord_tolerance_mm) || !(paper_chord_tolerance_mm > 0.0) || paper_chord_tolerance_mm > 10.0)
    throw InputError::field("paper_chord_tolerance_mm",
                            fmt::format("is {}, must be finite, > 0 and <= 10 mm", paper_chord_tolerance_mm));
}

ProhibitedRegion ProhibitedRegion::build(const std::vector<Contour>& profile, const RegionOptions& options,
                                         const std::vector<std::string>& contour_names) {
  options.validate();
  if (!contour_names.empty() && contour_names.size() != profile.size())
    throw InputError("", 0,
                     fmt::format("prohibited region: {} contour names for {} contours", contour_names.size(),
                                 profile.size()));
  auto name = [&](std::size_t k) { return contour_names.empty() ? fmt::format("contour {}", k) : contour_names[k]; };
  if (profile.empty()) throw InputError("", 0, "prohibited region: the profile has no contours");
  const double tol = options.tolerance_mm;

  // 1. Each contour closed (a Contour always is), with area, not crossing itself.
  std::vector<Eigen::AlignedBox2d> boxes;
  std::vector<double> areas;
  for (std::size_t k = 0; k < profile.size(); ++k) {
    const Contour& c = profile[k];
    if (c.empty()) throw InputError("", 0, fmt::format("{}: the contour has no vertices", name(k)));
    if (const auto x = self_intersections(c, tol); !x.empty())
      throw InputError("", 0,
                       fmt::format("{}: the contour crosses itself at ({:.6f}, {:.6f}) mm, spans {} and {}", name(k),
                                   x.front().point.x(), x.front().point.y(), x.front().span_a, x.front().span_b));
    const double a = signed_area(c), per = perimeter(c);
    if (!(std::abs(a) > tol * per))
      throw InputError("", 0,
                       fmt::format("{}: the contour encloses no area ({:.6g} mm^2 for a perimeter of {:.6g} mm)",
                                   name(k), a, per));
    areas.push_back(a);
    boxes.push_back(bounding_box(c));
  }
  // Contours must not meet; nesting depth by containment among those whose boxes overlap.
  std::vector<int> depth(profile.size(), 0);
  {
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for_each_intersecting_pair(boxes, [&](std::size_t i, std::size_t j) { pairs.push_back({std::min(i, j), std::max(i, j)}); });
    std::sort(pairs.begin(), pairs.end());
    for (const auto& [i, j] : pairs) {
      if (const auto x = contour_intersections(profile[i], profile[j], tol); !x.empty())
        throw InputError("", 0,
                         fmt::format("{} and {}: the contours cross or touch at ({:.6f}, {:.6f}) mm", name(i), name(j),
                                     x.front().x(), x.front().y()));
      // Disjoint boundaries: one lies inside the other or neither does.
      if (boxes[j].contains(boxes[i]) && contains(profile[j], profile[i].vertices().front())) ++depth[i];
      if (boxes[i].contains(boxes[j]) && contains(profile[i], profile[j].vertices().front())) ++depth[j];
    }
  }

  // 2. Orientation (the positive region on the left: even depth counter-clockwise) and offset
  // to the right by R (outside: away from the material) or to the left (inside: into the pocket).
  ProhibitedRegion region;
  region.options_ = options;
  const double side = options.side == MachiningSide::outside ? 1.0 : -1.0;
  const double r = options.tool_radius_mm;
  std::vector<Contour> offsets;
  std::vector<std::size_t> source;  // profile contour of each offset contour
  for (std::size_t k = 0; k < profile.size(); ++k) {
    const bool want_ccw = depth[k] % 2 == 0;
    const Contour oriented = (areas[k] > 0) == want_ccw ? profile[k] : profile[k].reversed();
    if (options.method == OffsetMethod::robust) {
      // offset_contour's sign is for the region the contour encloses: growing the positive
      // region grows a ccw contour and shrinks a cw one.
      const OffsetResult o = offset_contour(oriented, side * (want_ccw ? r : -r), {tol});
      for (auto p : o.problems) {
        p.contour = k;
        p.message = fmt::format("{}: {}", name(k), p.message);
        region.problems_.push_back(std::move(p));
      }
      for (const auto& c : o.contours) {
        offsets.push_back(c);
        source.push_back(k);
      }
    } else {
      const PaperOffsetResult o = paper_offset(oriented, side * r, options.paper_chord_tolerance_mm, tol);
      for (const auto& d : o.dropped) {
        // Span numbers refer to the oriented copy; name the original span.
        const std::size_t n = profile[k].size();
        const std::size_t span = oriented.vertices() == profile[k].vertices() ? d.span : (n - d.span) % n;
        OffsetProblem p;
        p.kind = OffsetProblem::Kind::vertex_dropped;
        p.span = span;
        p.span_count = 1;
        p.contour = k;
        p.message = fmt::format(
            "{}: vertex near ({:.4f}, {:.4f}) dropped (paper offset): the corner setback R tan(phi/2) = {:.4g} mm "
            "exceeds the neighbouring segment of {:.4g} mm",
            name(k), d.at.x(), d.at.y(), d.setback_mm, d.segment_mm);
        region.problems_.push_back(std::move(p));
      }
      if (o.vanished()) {
        OffsetProblem p;
        p.kind = OffsetProblem::Kind::contour_vanished;
        p.contour = k;
        p.message = fmt::format("{}: nothing is left of the contour after dropping its very close points", name(k));
        region.problems_.push_back(std::move(p));
        continue;
      }
      offsets.emplace_back(o.vertices, std::vector<double>(o.vertices.size(), 0.0));
      source.push_back(k);
    }
  }

  // 3. One clean boundary.
  const MergeResult merged = merge_positive(offsets, {tol});
  for (const auto& x : merged.crossings) {
    const std::size_t a = source[x.contour_a], b = source[x.contour_b];
    OffsetProblem p;
    p.kind = OffsetProblem::Kind::gap_too_narrow;
    p.contour = a;
    p.span_count = 0;
    p.message = a == b ? fmt::format("{}: its offset crosses itself near ({:.4f}, {:.4f}): a feature narrower than "
                                     "2R = {:.6g} mm is lost",
                                     name(a), x.at.x(), x.at.y(), 2 * r)
                       : fmt::format("{} and {}: closer than 2R = {:.6g} mm near ({:.4f}, {:.4f}); the tool cannot "
                                     "pass between them",
                                     name(a), name(b), 2 * r, x.at.x(), x.at.y());
    region.problems_.push_back(std::move(p));
  }
  region.boundary_ = merged.contours;
  if (region.boundary_.empty())
    throw InputError("", 0,
                     fmt::format("prohibited region: nothing is left for the tool: with a tool radius of {:.6g} mm "
                                 "the {} is narrower than {:.6g} mm everywhere",
                                 r, options.side == MachiningSide::inside ? "pocket" : "profile", 2 * r));
  region.index_ = SpanIndex(region.boundary_);
  return region;
}

RegionDistance ProhibitedRegion::query(const Vector2d& p) const noexcept {
  RegionDistance out;
  if (index_.empty()) {
    out.signed_distance_mm = std::numeric_limits<double>::infinity();
    return out;
  }
  const SpanIndex::Nearest n = index_.nearest(p);
  const SpanIndex::Item& it = index_.item(n.item);
  const bool prohibited_left = options_.side == MachiningSide::outside;
  out.nearest_mm = n.point;
  out.contour = it.contour;
  out.span = it.span;
  if (n.distance > 0.0) {
    const bool bad = index_.left_of(p, n) == prohibited_left;
    out.signed_distance_mm = bad ? -n.distance : n.distance;
    out.normal = (p - n.point) / n.distance;
    if (bad) out.normal = -out.normal;
  } else {
    Vector2d t = it.is_arc() ? Vector2d(it.sweep > 0 ? Vector2d(-(n.point - it.center).y(), (n.point - it.center).x())
                                                      : Vector2d((n.point - it.center).y(), -(n.point - it.center).x()))
                             : Vector2d(it.b - it.a);
    if (n.at_start) t = it.t_start;
    if (n.at_end) t = it.t_end;
    const double tn = t.norm();
    const Vector2d left = tn > 0 ? Vector2d(Vector2d(-t.y(), t.x()) / tn) : Vector2d(0, 1);
    out.signed_distance_mm = 0.0;
    out.normal = prohibited_left ? Vector2d(-left) : left;
  }
  return out;
}

bool ProhibitedRegion::prohibited(const Vector2d& p) const noexcept { return query(p).signed_distance_mm < 0.0; }

}  // namespace machplan
