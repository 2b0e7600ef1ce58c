// The DXF profile reader: its public functions, and the three stages run one after another
// (engine/programs/internal/dxf_stages.h lists them and their files).
#include "engine/programs/dxf.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/programs/internal/dxf_stages.h"

namespace machplan {
namespace dxf {

std::string fmt_pt(const Eigen::Vector2d& p) { return fmt::format("({:.4f}, {:.4f})", p.x(), p.y()); }

std::size_t Drawing::new_instance(const Entity& e, std::string handle, std::string layer) {
  if (instances_.size() >= options_.max_entities)
    throw InputError(source_, e.line,
                     fmt::format("the drawing holds more than {} entities (INSERT copies counted); the limit "
                                 "bounds the time and memory a read takes, about 1 s per 100 000: raise it",
                                 options_.max_entities))
        .with_option("max_entities");
  instances_.push_back({&e, std::move(handle), std::move(layer)});
  return instances_.size() - 1;
}

std::string Drawing::where(std::size_t k) const {
  const auto& in = instances_[k];
  return fmt::format("{} {} (layer {}, line {})", excerpt(in.entity->type), excerpt(in.handle), excerpt(in.layer),
                     in.entity->line);
}

void Drawing::problem(ProfileProblem::Severity s, std::string kind, const std::vector<std::size_t>& insts,
                      std::string message, std::optional<Eigen::Vector2d> at, std::string option) {
  ProfileProblem p{s, std::move(kind), {}, std::move(message), at, std::nullopt, std::move(option)};
  for (auto e : insts) p.handles.push_back(label(e));
  out_.problems.push_back(std::move(p));
}

}  // namespace dxf

void DxfOptions::validate() const {
  if (!std::isfinite(chain_tolerance_mm) || !(chain_tolerance_mm > 0.0) || chain_tolerance_mm > 10.0)
    throw InputError::field("chain_tolerance_mm", fmt::format("is {}, must be finite, > 0 and <= 10 mm", chain_tolerance_mm));
  if (!std::isfinite(join_tolerance_mm) || join_tolerance_mm < 0.0 || join_tolerance_mm > 10.0)
    throw InputError::field("join_tolerance_mm", fmt::format("is {}, must be finite, >= 0 and <= 10 mm", join_tolerance_mm));
  if (!std::isfinite(assumed_mm_per_unit) || assumed_mm_per_unit < 0.0 || assumed_mm_per_unit > 1e4)
    throw InputError::field("assumed_mm_per_unit",
                            fmt::format("is {}, must be 0 (not given) or a positive scale up to 1e4 mm", assumed_mm_per_unit));
  if (max_entities < 1 || max_entities > 10'000'000)
    throw InputError::field("max_entities", fmt::format("is {}, must lie in 1 .. 10 000 000", max_entities));
  if (max_fitted_spans < 1 || max_fitted_spans > 10'000'000)
    throw InputError::field("max_fitted_spans", fmt::format("is {}, must lie in 1 .. 10 000 000", max_fitted_spans));
  if (!std::isfinite(flatten_tolerance_deg) || flatten_tolerance_deg < 0.0 || flatten_tolerance_deg > 5.0)
    throw InputError::field("flatten_tolerance_deg",
                            fmt::format("is {}, must be finite, >= 0 and <= 5 degrees", flatten_tolerance_deg));
}

double mm_per_drawing_unit(std::string_view name) {
  static const std::map<std::string, double, std::less<>> units = {
      {"mm", 1.0},      {"millimeter", 1.0}, {"millimetre", 1.0}, {"cm", 10.0},      {"m", 1000.0},
      {"dm", 100.0},    {"inch", 25.4},      {"in", 25.4},        {"inches", 25.4},  {"foot", 304.8},
      {"ft", 304.8},    {"feet", 304.8},     {"yard", 914.4},     {"yd", 914.4},     {"mil", 0.0254},
      {"micron", 1e-3}, {"um", 1e-3},        {"microinch", 25.4e-6}};
  const auto it = units.find(name);
  return it == units.end() ? 0.0 : it->second;
}

std::string ProfileProblem::text() const { return option.empty() ? message : message + " with " + option; }

const char* to_string(ProfileProblem::Severity s) {
  return s == ProfileProblem::Severity::error ? "error" : "warning";
}

bool ProfileReadResult::has_errors() const {
  return std::any_of(problems.begin(), problems.end(),
                     [](const ProfileProblem& p) { return p.severity == ProfileProblem::Severity::error; });
}

std::string ProfileReadResult::report() const {
  std::string s = fmt::format("{}: {} contour(s), units mm", source, contours.size());
  if (mm_per_unit != 1.0) s += fmt::format(" (drawing units scaled by {:g})", mm_per_unit);
  s += fmt::format("; ends joined within {:g} mm, gaps healed up to {:g} mm", chain_tolerance_mm, join_tolerance_mm);
  s += "\n";
  for (std::size_t i = 0; i < contours.size(); ++i) {
    const auto& c = contours[i];
    const auto box = bounding_box(c.contour);
    s += fmt::format("contour {}: {} ({}), {} vertices, area {:.4f} mm2, {}, perimeter {:.4f} mm\n", i,
                     c.depth % 2 == 0 ? "outer" : "hole", c.depth, c.contour.size(), std::abs(c.area_mm2),
                     to_string(orientation(c.contour)), c.perimeter_mm);
    s += fmt::format("  bbox ({:.4f}, {:.4f}) - ({:.4f}, {:.4f}) mm, layer {}\n", box.min().x(), box.min().y(),
                     box.max().x(), box.max().y(), c.layer);
    if (c.parent >= 0) s += fmt::format("  inside contour {}\n", c.parent);
    if (!c.children.empty()) s += fmt::format("  holds contour(s) {}\n", fmt::join(c.children, ", "));
    s += fmt::format("  entities {}\n", fmt::join(c.handles, " "));
    for (std::size_t k = 0; k < c.contour.size(); ++k)
      s += fmt::format("    {:12.4f} {:12.4f}  bulge {:.6g}\n", c.contour.vertices()[k].x(), c.contour.vertices()[k].y(),
                       c.contour.bulges()[k]);
  }
  for (const auto& p : problems) {
    s += fmt::format("{} {}: {}", to_string(p.severity), p.kind, p.text());
    if (!p.handles.empty()) s += fmt::format(" [{}]", fmt::join(p.handles, " "));
    s += "\n";
  }
  return s;
}

ProfileReadResult read_dxf_profile_text(std::string_view text, const std::string& source, const DxfOptions& options) {
  options.validate();
  const dxf::Scan sc = dxf::scan(text, source);
  ProfileReadResult out;
  out.source = source;
  out.chain_tolerance_mm = options.chain_tolerance_mm;
  out.join_tolerance_mm = options.join_tolerance_mm;
  out.has_insunits = sc.mm_per_unit > 0;
  out.mm_per_unit = out.has_insunits ? sc.mm_per_unit : options.assumed_mm_per_unit > 0 ? options.assumed_mm_per_unit : 1.0;
  dxf::Drawing drawing(source, options, out);
  if (!out.has_insunits) {
    if (options.assumed_mm_per_unit > 0)
      drawing.problem(ProfileProblem::Severity::warning, "no_units", {},
                      fmt::format("the drawing does not state its units ($INSUNITS); read as {:g} mm per unit as asked",
                                  out.mm_per_unit));
    else
      drawing.problem(ProfileProblem::Severity::warning, "no_units", {},
                      "the drawing does not state its units ($INSUNITS); read as mm: if it is drawn in another unit, "
                      "give that unit",
                      std::nullopt, "assumed_mm_per_unit");
  }
  dxf::assemble(drawing, dxf::expand(drawing, sc, out.mm_per_unit));
  return out;
}

ProfileReadResult read_dxf_profile(const std::string& path, const DxfOptions& options) {
  options.validate();
  const std::string text = read_text_file(path);
  return read_dxf_profile_text(text, path, options);
}

}  // namespace machplan
