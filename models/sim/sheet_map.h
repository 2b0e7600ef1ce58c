// A measured (or made-up) sheet for the simulator: the plate's height on a grid, read from a
// CSV file (`machplan run --sheet-map FILE.csv`), between the grid's points bilinear, outside it
// the nearest edge's.
//
// File format: '#' starts a comment, blank lines are ignored; the first data line is the
// header `x_mm,y_mm,z_mm`; then one point a row. The points make a full rectangular grid:
// every x of the file with every y of the file, each once, at least 2 of each, in any order.
// z is the plate's surface in the machine's height frame (0: the nominal surface; up is
// positive), within +-50 mm. Errors name FILE:LINE: a row that is not three numbers, a point
// given twice, a value out of range, more than 1 000 000 points; and the whole file: a grid
// with a point missing (named), fewer than 2 x or y values.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace machplan::sim {

class SheetMap {
 public:
  // The plate's surface at (x, y), mm.
  double z_mm(double x, double y) const noexcept;
  const std::vector<double>& xs() const { return xs_; }
  const std::vector<double>& ys() const { return ys_; }
  std::string source;

 private:
  friend SheetMap parse_sheet_map(std::string_view text, const std::string& source);
  std::vector<double> xs_, ys_;  // ascending
  std::vector<double> z_;        // z_[j * xs_.size() + i] at (xs_[i], ys_[j])
};

SheetMap parse_sheet_map(std::string_view text, const std::string& source);
SheetMap read_sheet_map(const std::string& path);

inline constexpr double kSheetMapMaxZ = 50.0;
inline constexpr std::size_t kSheetMapMaxPoints = 1'000'000;

}  // namespace machplan::sim
