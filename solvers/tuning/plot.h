// Pictures of `machplan tune`: stacked time plots (the contour error of the baseline and the
// tuned controller; the ACC's cutting force and feed against time). PNG or SVG by extension.
#pragma once

#include <string>
#include <vector>

#include "solvers/tuning/acc_tuning.h"
#include "solvers/tuning/tune.h"

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

// `machplan tune --plot`: the contour error (um) of the baseline and the tuned gains against
// time, on the evaluator's first contour under its first noise draw (both run again here).
void write_tune_plot(const std::string& path, const std::string& field, const Evaluator& evaluator, const TuneOptions& options,
                     const TuneResult& result);
// `machplan tune --acc --plot`: force, feed and depth of cut against time in Koren's test, for
// his fixed gain and each tuned one, with F_r dashed.
void write_acc_plot(const std::string& path, const std::string& field, const AccStudy& study);

}  // namespace machplan::tuning
