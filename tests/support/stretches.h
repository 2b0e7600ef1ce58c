// Building Stretches for tests: a chain of segments with one feed and consecutive source
// lines, polygons and circles as segments. Shared by the motion and executor tests.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/geometry/contour.h"
#include "engine/motion/job.h"

namespace machplan::test {

// A stretch through `segs`, every segment at `feed` mm/s, source lines line, line + 1, ...
inline motion::Stretch make_stretch(std::vector<Segment> segs, double feed, bool cutting, bool rapid = false, int line = 10) {
  motion::Stretch s;
  s.cutting = cutting;
  s.rapid = rapid;
  const std::size_t n = segs.size();
  s.segments = std::move(segs);
  s.feed_mm_per_s.assign(n, feed);
  for (std::size_t i = 0; i < n; ++i) s.source_lines.push_back(line + static_cast<int>(i));
  return s;
}

// The two half circles of a full circle, counter-clockwise from center + (R, 0).
inline std::vector<Segment> circle_segments(const Eigen::Vector2d& c, double R) {
  const Eigen::Vector2d a = c + Eigen::Vector2d(R, 0), b = c - Eigen::Vector2d(R, 0);
  return {make_segment(a, b, 1.0), make_segment(b, a, 1.0)};
}

// A polygon as line segments through `pts` (closed back to the first point when `close`).
inline std::vector<Segment> polyline_segments(const std::vector<Eigen::Vector2d>& pts, bool close) {
  std::vector<Segment> out;
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) out.push_back(make_segment(pts[i], pts[i + 1], 0.0));
  if (close) out.push_back(make_segment(pts.back(), pts.front(), 0.0));
  return out;
}

}  // namespace machplan::test
