// How a run's arc covered the programmed cuts, from the simulator's truth: where along each
// cutting stretch the torch burned, pass by pass. The gaps a hold or a recovery left, and the
// lengths cut twice.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "engine/executor/executor.h"
#include "engine/motion/job.h"

namespace machplan::test {

struct CutCoverage {
  double longest_gap_mm = 0.0;  // the longest run of the stretch no pass burned along
  double double_mm = 0.0;       // the length burned by two passes or more
  int passes = 0;               // runs of burning samples, unbroken in time, on this stretch
};

// Coverage of stretch `s` along its length. A burning sample (torch fired, arc OK, true position
// known) within `reach_mm` of the stretch counts at the arc length of its nearest point; a pass
// covers the interval from its least to its greatest arc length.
inline CutCoverage cut_coverage(const motion::Stretch& s, const std::vector<executor::TraceSample>& trace, double reach_mm) {
  std::vector<double> start(s.segments.size() + 1, 0.0);
  for (std::size_t i = 0; i < s.segments.size(); ++i) start[i + 1] = start[i] + length(s.segments[i]);
  // A box round the stretch (its segments sampled, widened by more than an arc's sagitta
  // between samples): samples outside it are not on it, without the search.
  Eigen::AlignedBox2d box;
  for (const Segment& seg : s.segments)
    for (int k = 0; k <= 32; ++k) box.extend(point_at(seg, k / 32.0));
  box.min().array() -= reach_mm + 1.0;
  box.max().array() += reach_mm + 1.0;
  CutCoverage c;
  std::vector<std::pair<double, double>> passes;  // intervals of arc length burned
  bool in_pass = false;
  double last_at = 0.0;
  for (const executor::TraceSample& t : trace) {
    // The nearest point; of points as near (a closed contour's start and end), the one nearest
    // along the stretch to the pass's last sample, else the first.
    double at = std::numeric_limits<double>::quiet_NaN(), best = reach_mm;
    const double last = in_pass ? last_at : 0.0;
    if (t.torch_fire && t.arc_ok && t.true_mm.allFinite() && box.contains(t.true_mm))
      for (std::size_t i = 0; i < s.segments.size(); ++i) {
        const Eigen::Vector2d q = closest_point(s.segments[i], t.true_mm);
        const double d = (q - t.true_mm).norm();
        const double here = start[i] + parameter_at(s.segments[i], q) * length(s.segments[i]);
        const bool tie = std::abs(d - best) < 1e-6 && !std::isnan(at);
        if (tie ? std::abs(here - last) < std::abs(at - last) : d < best) best = d, at = here;
      }
    if (std::isnan(at)) {
      in_pass = false;
      continue;
    }
    // A new pass, or a jump along the stretch within one (round a closed contour's start): a
    // new interval.
    if (!in_pass || std::abs(at - last_at) > 2.0) passes.emplace_back(at, at);
    c.passes += !in_pass;
    in_pass = true;
    last_at = at;
    passes.back().first = std::min(passes.back().first, at);
    passes.back().second = std::max(passes.back().second, at);
  }
  // Sweep the passes' ends: depth 0 is a gap, 2 or more is cut twice.
  std::vector<std::pair<double, int>> ends{{0.0, 0}, {start.back(), 0}};
  for (const auto& [lo, hi] : passes) ends.emplace_back(lo, +1), ends.emplace_back(hi, -1);
  std::sort(ends.begin(), ends.end());
  int depth = 0;
  for (std::size_t i = 0; i + 1 < ends.size(); ++i) {
    depth += ends[i].second;
    const double span = std::min(ends[i + 1].first, start.back()) - std::max(ends[i].first, 0.0);
    if (span <= 0) continue;
    if (depth == 0) c.longest_gap_mm = std::max(c.longest_gap_mm, span);
    if (depth >= 2) c.double_mm += span;
  }
  return c;
}

}  // namespace machplan::test
