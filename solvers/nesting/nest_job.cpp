#include "solvers/nesting/nest_job.h"

#include <charconv>
#include <filesystem>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/offset.h"

namespace machplan::nesting {

namespace {

// Why a list of n rotations is refused (more than a part may list), or empty.
std::string rotation_count_problem(std::size_t n) {
  return n > kMaxRotations ? fmt::format("lists {} rotations; at most {} (any: any angle)", n, kMaxRotations) : std::string();
}

}  // namespace

std::vector<double> rotations_from_text(const std::string& s, const std::string& field) {
  if (s == "none") return {0.0};
  if (s == "any") return {0, 45, 90, 135, 180, 225, 270, 315};
  std::vector<double> out;
  std::size_t at = 0;
  while (at <= s.size()) {
    const std::size_t comma = std::min(s.find(',', at), s.size());
    const std::string item = s.substr(at, comma - at);
    double d = 0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), d);
    if (item.empty() || ec != std::errc() || end != item.data() + item.size() || !(d >= -360 && d <= 360))
      throw InputError(field, 0, fmt::format("'{}': any, none, or degrees in [-360, 360] separated by commas", excerpt(s)));
    out.push_back(d);
    at = comma + 1;
  }
  if (const std::string problem = rotation_count_problem(out.size()); !problem.empty()) throw InputError(field, 0, problem);
  return out;
}

namespace {

std::vector<double> rotations_of(const Yaml& y) {
  if (y.is_scalar()) {
    const std::string s = y.string();
    if (s != "any" && s != "none") y.fail("must be any, none or a list of degrees");
    return rotations_from_text(s, "rotations");
  }
  std::vector<double> out;
  for (const Yaml& d : y.items()) out.push_back(d.number(NumberRule{.min = -360, .max = 360}));
  if (out.empty()) y.fail("lists no rotation (none: as drawn)");
  if (const std::string problem = rotation_count_problem(out.size()); !problem.empty()) y.fail(problem);
  return out;
}

}  // namespace

Sheet remnant_sheet(const std::string& path, double margin_mm) {
  std::vector<NestPart> found = read_nest_parts(path, false);  // refuses open chains, several outers
  NestPart& outline = found.front();
  const Eigen::AlignedBox2d box = bounding_box(outline.outer);
  Placement to_corner;
  to_corner.translate_mm = -box.min();
  outline.outer = place(outline.outer, to_corner);
  for (Contour& h : outline.holes) h = place(h, to_corner);
  Sheet s;
  s.width_mm = box.sizes().x();
  s.height_mm = box.sizes().y();
  s.margin_mm = margin_mm;
  s.drawn_at = box.min();
  if (2 * margin_mm >= std::min(s.width_mm, s.height_mm) || offset_contour(outline.outer, -margin_mm).vanished())
    throw InputError(path, 0, fmt::format("the remnant ({:.1f} x {:.1f} mm) leaves no usable area inside a margin of {:g} mm",
                                          s.width_mm, s.height_mm, margin_mm));
  s.remnant = std::move(outline);
  return s;
}

NestRequest read_nest_job(const std::string& path) {
  return read_nest_job(Yaml::load_file(path), std::filesystem::path(path).parent_path().string());
}

NestRequest read_nest_job(const Yaml& root, const std::string& folder_path) {
  root.reject_unknown_keys({"sheets", "spacing_mm", "parts", "program"});  // program: read by the CLI
  const std::filesystem::path folder = folder_path;
  NestRequest r;
  r.spacing_mm = root.number_or("spacing_mm", 6.0, {.min = 0, .max = 1000});
  for (const Yaml& s : root.at("sheets").items()) {
    s.reject_unknown_keys({"width_mm", "height_mm", "count", "margin_mm", "outline"});
    if (s.has("outline")) {
      s.reject_unknown_keys({"outline", "count", "margin_mm"});
      std::filesystem::path file = s.string("outline");
      if (file.is_relative()) file = folder / file;
      const double margin = s.number_or("margin_mm", 10.0, {.min = 0, .max = 1000});
      const int count = s.has("count") ? s.at("count").integer(1, 1000) : 1;
      try {
        const Sheet remnant = remnant_sheet(file.string(), margin);
        for (int k = 0; k < count; ++k) r.sheets.push_back(remnant);
      } catch (const InputError& e) {
        s.at("outline").fail(e.what());
      }
      continue;
    }
    Sheet sheet;
    sheet.width_mm = s.number("width_mm", {.min = 0, .max = 100000, .min_exclusive = true});
    sheet.height_mm = s.number("height_mm", {.min = 0, .max = 100000, .min_exclusive = true});
    sheet.margin_mm = s.number_or("margin_mm", 10.0, {.min = 0, .max = 1000});
    if (2 * sheet.margin_mm >= std::min(sheet.width_mm, sheet.height_mm)) s.at("margin_mm").fail("leaves no usable area");
    const int count = s.has("count") ? s.at("count").integer(1, 1000) : 1;
    for (int k = 0; k < count; ++k) r.sheets.push_back(sheet);
  }
  if (r.sheets.empty()) root.at("sheets").fail("lists no sheet");
  for (const Yaml& p : root.at("parts").items()) {
    p.reject_unknown_keys({"file", "quantity", "rotations", "mirror", "priority", "split"});
    std::filesystem::path file = p.string("file");
    if (file.is_relative()) file = folder / file;
    const int quantity = p.has("quantity") ? p.at("quantity").integer(1, 100000) : 1;
    const std::vector<double> rotations = p.has("rotations") ? rotations_of(p.at("rotations")) : rotations_from_text("any", "rotations");
    const bool any = !p.has("rotations") || (p.at("rotations").is_scalar() && p.at("rotations").string() == "any");
    const bool mirror = p.boolean_or("mirror", false), split = p.boolean_or("split", false);
    const int priority = p.has("priority") ? p.at("priority").integer(0, 1000) : 1;
    std::vector<NestPart> parts;
    try {
      parts = read_nest_parts(file.string(), split);
    } catch (const InputError& e) {
      p.at("file").fail(e.what());
    }
    for (NestPart& part : parts) {
      r.parts.push_back(std::move(part));
      r.quantity.push_back(quantity);
      r.rotations.push_back(rotations);
      r.any_rotations.push_back(any);
      r.mirror.push_back(mirror);
      r.priority.push_back(priority);
    }
  }
  if (r.parts.empty()) root.at("parts").fail("lists no part");
  return r;
}

}  // namespace machplan::nesting
