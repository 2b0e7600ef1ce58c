// Pictures of `machplan tune`: stacked time plots (the contour error of the baseline and the
// tuned controller; the ACC's cutting force and feed against time). PNG or SVG by extension.
#pragma once

#include <string>
#include <vector>

namespace machplan::tuning {

struct Series {
  std::string name;
  double r = 0, g = 0, b = 0;   // colour
  std::vector<double> t_s, y;
  bool dashed = false;
};

struct Panel {
  std::string y_label;
  std::vector<Series> series;
};

// One panel per entry, stacked, sharing the time axis. Throws InputError naming `field` for a
// bad extension or an unwritable file.
void write_time_plot(const std::string& path, const std::string& field, const std::string& title,
                     const std::vector<Panel>& panels);

}  // namespace machplan::tuning
