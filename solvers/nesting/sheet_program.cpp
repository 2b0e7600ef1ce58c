#include "solvers/nesting/sheet_program.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace machplan::nesting {

namespace {

// `c` starting at the middle of its longest straight span (split there), else as it is.
Contour from_longest_line(const Contour& c) {
  std::size_t best = c.size();
  double longest = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    if (!s.is_arc() && length(s) > longest) longest = length(s), best = i;
  }
  if (best == c.size()) return c;
  const std::size_t n = c.size();
  std::vector<Eigen::Vector2d> v;
  std::vector<double> b;
  const Segment s = c.span(best);
  v.push_back(0.5 * (s.start + s.end));
  b.push_back(0.0);
  for (std::size_t k = 1; k <= n; ++k) {
    const std::size_t i = (best + k) % n;
    v.push_back(c.vertices()[i]);
    b.push_back(c.bulges()[i]);
  }
  // The split span's first half ends the contour: its vertex (best) has bulge 0 already.
  return Contour(std::move(v), std::move(b));
}

void add_cut(Program& p, const Contour& c, bool hole, const SheetProgramOptions& o, int& line) {
  const Contour k = from_longest_line(c);
  const Segment first = k.span(0);
  Eigen::Vector2d t = first.is_arc() ? Eigen::Vector2d(-std::sin(first.start_angle), std::cos(first.start_angle)) *
                                           (first.sweep > 0 ? 1.0 : -1.0)
                                     : (first.end - first.start).normalized();
  // The material on the left of the travel (outer counter-clockwise, hole clockwise): the waste
  // on the right.
  const Eigen::Vector2d waste(t.y(), -t.x());
  double lead = o.lead_in_mm;
  if (hole) lead = std::min(lead, 0.4 * bounding_box(c).sizes().minCoeff());
  const Eigen::Vector2d start = k.vertices().front();
  Move m;
  m.kind = Move::Kind::rapid;
  m.line = ++line;
  m.end = Eigen::Vector3d((start + lead * waste).x(), (start + lead * waste).y(), 0.0);
  p.moves.push_back(m);
  Move on;
  on.kind = Move::Kind::torch_on;
  on.line = ++line;
  on.spindle_speed = 1.0;
  p.moves.push_back(on);
  Move in;
  in.kind = Move::Kind::line;
  in.line = ++line;
  in.end = Eigen::Vector3d(start.x(), start.y(), 0.0);
  in.feed_mm_per_min = o.feed_mm_per_min;
  p.moves.push_back(in);
  for (std::size_t i = 0; i < k.size(); ++i) {
    const Segment s = k.span(i);
    Move f;
    f.kind = s.is_arc() ? Move::Kind::arc : Move::Kind::line;
    f.line = ++line;
    f.end = Eigen::Vector3d(s.end.x(), s.end.y(), 0.0);
    f.feed_mm_per_min = o.feed_mm_per_min;
    if (s.is_arc()) {
      f.center = s.center;
      f.clockwise = s.sweep < 0;
    }
    p.moves.push_back(f);
  }
  Move off;
  off.kind = Move::Kind::torch_off;
  off.line = ++line;
  p.moves.push_back(off);
}

}  // namespace

Program sheet_program(const std::vector<NestPart>& parts, const std::vector<Placement>& placements, int sheet,
                      const SheetProgramOptions& o) {
  Program p;
  p.source = fmt::format("sheet {}", sheet + 1);
  int line = 0;
  for (const Placement& pl : placements) {
    if (pl.sheet != sheet) continue;
    const NestPart& part = parts[pl.part];
    for (const Contour& h : part.holes) add_cut(p, place(h, pl), true, o, line);
    add_cut(p, place(part.outer, pl), false, o, line);
  }
  Move home;
  home.kind = Move::Kind::rapid;
  home.line = ++line;
  p.moves.push_back(home);
  p.ends_with_program_end = true;
  return p;
}

}  // namespace machplan::nesting
