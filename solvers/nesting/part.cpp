#include "solvers/nesting/part.h"

#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::nesting {

std::vector<NestPart> nest_parts(const ProfileReadResult& profile, bool split) {
  for (const ProfileProblem& p : profile.problems)
    if (p.severity == ProfileProblem::Severity::error)
      throw InputError(profile.source, 0, fmt::format("the drawing is not a part: {}", p.text()));
  std::vector<NestPart> parts;
  for (const ProfileContour& c : profile.contours) {
    if (c.depth % 2 != 0) continue;  // a hole: taken with its part
    NestPart p;
    p.file = profile.source;
    p.index = static_cast<int>(parts.size());
    p.outer = orientation(c.contour) == Orientation::cw ? c.contour.reversed() : c.contour;
    p.area_mm2 = std::abs(c.area_mm2);
    for (int h : c.children) {
      const Contour& hole = profile.contours[static_cast<std::size_t>(h)].contour;
      p.holes.push_back(orientation(hole) == Orientation::ccw ? hole.reversed() : hole);
      p.area_mm2 -= std::abs(profile.contours[static_cast<std::size_t>(h)].area_mm2);
    }
    parts.push_back(std::move(p));
  }
  if (parts.empty()) throw InputError(profile.source, 0, "the drawing holds no closed contour: no part to nest");
  if (parts.size() > 1 && !split)
    throw InputError(profile.source, 0,
                     fmt::format("the drawing holds {} outer contours: one part per drawing, or split it into its parts "
                                 "(split: true)",
                                 parts.size()));
  return parts;
}

std::vector<NestPart> read_nest_parts(const std::string& path, bool split, const DxfOptions& options) {
  return nest_parts(read_dxf_profile(path, options), split);
}

}  // namespace machplan::nesting
