#include "engine/motion/kerf.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

double bulge_of(const Segment& s) { return s.is_arc() ? std::tan(s.sweep / 4.0) : 0.0; }

// The part of `s` from its start to parameter t.
Segment head_of(const Segment& s, double t) { return make_segment(s.start, point_at(s, t), std::tan(s.sweep * t / 4)); }

// Segment `s` with its start (or end) moved to `p`, keeping its bulge.
Segment reaim_start(const Segment& s, const Vector2d& p) { return make_segment(p, s.end, bulge_of(s)); }
Segment reaim_end(const Segment& s, const Vector2d& p) { return make_segment(s.start, p, bulge_of(s)); }

// A run of stretch segments as a Contour. Arcs of more than 3/4 turn are split in halves so
// that their bulge stays moderate (a full programmed circle is one such arc).
struct LoopContour {
  std::size_t a = 0, b = 0;             // segments a..b of the stretch
  Contour contour;
  std::vector<std::size_t> seg_of_span;  // contour span -> stretch segment index
};

std::optional<LoopContour> to_contour(const std::vector<Segment>& segs, std::size_t a, std::size_t b) {
  std::vector<Vector2d> v;
  std::vector<double> bl;
  std::vector<std::size_t> map;
  for (std::size_t i = a; i <= b; ++i) {
    const Segment& s = segs[i];
    if (s.is_arc() && std::abs(s.sweep) > 1.5 * kPi) {
      const double half = std::tan(s.sweep / 8);
      v.push_back(s.start), bl.push_back(half), map.push_back(i);
      v.push_back(point_at(s, 0.5)), bl.push_back(half), map.push_back(i);
    } else {
      v.push_back(s.start), bl.push_back(bulge_of(s)), map.push_back(i);
    }
  }
  try {
    return LoopContour{a, b, Contour(std::move(v), std::move(bl)), std::move(map)};
  } catch (const InputError&) {
    return std::nullopt;  // coordinates beyond the geometry's limits: not a loop we can offset
  }
}

// The shortest run of segments within [from, to) that closes and encloses area.
std::optional<LoopContour> find_loop(const std::vector<Segment>& segs, std::size_t from, std::size_t to,
                                     double tol) {
  std::optional<LoopContour> best;
  for (std::size_t a = from; a < to; ++a)
    for (std::size_t b = a; b < to; ++b) {
      if (best && b - a >= best->b - best->a) break;
      if ((segs[b].end - segs[a].start).norm() > tol) continue;
      auto lc = to_contour(segs, a, b);
      if (!lc) continue;
      if (std::abs(signed_area(lc->contour)) > tol * perimeter(lc->contour)) {
        best = std::move(lc);
        break;
      }
    }
  return best;
}

// True when loop `inner` lies inside loop `outer`: judged at its first vertex clear of
// `outer`'s boundary.
bool encloses(const Contour& outer, const Contour& inner, double tol) {
  for (const auto& v : inner.vertices())
    if (distance(outer, v) > tol) return contains(outer, v);
  return false;
}

// `c` re-started at its point nearest to `target` (splitting a span there if needed);
// `src` is permuted (and split) along.
std::pair<Contour, std::vector<std::size_t>> start_near(const Contour& c, const std::vector<std::size_t>& src,
                                                        const Vector2d& target, double tol) {
  const std::size_t n = c.size();
  const ContourPoint cp = closest_point(c, target);
  const Segment s = c.span(cp.span);
  std::vector<Vector2d> v;
  std::vector<double> b;
  std::vector<std::size_t> ids;
  std::size_t first = cp.span;
  if ((cp.point - s.end).norm() <= tol) first = (cp.span + 1) % n;
  if ((cp.point - s.start).norm() <= tol || (cp.point - s.end).norm() <= tol) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = (first + k) % n;
      v.push_back(c.vertices()[i]), b.push_back(c.bulges()[i]), ids.push_back(src[i]);
    }
  } else {
    const double t = parameter_at(s, cp.point);
    v.push_back(cp.point), b.push_back(std::tan(s.sweep * (1 - t) / 4)), ids.push_back(src[cp.span]);
    for (std::size_t k = 1; k < n; ++k) {
      const std::size_t i = (cp.span + k) % n;
      v.push_back(c.vertices()[i]), b.push_back(c.bulges()[i]), ids.push_back(src[i]);
    }
    v.push_back(c.vertices()[cp.span]), b.push_back(std::tan(s.sweep * t / 4)), ids.push_back(src[cp.span]);
  }
  return {Contour(std::move(v), std::move(b)), std::move(ids)};
}

int line_of(const Stretch& st, std::size_t seg) {
  return seg < st.source_lines.size() ? st.source_lines[seg] : 0;
}
double feed_of(const Stretch& st, std::size_t seg) {
  return seg < st.feed_mm_per_s.size() ? st.feed_mm_per_s[seg] : 0.0;
}

void push(Stretch& st, const Segment& s, double feed, int line) {
  st.segments.push_back(s);
  st.feed_mm_per_s.push_back(feed);
  st.source_lines.push_back(line);
}

KerfIssue::Kind from_offset_kind(OffsetProblem::Kind k) {
  switch (k) {
    case OffsetProblem::Kind::arc_collapsed: return KerfIssue::Kind::arc_collapsed;
    case OffsetProblem::Kind::feature_too_small: return KerfIssue::Kind::feature_too_small;
    case OffsetProblem::Kind::contour_vanished: return KerfIssue::Kind::contour_vanished;
    case OffsetProblem::Kind::vertex_dropped:  // not produced by offset_contour
    case OffsetProblem::Kind::gap_too_narrow: return KerfIssue::Kind::feature_too_small;
  }
  return KerfIssue::Kind::feature_too_small;
}

// A closed loop found in a cutting stretch; compensated only when it is the stretch's only one.
struct Found {
  std::size_t stretch;
  LoopContour loop;
  bool compensate;
};

// Step 1 of apply_kerf: the loops of every cutting stretch (open cuts and stretches of several
// loops reported); a loop that crosses itself is refused.
std::vector<Found> find_loops(const Job& job, const KerfOptions& options, KerfReport& report) {
  const double tol = options.closure_tolerance_mm;
  const auto& in = job.stretches;
  std::vector<Found> found;
  for (std::size_t si = 0; si < in.size(); ++si) {
    const Stretch& st = in[si];
    if (!st.cutting || st.segments.empty()) continue;
    std::vector<LoopContour> loops;
    for (std::size_t from = 0; from < st.segments.size();) {
      auto l = find_loop(st.segments, from, st.segments.size(), tol);
      if (!l) break;
      from = l->b + 1;
      loops.push_back(std::move(*l));
    }
    if (loops.empty()) {
      report.issues.push_back({KerfIssue::Kind::open_cut, si, line_of(st, 0),
                               "an open cut (it never returns to a point it left): not compensated"});
      continue;
    }
    if (loops.size() > 1)
      report.issues.push_back(
          {KerfIssue::Kind::several_loops, si, line_of(st, 0),
           fmt::format("one cut holds {} closed loops (lines {} and {}); not compensated: turn the torch off between "
                       "them",
                       loops.size(), line_of(st, loops[0].a), line_of(st, loops[1].a))});
    for (auto& l : loops) {
      const auto crossings = self_intersections(l.contour, options.offset.tolerance_mm);
      if (!crossings.empty()) {
        const auto& x = crossings.front();
        throw InputError(job.source, line_of(st, l.a),
                         fmt::format("kerf: the closed cut starting here crosses itself at ({:.4f}, {:.4f}) mm "
                                     "(lines {} and {}); its kerf offset is not defined",
                                     x.point.x(), x.point.y(), line_of(st, l.seg_of_span[x.span_a]),
                                     line_of(st, l.seg_of_span[x.span_b])));
      }
      found.push_back({si, std::move(l), loops.size() == 1});
    }
  }
  return found;
}

// Step 2: the nesting depth of each loop among all loops (even: a part boundary, odd: a hole).
std::vector<int> nesting_depths(const std::vector<Found>& found, double tol) {
  std::vector<int> depth(found.size(), 0);
  std::vector<double> area(found.size());
  for (std::size_t i = 0; i < found.size(); ++i) area[i] = std::abs(signed_area(found[i].loop.contour));
  for (std::size_t i = 0; i < found.size(); ++i)
    for (std::size_t j = 0; j < found.size(); ++j)
      if (i != j && area[j] > area[i] && encloses(found[j].loop.contour, found[i].loop.contour, tol)) ++depth[i];
  return depth;
}

// The move stretches in step order, to find a stretch's neighbours.
struct MoveOrder {
  std::vector<std::size_t> order;

  explicit MoveOrder(const Job& job) {
    for (const auto& step : job.steps)
      if (step.kind == Step::Kind::move && step.stretch < job.stretches.size() &&
          std::find(order.begin(), order.end(), step.stretch) == order.end())
        order.push_back(step.stretch);
  }
  // The move stretch before (dir -1) or after (dir +1) stretch si.
  std::optional<std::size_t> neighbour(std::size_t si, int dir) const {
    const auto it = std::find(order.begin(), order.end(), si);
    if (it == order.end()) return std::nullopt;
    const auto pos = static_cast<std::ptrdiff_t>(it - order.begin()) + dir;
    if (pos < 0 || pos >= static_cast<std::ptrdiff_t>(order.size())) return std::nullopt;
    return order[static_cast<std::size_t>(pos)];
  }
};

// Where the loop's start moves to (its start pushed out by d), and which offset contour to cut:
// the nearest of its own orientation (or of any); the others are reported as pieces not cut.
std::pair<std::size_t, Vector2d> choose_offset_contour(const OffsetResult& r, const LoopContour& lc, double d,
                                                       const Found& f,
                                                       const std::function<int(std::size_t)>& line_of_span,
                                                       KerfReport& report) {
  const Contour& c = lc.contour;
  const Segment first = c.span(0);
  const Vector2d p0 = c.vertices()[0];
  const Vector2d tangent = start_tangent(first);
  const Vector2d right(tangent.y(), -tangent.x());
  const Orientation orient = orientation(c);
  const Vector2d outward = orient == Orientation::ccw ? right : Vector2d(-right);
  const Vector2d target = p0 + d * outward;
  std::size_t chosen = 0;
  double best = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < 2 && !std::isfinite(best); ++pass)
    for (std::size_t k = 0; k < r.contours.size(); ++k) {
      if (pass == 0 && orientation(r.contours[k]) != orient) continue;
      const double dist = distance(r.contours[k], target);
      if (dist < best) best = dist, chosen = k;
    }
  for (std::size_t k = 0; k < r.contours.size(); ++k)
    if (k != chosen)
      report.issues.push_back(
          {KerfIssue::Kind::piece_not_cut, f.stretch, line_of_span(r.source_spans[k].front()),
           fmt::format("the kerf offset falls apart where the {} is narrower than the kerf; a separate piece of "
                       "{:.4g} mm^2 near ({:.3f}, {:.3f}) is not cut",
                       d > 0 ? "part's inlet" : "hole", std::abs(signed_area(r.contours[k])),
                       r.contours[k].vertices()[0].x(), r.contours[k].vertices()[0].y())});
  return {chosen, target};
}

// Step 4: the stretch rebuilt round the compensated loop (re-started near the old start):
// lead-in, loop, overcut, lead-out.
Stretch rebuild_stretch(const Stretch& st, const LoopContour& lc, const Contour& loop,
                        const std::vector<std::size_t>& src, const KerfOptions& options) {
  const double tol = options.closure_tolerance_mm;
  const Contour& c = lc.contour;
  const Vector2d new_start = loop.vertices()[0];
  Stretch ns;
  ns.cutting = st.cutting;
  ns.rapid = st.rapid;
  for (std::size_t i = 0; i < lc.a; ++i) {
    const Segment s = i + 1 == lc.a ? reaim_end(st.segments[i], new_start) : st.segments[i];
    push(ns, s, feed_of(st, i), line_of(st, i));
  }
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const std::size_t seg = lc.seg_of_span[src[k]];
    push(ns, loop.span(k), feed_of(st, seg), line_of(st, seg));
  }
  std::size_t i = lc.b + 1;
  double overcut = 0.0;
  while (i < st.segments.size()) {
    const Segment& s = st.segments[i];
    if (distance(c, s.start) > tol || distance(c, point_at(s, 0.5)) > tol || distance(c, s.end) > tol) break;
    overcut += length(s);
    ++i;
  }
  overcut = std::min(overcut, perimeter(loop));
  for (std::size_t k = 0; overcut > options.offset.tolerance_mm && k < loop.size(); ++k) {
    const Segment s = loop.span(k);
    const double l = length(s);
    const Segment piece = l <= overcut ? s : head_of(s, overcut / l);
    push(ns, piece, feed_of(st, lc.b + 1), line_of(st, lc.b + 1));
    overcut -= l;
  }
  const Vector2d loop_end = ns.segments.back().end;
  for (std::size_t j = i; j < st.segments.size(); ++j) {
    const Segment s = j == i ? reaim_start(st.segments[j], loop_end) : st.segments[j];
    push(ns, s, feed_of(st, j), line_of(st, j));
  }
  return ns;
}

// The THC switches (Stretch::thc_off) of `st` carried to its rebuilt `ns`, by program line: a
// segment of ns holds THC off when the segments of its line in st did.
void carry_thc_off(const Stretch& st, Stretch& ns) {
  if (st.thc_off.empty()) return;
  std::map<int, std::uint8_t> by_line;
  for (std::size_t i = 0; i < st.segments.size(); ++i) by_line[line_of(st, i)] |= st.thc_off[i];
  ns.thc_off.assign(ns.segments.size(), 0);
  for (std::size_t i = 0; i < ns.segments.size(); ++i) ns.thc_off[i] = by_line[line_of(ns, i)];
}

// Step 5: the rebuilt stretch `ns` (replacing stretch si) kept continuous with the stretches
// before and after: a rapid next to it is re-aimed, else a straight connector cut is added.
void keep_continuous(Stretch& ns, std::size_t si, const std::vector<Stretch>& in, std::vector<Stretch>& out,
                     const MoveOrder& order, const KerfOptions& options, KerfReport& report) {
  const double tol = options.closure_tolerance_mm;
  const Stretch& st = in[si];
  const Vector2d old_start = st.segments.front().start, old_end = st.segments.back().end;
  const double snap = options.offset.tolerance_mm;
  if ((ns.segments.front().start - old_start).norm() > snap) {
    const auto prev = order.neighbour(si, -1);
    if (prev && !in[*prev].cutting && !out[*prev].segments.empty() &&
        (out[*prev].segments.back().end - old_start).norm() <= tol) {
      out[*prev].segments.back() = reaim_end(out[*prev].segments.back(), ns.segments.front().start);
    } else {
      const Vector2d to = ns.segments.front().start;
      ns.segments.insert(ns.segments.begin(), make_segment(old_start, to, 0.0));
      ns.feed_mm_per_s.insert(ns.feed_mm_per_s.begin(), feed_of(st, 0));
      ns.source_lines.insert(ns.source_lines.begin(), line_of(st, 0));
      report.issues.push_back({KerfIssue::Kind::connector_added, si, line_of(st, 0),
                               fmt::format("the cut has no lead-in and cannot move its start: a {:.4g} mm straight "
                                           "cut from the programmed start onto the compensated loop was added",
                                           (to - old_start).norm())});
    }
  }
  if ((ns.segments.back().end - old_end).norm() > snap) {
    const auto next = order.neighbour(si, +1);
    if (next && !in[*next].cutting && !out[*next].segments.empty() &&
        (out[*next].segments.front().start - old_end).norm() <= tol) {
      out[*next].segments.front() = reaim_start(out[*next].segments.front(), ns.segments.back().end);
    } else if (next) {
      const Vector2d from = ns.segments.back().end;
      push(ns, make_segment(from, old_end, 0.0), feed_of(st, st.segments.size() - 1),
           line_of(st, st.segments.size() - 1));
      report.issues.push_back({KerfIssue::Kind::connector_added, si, line_of(st, st.segments.size() - 1),
                               fmt::format("the next stretch is also a cut: a {:.4g} mm straight cut back to the "
                                           "programmed end point was added",
                                           (old_end - from).norm())});
    }
  }
}

// Step 3 to 5 for one loop at the given nesting depth: offset (its problems reported), the
// offset contour chosen, the stretch rebuilt into `out` and joined to its neighbours.
KerfLoop compensate_loop(const Found& f, int depth, double half, const std::vector<Stretch>& in,
                         std::vector<Stretch>& out, const MoveOrder& order, const KerfOptions& options,
                         KerfReport& report) {
  const Stretch& st = in[f.stretch];
  const LoopContour& lc = f.loop;
  const double d = depth % 2 == 0 ? half : -half;
  KerfLoop info{f.stretch, depth, d, false, line_of(st, lc.a)};
  if (!f.compensate || half <= 0.0) return info;  // no kerf for this cut: as programmed
  const OffsetResult r = offset_contour(lc.contour, d, options.offset);
  const std::function<int(std::size_t)> line_of_span = [&](std::size_t span) {
    return span < lc.seg_of_span.size() ? line_of(st, lc.seg_of_span[span]) : info.source_line;
  };
  for (const auto& p : r.problems)
    report.issues.push_back({from_offset_kind(p.kind), f.stretch,
                             p.span == OffsetProblem::kNoSpan ? info.source_line : line_of_span(p.span),
                             fmt::format("{} of {:.4g} mm: {}{}", d > 0 ? "part boundary grown by half the kerf"
                                                                          : "hole shrunk by half the kerf",
                                         std::abs(d), p.message,
                                         p.kind == OffsetProblem::Kind::contour_vanished
                                             ? "; the cut is left as programmed"
                                             : "")});
  if (r.vanished()) return info;
  const auto [chosen, target] = choose_offset_contour(r, lc, d, f, line_of_span, report);
  const auto [loop, src] = start_near(r.contours[chosen], r.source_spans[chosen], target, options.offset.tolerance_mm);
  Stretch ns = rebuild_stretch(st, lc, loop, src, options);
  keep_continuous(ns, f.stretch, in, out, order, options, report);
  carry_thc_off(st, ns);
  out[f.stretch] = std::move(ns);
  info.compensated = true;
  return info;
}

// The kerf each stretch is cut with: its material's (the material of the torch_on before it),
// where KerfOptions::kerf_from_materials asks for it and the material gives one, else `width`.
std::vector<double> kerf_of_stretches(const Job& job, double width, const KerfOptions& options) {
  std::vector<double> kerf(job.stretches.size(), width);
  if (!options.kerf_from_materials) return kerf;
  double in_force = width;  // the kerf of the material the last torch_on lit
  for (const Step& st : job.steps) {
    if (st.kind == Step::Kind::torch_on) {
      const auto m = static_cast<std::size_t>(st.material);
      in_force = st.material >= 0 && m < job.materials.size() && job.materials[m].kerf_mm > 0.0 ? job.materials[m].kerf_mm : width;
    }
    if (st.kind == Step::Kind::move && st.stretch < kerf.size()) kerf[st.stretch] = in_force;
  }
  return kerf;
}

}  // namespace

void KerfOptions::validate() const {
  if (!std::isfinite(closure_tolerance_mm) || !(closure_tolerance_mm > 0.0) || closure_tolerance_mm > 1.0)
    throw InputError::field("closure_tolerance_mm",
                            fmt::format("is {}, must be finite, > 0 and <= 1 mm", closure_tolerance_mm));
  validate_member("offset", offset);
}

const char* to_string(KerfIssue::Kind k) {
  switch (k) {
    case KerfIssue::Kind::open_cut: return "open_cut";
    case KerfIssue::Kind::several_loops: return "several_loops";
    case KerfIssue::Kind::contour_vanished: return "contour_vanished";
    case KerfIssue::Kind::arc_collapsed: return "arc_collapsed";
    case KerfIssue::Kind::feature_too_small: return "feature_too_small";
    case KerfIssue::Kind::piece_not_cut: return "piece_not_cut";
    case KerfIssue::Kind::connector_added: return "connector_added";
  }
  return "?";
}

std::size_t KerfReport::compensated_count() const {
  return static_cast<std::size_t>(
      std::count_if(loops.begin(), loops.end(), [](const KerfLoop& l) { return l.compensated; }));
}

std::string KerfReport::brief(const std::string& source) const {
  std::size_t parts = 0, holes = 0;
  for (const auto& l : loops)
    if (l.compensated) (l.depth % 2 == 0 ? parts : holes)++;
  const std::string width = !kerf_from_materials ? fmt::format("kerf {:.3f} mm", kerf_width_mm)
                            : kerf_width_mm > 0 ? fmt::format("kerf of each cut's material (else {:.3f} mm)", kerf_width_mm)
                                                : std::string("kerf of each cut's material");
  std::string s = fmt::format("{}: {} of {} closed cuts compensated ({} part boundaries grown, {} holes "
                              "shrunk), {} issue(s)\n",
                              width, compensated_count(), loops.size(), parts, holes, issues.size());
  for (const auto& i : issues) {
    const std::string where = source.empty() ? "line" : source;
    s += i.source_line > 0 ? fmt::format("{}:{}: ", where, i.source_line) : (source.empty() ? "" : source + ": ");
    s += fmt::format("{}: {}\n", to_string(i.kind), i.message);
  }
  return s;
}

KerfReport apply_kerf(Job& job, double kerf_width_mm, const KerfOptions& options) {
  options.validate();
  if (!std::isfinite(kerf_width_mm) || kerf_width_mm < 0.0 || kerf_width_mm > 100.0)
    throw InputError::field("kerf_width_mm", fmt::format("is {}, must be finite, >= 0 and <= 100 mm", kerf_width_mm));
  KerfReport report;
  report.kerf_width_mm = kerf_width_mm;
  report.kerf_from_materials = options.kerf_from_materials;
  const std::vector<double> kerf = kerf_of_stretches(job, kerf_width_mm, options);
  if (std::none_of(kerf.begin(), kerf.end(), [](double k) { return k > 0.0; })) return report;
  const std::vector<Found> found = find_loops(job, options, report);                  // 1.
  const std::vector<int> depth = nesting_depths(found, options.closure_tolerance_mm);  // 2.
  const MoveOrder order(job);
  std::vector<Stretch> out = job.stretches;
  for (std::size_t fi = 0; fi < found.size(); ++fi)                                    // 3. to 5.
    report.loops.push_back(compensate_loop(found[fi], depth[fi], 0.5 * kerf[found[fi].stretch], job.stretches, out,
                                           order, options, report));
  job.stretches = std::move(out);
  return report;
}

}  // namespace machplan::motion
