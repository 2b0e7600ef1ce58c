#include "engine/programs/region_profile.h"

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

std::string handle_list(const std::vector<std::string>& handles) {
  constexpr std::size_t kShown = 4;
  std::string s;
  for (std::size_t i = 0; i < handles.size() && i < kShown; ++i) s += (i ? ", " : "") + handles[i];
  if (handles.size() > kShown) s += fmt::format(", ... {} more", handles.size() - kShown);
  return s;
}

}  // namespace

std::string describe_contour(const ProfileReadResult& profile, std::size_t k) {
  const auto& h = profile.contours.at(k).handles;
  if (h.empty()) return fmt::format("contour {}", k);
  return fmt::format("contour {} (entit{} {})", k, h.size() == 1 ? "y" : "ies", handle_list(h));
}

ProhibitedRegion build_region(const ProfileReadResult& profile, const RegionOptions& options) {
  for (const auto& p : profile.problems) {
    if (p.severity != ProfileProblem::Severity::error) continue;
    std::string where = p.handles.empty() ? "" : fmt::format(" (entities {})", handle_list(p.handles));
    if (p.at) where += fmt::format(" at ({:.4f}, {:.4f})", p.at->x(), p.at->y());
    throw InputError(profile.source, 0,
                     fmt::format("{}{}: {}; the profile cannot bound a prohibited region", p.kind, where, p.message));
  }
  std::vector<Contour> contours;
  std::vector<std::string> names;
  for (std::size_t k = 0; k < profile.contours.size(); ++k) {
    contours.push_back(profile.contours[k].contour);
    names.push_back(describe_contour(profile, k));
  }
  try {
    return ProhibitedRegion::build(contours, options, names);
  } catch (const InputError& e) {
    if (!e.where().empty()) throw;
    throw InputError(profile.source, 0, e.message());
  }
}

}  // namespace machplan
