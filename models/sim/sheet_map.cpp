#include "models/sim/sheet_map.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/common/internal/text_scan.h"
#include "engine/common/text_file.h"

namespace machplan::sim {

namespace {

// Index of the cell [v[k], v[k+1]] holding `x` and the share of the way through it, clamped
// to the grid.
std::pair<std::size_t, double> cell(const std::vector<double>& v, double x) {
  if (!(x > v.front())) return {0, 0.0};
  if (!(x < v.back())) return {v.size() - 2, 1.0};
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(v.begin(), v.end(), x) - v.begin()) - 1;
  return {k, (x - v[k]) / (v[k + 1] - v[k])};
}

}  // namespace

double SheetMap::z_mm(double x, double y) const noexcept {
  const auto [i, u] = cell(xs_, x);
  const auto [j, w] = cell(ys_, y);
  const std::size_t n = xs_.size();
  const auto at = [&](std::size_t a, std::size_t b) { return z_[b * n + a]; };
  return (1 - w) * ((1 - u) * at(i, j) + u * at(i + 1, j)) + w * ((1 - u) * at(i, j + 1) + u * at(i + 1, j + 1));
}

SheetMap parse_sheet_map(std::string_view text, const std::string& source) {
  using text_scan::printable;
  using text_scan::trim;
  std::map<std::pair<double, double>, std::pair<double, int>> points;  // (x, y) -> (z, line)
  text_scan::LineReader lines(text);
  std::string_view raw;
  bool header = false;
  int last_line = 0;
  while (lines.next(raw)) {
    const int line = last_line = lines.line_number();
    const std::string_view l = trim(raw.substr(0, raw.find('#')));
    if (l.empty()) continue;
    if (!header) {
      if (l != "x_mm,y_mm,z_mm")
        throw InputError(source, line, fmt::format("the first line must be the header 'x_mm,y_mm,z_mm', found '{}'", printable(l)));
      header = true;
      continue;
    }
    double v[3];
    std::size_t from = 0;
    for (int k = 0; k < 3; ++k) {
      const std::size_t comma = l.find(',', from);
      if ((k < 2) == (comma == std::string_view::npos))
        throw InputError(source, line, fmt::format("expected three numbers x_mm,y_mm,z_mm, found '{}'", printable(l)));
      const std::string_view f = trim(l.substr(from, comma == std::string_view::npos ? std::string_view::npos : comma - from));
      const std::optional<double> n = parse_finite(std::string(f));
      if (!n) throw InputError(source, line, fmt::format("'{}' is not a number", printable(f)));
      v[k] = *n;
      from = comma + 1;
    }
    if (std::abs(v[0]) > 1e6 || std::abs(v[1]) > 1e6)
      throw InputError(source, line, fmt::format("({:g}, {:g}) lies beyond 1e6 mm", v[0], v[1]));
    if (std::abs(v[2]) > kSheetMapMaxZ)
      throw InputError(source, line, fmt::format("z {:g} mm must be within +-{:g} mm of the nominal surface", v[2], kSheetMapMaxZ));
    if (points.size() >= kSheetMapMaxPoints)
      throw InputError(source, line, fmt::format("more than {} points", kSheetMapMaxPoints));
    const auto [it, fresh] = points.emplace(std::make_pair(v[0], v[1]), std::make_pair(v[2], line));
    if (!fresh)
      throw InputError(source, line, fmt::format("({:g}, {:g}) given twice (first on line {})", v[0], v[1], it->second.second));
  }
  if (!header) throw InputError(source, last_line, "no header 'x_mm,y_mm,z_mm': the file is empty");
  SheetMap m;
  m.source = source;
  for (const auto& [xy, z] : points) m.xs_.push_back(xy.first), m.ys_.push_back(xy.second);
  for (auto* v : {&m.xs_, &m.ys_}) {
    std::sort(v->begin(), v->end());
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  if (m.xs_.size() < 2 || m.ys_.size() < 2)
    throw InputError(source, last_line,
                     fmt::format("the grid has {} x and {} y values: at least 2 of each", m.xs_.size(), m.ys_.size()));
  if (points.size() != m.xs_.size() * m.ys_.size()) {
    for (double y : m.ys_)
      for (double x : m.xs_)
        if (!points.count({x, y}))
          throw InputError(source, last_line,
                           fmt::format("the grid of {} x by {} y values has no point at ({:g}, {:g})", m.xs_.size(), m.ys_.size(), x, y));
  }
  m.z_.reserve(points.size());
  for (double y : m.ys_)
    for (double x : m.xs_) m.z_.push_back(points.at({x, y}).first);
  return m;
}

SheetMap read_sheet_map(const std::string& path) { return parse_sheet_map(read_text_file(path), path); }

}  // namespace machplan::sim
