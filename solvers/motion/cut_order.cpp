#include "solvers/motion/cut_order.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/nesting.h"
#include "engine/geometry/span_index.h"
#include "engine/motion/make_job.h"
#include "solvers/motion/cut_sequence.h"
#include "solvers/motion/rapid_zones.h"
#include "solvers/motion/rapids.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
constexpr double kZ = 1e-9;  // Z changes below this are none, mm

// A place on a cut's loop: segment `span` of the loop (0 = its first), at parameter t in [0, 1).
struct Entry {
  std::size_t span = 0;
  double t = 0.0;
};

// One cut of the program.
struct Cut {
  std::size_t approach = 0, on = 0, end = 0;  // moves [approach, on): the rapids to it; [on, end): the cut
  std::size_t off = 0;                        // its torch_off (end when it has none); dwells after it are its own
  int line = 0;                     // its first feed move's line (the torch_on's when it has none)
  Vector2d pierce = Vector2d::Zero(), exit = Vector2d::Zero();
  std::vector<Segment> path;        // its feed moves as segments
  std::vector<std::size_t> origin;  // the move of each segment
  std::optional<Loop> loop;         // segments loop->first .. loop->last
  bool movable = false;             // a lead-in, nothing that pins the pierce point
  std::vector<Entry> entries;       // candidates: [0] as programmed
};

// The program cut into preamble, cuts and postamble; or why it cannot be.
struct Layout {
  std::vector<Cut> cuts;
  std::size_t post = 0;  // first move of the postamble
  Vector2d start = Vector2d::Zero();
  std::optional<Vector2d> end;
  std::vector<Eigen::Vector3d> at;  // position before each move
  std::string refused;              // empty when the program can be reordered
};

// Where the torch is before each move.
std::vector<Eigen::Vector3d> positions(const Program& p) {
  std::vector<Eigen::Vector3d> at;
  Eigen::Vector3d pos = p.start;
  for (const Move& m : p.moves) {
    at.push_back(pos);
    if (is_motion(m)) pos = m.end;
  }
  at.push_back(pos);
  return at;
}

// The cut path of moves [on, end): its segments, and whether a dwell after the first feed move
// or an arc of several turns pins its pierce point.
void read_path(const Program& p, const Layout& l, Cut& c) {
  bool fed = false, pinned = false;
  for (std::size_t i = c.on; i < c.end; ++i) {
    const Move& m = p.moves[i];
    if (m.kind == Move::Kind::dwell && fed && i < c.off) pinned = true;
    if (m.kind != Move::Kind::line && m.kind != Move::Kind::arc) continue;
    fed = true;
    if (m.kind == Move::Kind::arc && m.turns > 0) pinned = true;
    for (const Segment& s : move_segments(m, l.at[i].head<2>())) {
      c.path.push_back(s);
      c.origin.push_back(i);
    }
  }
  c.line = c.path.empty() ? p.moves[c.on].line : p.moves[c.origin.front()].line;  // the cut's first feed line
  c.pierce = l.at[c.on].head<2>();
  c.exit = l.at[c.end].head<2>();
  c.loop = find_loop(c.path);
  c.movable = c.loop && c.loop->first > 0 && !pinned;
}

std::string refuse_at(const Program& p, const Move& m, const std::string& what) {
  return fmt::format("{}:{}: {}", p.source, m.line, what);
}

Layout layout(const Program& p) {
  Layout l;
  l.at = positions(p);
  const std::size_t n = p.moves.size();
  for (const Move& m : p.moves) {
    if (m.kind == Move::Kind::arc && m.plane != Move::Plane::xy)
      return l.refused = refuse_at(p, m, "an arc outside the XY plane"), l;
    if (is_motion(m) && std::abs(m.end.z() - p.start.z()) > kZ)
      return l.refused = refuse_at(p, m, "Z moves (cut order works on 2-D cutting programs)"), l;
  }
  std::size_t i = 0;
  while (i < n) {
    if (p.moves[i].kind != Move::Kind::torch_on) {
      ++i;
      continue;
    }
    Cut c;
    c.on = i;
    std::size_t j = i + 1;
    for (; j < n && p.moves[j].kind != Move::Kind::torch_off; ++j) {
      if (p.moves[j].kind == Move::Kind::torch_on)
        return l.refused = refuse_at(p, p.moves[j], "the torch is turned on again before it was turned off"), l;
      if (p.moves[j].kind == Move::Kind::rapid) return l.refused = refuse_at(p, p.moves[j], "a rapid with the torch on"), l;
    }
    c.off = j;
    c.end = std::min(j + 1, n);
    // A pause after the torch_off (to let the arc die, as some posts write) goes with the cut.
    while (c.end < n && p.moves[c.end].kind == Move::Kind::dwell) ++c.end;
    // Its approach: the rapids (and stray torch_offs) since the previous cut, or the trailing
    // rapids of the preamble.
    std::size_t a = l.cuts.empty() ? i : l.cuts.back().end;
    if (l.cuts.empty()) {
      while (a > 0 && (p.moves[a - 1].kind == Move::Kind::rapid || p.moves[a - 1].kind == Move::Kind::torch_off)) --a;
    } else {
      for (std::size_t k = a; k < i; ++k)
        if (p.moves[k].kind != Move::Kind::rapid && p.moves[k].kind != Move::Kind::torch_off)
          return l.refused = refuse_at(p, p.moves[k], fmt::format("a {} between cuts with the torch off",
                                                                  to_string(p.moves[k].kind))),
                 l;
    }
    c.approach = a;
    read_path(p, l, c);
    l.cuts.push_back(std::move(c));
    i = l.cuts.back().end;
  }
  l.post = l.cuts.empty() ? n : l.cuts.back().end;
  l.start = l.cuts.empty() ? Vector2d(p.start.head<2>()) : Vector2d(l.at[l.cuts.front().approach].head<2>());
  for (std::size_t k = l.post; k < n; ++k)
    if (is_motion(p.moves[k])) {
      l.end = p.moves[k].end.head<2>();
      break;
    }
  return l;
}

// ---------------------------------------------------------------------------------------
// Moving a cut's entry along its loop.

Segment transformed(const Segment& s, const Vector2d& from, const Vector2d& to, double angle) {
  const Eigen::Rotation2Dd r(angle);
  Segment out = s;
  out.start = to + r * (s.start - from);
  out.end = to + r * (s.end - from);
  if (s.is_arc()) {
    out.center = to + r * (s.center - from);
    out.start_angle = s.start_angle + angle;
  }
  return out;
}

// Segment s from parameter a to b (0 <= a < b <= 1).
Segment piece(const Segment& s, double a, double b) {
  Segment out = s;
  out.start = a == 0.0 ? s.start : point_at(s, a);
  out.end = b == 1.0 ? s.end : point_at(s, b);
  if (s.is_arc()) {
    out.start_angle = s.start_angle + a * s.sweep;
    out.sweep = (b - a) * s.sweep;
  }
  return out;
}

// The cut's path pierced at `e`: segments with their origin moves, the pierce and exit points.
struct Path {
  std::vector<Segment> segs;
  std::vector<std::size_t> origin;
  Vector2d pierce, exit;
  std::size_t loop_begin = 0, loop_end = 0;  // the loop's segments in segs
  bool overcut = false;                      // the lead-out runs along the loop
};

Path entered_at(const Cut& c, const Entry& e) {
  const std::size_t first = c.loop->first, last = c.loop->last, count = last - first + 1;
  const Segment& span = c.path[first + e.span];
  const Vector2d s_old = c.path[first].start, s_new = e.t == 0.0 ? span.start : point_at(span, e.t);
  const Vector2d t_old = start_tangent(c.path[first]), t_new = e.t == 0.0 ? start_tangent(span) : tangent_at(span, s_new);
  const double angle = std::atan2(t_new.y(), t_new.x()) - std::atan2(t_old.y(), t_old.x());
  Path out;
  const auto add = [&](const Segment& s, std::size_t origin) {
    out.segs.push_back(s);
    out.origin.push_back(origin);
  };
  for (std::size_t k = 0; k < first; ++k) add(transformed(c.path[k], s_old, s_new, angle), c.origin[k]);
  // The loop from the new entry round to it again.
  std::vector<std::pair<Segment, std::size_t>> loop;
  if (e.t > 0.0) loop.emplace_back(piece(span, e.t, 1.0), c.origin[first + e.span]);
  for (std::size_t k = 1; k <= count; ++k) {
    const std::size_t idx = first + (e.span + k) % count;
    if (k == count && e.t > 0.0) loop.emplace_back(piece(c.path[idx], 0.0, e.t), c.origin[idx]);
    else if (k < count || e.t == 0.0) loop.emplace_back(c.path[idx], c.origin[idx]);
  }
  if (e.t == 0.0) std::rotate(loop.begin(), loop.end() - 1, loop.end());  // starts with span e.span
  out.loop_begin = out.segs.size();
  for (const auto& [s, o] : loop) add(s, o);
  out.loop_end = out.segs.size();
  // The lead-out: along the loop again when it runs on it (an overcut), else moved rigidly.
  double along = 0.0;
  bool on_loop = last + 1 < c.path.size();
  for (std::size_t k = last + 1; k < c.path.size(); ++k) {
    along += length(c.path[k]);
    on_loop = on_loop && distance(c.loop->contour, c.path[k].end) < 1e-3 && distance(c.loop->contour, point_at(c.path[k], 0.5)) < 1e-3;
  }
  out.overcut = on_loop;
  if (on_loop) {
    for (std::size_t k = 0; k < loop.size() && along > 1e-9; ++k) {
      const double len = length(loop[k].first);
      add(len <= along ? loop[k].first : piece(loop[k].first, 0.0, along / len), c.origin[last + 1]);
      along -= len;
    }
  } else {
    for (std::size_t k = last + 1; k < c.path.size(); ++k) add(transformed(c.path[k], s_old, s_new, angle), c.origin[k]);
  }
  out.pierce = out.segs.front().start;
  out.exit = out.segs.back().end;
  return out;
}

// Candidate entries: evenly along the loop by length, kept off the spans' ends.
std::vector<Entry> spread_entries(const Cut& c, int count, double margin) {
  std::vector<Entry> out;
  const std::size_t first = c.loop->first, n = c.loop->last - first + 1;
  double total = 0.0;
  for (std::size_t k = 0; k < n; ++k) total += length(c.path[first + k]);
  for (int q = 0; q < count; ++q) {
    double at = total * (q + 0.5) / count;
    std::size_t k = 0;
    for (; k + 1 < n && at > length(c.path[first + k]); ++k) at -= length(c.path[first + k]);
    const double len = length(c.path[first + k]);
    if (!(len > 0.0)) continue;
    const double m = std::min(margin, 0.5 * len);
    at = std::clamp(at, m, len - m);
    const double t = at / len;
    if (t <= 0.0 || t >= 1.0) continue;
    out.push_back({k, t});
  }
  return out;
}

// What a moved entry is checked against: every loop (an index over them) and every open cut.
struct Neighbourhood {
  std::vector<Contour> loops;
  std::vector<std::size_t> loop_cut;  // loop -> cut
  SpanIndex index;
  std::vector<std::pair<Segment, std::size_t>> open;  // segments of open cuts, with their cut

  explicit Neighbourhood(const std::vector<Cut>& cuts) {
    for (std::size_t i = 0; i < cuts.size(); ++i) {
      if (cuts[i].loop) {
        loops.push_back(cuts[i].loop->contour);
        loop_cut.push_back(i);
      } else {
        for (const Segment& s : cuts[i].path) open.emplace_back(s, i);
      }
    }
    if (!loops.empty()) index = SpanIndex(loops);
  }
  // The cuts (by index) whose loop holds p.
  std::vector<std::size_t> holding(const Vector2d& p) const {
    std::vector<std::pair<std::uint32_t, int>> w;
    if (!loops.empty()) index.windings(p, w);
    std::vector<std::size_t> out;
    for (const auto& [k, n] : w) out.push_back(loop_cut[k]);
    return out;
  }
  // Distance from segment s (an arc by chords) to every cut but `own`, up to `cap`.
  double distance_to_others(const Segment& s, std::size_t own, double cap) const {
    double best = cap;
    const int pieces = s.is_arc() ? 8 : 1;
    for (int k = 0; k < pieces; ++k) {
      const Vector2d a = point_at(s, double(k) / pieces), b = point_at(s, double(k + 1) / pieces);
      Eigen::AlignedBox2d box(a);
      box.extend(b);
      box.min().array() -= cap;
      box.max().array() += cap;
      if (!loops.empty())
        index.for_each_in_box(box, [&](std::size_t i) {
          const SpanIndex::Item& it = index.item(i);
          if (loop_cut[it.contour] == own) return;
          best = std::min(best, segment_distance_mm(a, b, loops[it.contour].span(it.span)));
        });
      for (const auto& [g, cut] : open)
        if (cut != own && bounding_box(g).exteriorDistance(box) <= 0.0) best = std::min(best, segment_distance_mm(a, b, g));
    }
    return best;
  }
};

// A moved entry keeps the pierce in its region, off every edge, and the lead-in and lead-out
// on the loop only where they join it.
bool entry_ok(const Cut& c, std::size_t own, const Path& moved, const Neighbourhood& hood, double clearance) {
  if (hood.holding(moved.pierce) != hood.holding(c.pierce)) return false;
  const Contour& loop = c.loop->contour;
  const double own_margin = std::min(clearance, distance(loop, c.pierce));
  if (!(distance(loop, moved.pierce) >= own_margin - 1e-9)) return false;
  const Vector2d entry = moved.segs[moved.loop_begin].start;
  for (std::size_t k = 0; k < moved.segs.size(); ++k) {
    const bool lead_in = k < moved.loop_begin, lead_out = k >= moved.loop_end;
    if (!lead_in && !(lead_out && !moved.overcut)) continue;
    if (hood.distance_to_others(moved.segs[k], own, clearance) < clearance) return false;
    for (std::size_t q = 0; q < loop.size(); ++q)
      for (const Vector2d& x : intersect(moved.segs[k], loop.span(q), 1e-9).points)
        if ((x - entry).norm() > 1e-6 && (x - moved.exit).norm() > 1e-6) return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------
// The program rebuilt in a new order.

Move as_move(const Segment& s, const Move& like) {
  Move m = like;
  m.end.head<2>() = s.end;
  m.turns = 0;
  if (s.is_arc()) {
    m.kind = Move::Kind::arc;
    m.plane = Move::Plane::xy;
    m.center = s.center;
    m.clockwise = s.sweep < 0;
  } else {
    m.kind = Move::Kind::line;
  }
  return m;
}

Program rebuild(const Program& p, const Layout& l, const Sequence& s) {
  Program out = p;
  out.moves.clear();
  std::vector<std::size_t> new_index(p.moves.size() + 1, 0);  // old move -> new index (first derived)
  const auto copy = [&](std::size_t from, std::size_t to) {
    for (std::size_t i = from; i < to; ++i) {
      new_index[i] = out.moves.size();
      out.moves.push_back(p.moves[i]);
    }
  };
  copy(0, l.cuts.empty() ? p.moves.size() : l.cuts.front().approach);
  for (std::size_t k = 0; k < s.order.size(); ++k) {
    const Cut& c = l.cuts[static_cast<std::size_t>(s.order[k])];
    const std::size_t entry = static_cast<std::size_t>(s.entry[k]);
    // One straight rapid to the pierce point, like the cut's first approach rapid.
    const std::size_t like = c.approach < c.on ? c.approach : c.on;
    for (std::size_t i = c.approach; i <= c.on; ++i) new_index[i] = out.moves.size();
    Move rapid = p.moves[like];
    rapid.kind = Move::Kind::rapid;
    rapid.feed_mm_per_min = 0.0;
    const Path path = entry == 0 ? Path{c.path, c.origin, c.pierce, c.exit, 0, 0, false} : entered_at(c, c.entries[entry]);
    rapid.end = Eigen::Vector3d(path.pierce.x(), path.pierce.y(), p.start.z());
    out.moves.push_back(rapid);
    if (entry == 0) {
      copy(c.on, c.end);
      continue;
    }
    // Moved: torch and dwell moves as written, the feed moves from the moved path.
    std::size_t seg = 0;
    for (std::size_t i = c.on; i < c.end; ++i) {
      new_index[i] = out.moves.size();
      const Move& m = p.moves[i];
      if (m.kind != Move::Kind::line && m.kind != Move::Kind::arc) {
        out.moves.push_back(m);
        continue;
      }
      // Every moved segment from here up to the next non-feed move of the cut.
      std::size_t next = i + 1;
      while (next < c.end && (p.moves[next].kind == Move::Kind::line || p.moves[next].kind == Move::Kind::arc)) ++next;
      for (; seg < path.segs.size(); ++seg) out.moves.push_back(as_move(path.segs[seg], p.moves[path.origin[seg]]));
      for (std::size_t q = i + 1; q < next; ++q) new_index[q] = out.moves.size();
      i = next - 1;
    }
  }
  copy(l.post, p.moves.size());
  new_index[p.moves.size()] = out.moves.size();
  // Torch words and dwells happen where the torch is, as the reader records them.
  Eigen::Vector3d pos = p.start;
  for (Move& m : out.moves) {
    if (is_motion(m)) pos = m.end;
    else m.end = pos;
  }
  for (ProgramEvent& e : out.events) e.before_move = new_index[std::min(e.before_move, p.moves.size())];
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const ProgramEvent& a, const ProgramEvent& b) { return a.before_move < b.before_move; });
  return out;
}

}  // namespace

const char* to_string(CutOrder o) {
  switch (o) {
    case CutOrder::program: return "program";
    case CutOrder::nearest: return "nearest";
    case CutOrder::optimise: return "optimise";
  }
  return "?";
}

std::optional<CutOrder> cut_order_from(std::string_view name) {
  if (name == "program") return CutOrder::program;
  if (name == "nearest") return CutOrder::nearest;
  if (name == "optimise" || name == "optimize") return CutOrder::optimise;
  return std::nullopt;
}

void CutOrderOptions::validate() const {
  if (entry_candidates < 0 || entry_candidates > 64)
    throw InputError::field("entry_candidates", fmt::format("is {}, must lie in 0 .. 64", entry_candidates));
  if (!(edge_clearance_mm > 0.0) || !(edge_clearance_mm <= 100.0))
    throw InputError::field("edge_clearance_mm", fmt::format("is {}, must lie in (0, 100] mm", edge_clearance_mm));
  if (!(corner_margin_mm >= 0.0) || !(corner_margin_mm <= 1000.0))
    throw InputError::field("corner_margin_mm", fmt::format("is {}, must lie in [0, 1000] mm", corner_margin_mm));
  if (max_rounds < 1 || max_rounds > 1000)
    throw InputError::field("max_rounds", fmt::format("is {}, must lie in 1 .. 1000", max_rounds));
}

namespace {

// The routing problem of the layout: candidates and precedences.
SequenceProblem problem_of(Layout& l, const CutOrderOptions& o, CutOrderReport& r) {
  SequenceProblem sp;
  sp.start = l.start;
  sp.end = l.end;
  const Neighbourhood hood(l.cuts);
  const Nesting nesting = nest_contours(hood.loops);
  std::vector<int> loop_of(l.cuts.size(), -1);
  for (std::size_t k = 0; k < hood.loop_cut.size(); ++k) loop_of[hood.loop_cut[k]] = static_cast<int>(k);
  for (std::size_t i = 0; i < l.cuts.size(); ++i) {
    Cut& c = l.cuts[i];
    SequenceProblem::Cut sc;
    c.entries = {Entry{}};
    sc.pierce = {c.pierce};
    sc.exit = {c.exit};
    if (c.loop) {
      ++r.closed_cuts;
      const int parent = nesting.parent[static_cast<std::size_t>(loop_of[i])];
      sc.parent = parent < 0 ? -1 : static_cast<int>(hood.loop_cut[static_cast<std::size_t>(parent)]);
    } else {
      // An open cut belongs to the smallest loop holding its pierce point.
      double area = kInf;
      for (std::size_t h : hood.holding(c.pierce)) {
        const double a = std::abs(signed_area(l.cuts[h].loop->contour));
        if (a < area) area = a, sc.parent = static_cast<int>(h);
      }
    }
    if (c.movable) {
      ++r.with_lead_in;
      if (o.order == CutOrder::optimise)
        for (const Entry& e : spread_entries(c, o.entry_candidates, o.corner_margin_mm)) {
          const Path moved = entered_at(c, e);
          if (!entry_ok(c, i, moved, hood, o.edge_clearance_mm)) continue;
          c.entries.push_back(e);
          sc.pierce.push_back(moved.pierce);
          sc.exit.push_back(moved.exit);
        }
    }
    sp.cuts.push_back(std::move(sc));
  }
  return sp;
}

void note_outer_first(const Program& p, const Layout& l, const SequenceProblem& sp, CutOrderReport& r) {
  for (std::size_t i = 0; i < sp.cuts.size() && !r.outer_first; ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (sp.cuts[i].parent == static_cast<int>(j)) {
        r.outer_first = std::make_pair(l.cuts[j].line, l.cuts[i].line);
        break;
      }
  if (r.outer_first && r.order == CutOrder::program)
    r.warnings.push_back(fmt::format("{}:{}: the contour cut at line {} encloses the cut at line {}, cut after it: a part "
                                     "freed from the sheet can tip or shift before its inner cuts are made (the cut order "
                                     "'optimise' cuts inner contours first)",
                                     p.source, r.outer_first->first, r.outer_first->first, r.outer_first->second));
}

void summarise(const Program& p, CutOrderReport& r) {
  Summary& s = r.summary;
  if (!r.reordered && r.order != CutOrder::program) {
    s.status = Status::infeasible;
    s.message = r.warnings.empty() ? "not reordered" : r.warnings.back();
  }
  s.brief = r.reordered
                ? fmt::format("{} cuts in {} order: rapid travel {:.1f} mm (as programmed {:.1f} mm, nearest neighbour "
                              "{:.1f} mm, no order below {:.1f} mm); {} pierce points moved",
                              r.cuts, to_string(r.order), r.travel_mm, r.programmed_travel_mm, r.nearest_travel_mm,
                              r.lower_bound_mm, r.moved_pierces)
                : fmt::format("{} cuts in the program's order", r.cuts);
  std::string full = fmt::format("cut order of {}: {}\n", p.source, s.brief);
  if (r.reordered) {
    full += fmt::format("  cuts {} ({} closed, {} with a lead-in), order (by their first line):", r.cuts, r.closed_cuts,
                        r.with_lead_in);
    constexpr std::size_t kShown = 40;
    for (std::size_t k = 0; k < std::min(kShown, r.sequence.size()); ++k)
      full += fmt::format(" {}", r.cut_lines[static_cast<std::size_t>(r.sequence[k])]);
    if (r.sequence.size() > kShown) full += fmt::format(" ... ({} more)", r.sequence.size() - kShown);
    full += "\n";
    if (r.lower_bound_mm > 0)
      full += fmt::format("  at most {:.1f} % above the shortest travel any order could have\n",
                          100.0 * (r.travel_mm / r.lower_bound_mm - 1.0));
  }
  for (const std::string& w : r.warnings) full += "  warning: " + w + "\n";
  s.full = std::move(full);
}

}  // namespace

OrderedProgram order_cuts(const Program& program, const CutOrderOptions& options) {
  options.validate();
  OrderedProgram out{program, {}};
  CutOrderReport& r = out.report;
  r.order = options.order;
  Layout l = layout(program);
  r.cuts = l.cuts.size();
  for (const Cut& c : l.cuts) r.cut_lines.push_back(c.line);
  if (!l.refused.empty()) {
    if (options.order != CutOrder::program)
      r.warnings.push_back(l.refused + ": the cuts are made in the program's order");
    summarise(program, r);
    return out;
  }
  const SequenceProblem sp = problem_of(l, options, r);
  note_outer_first(program, l, sp, r);
  const Sequence programmed = program_sequence(sp);
  const Sequence nearest = nearest_neighbour(sp, true);
  r.programmed_travel_mm = programmed.travel_mm;
  r.nearest_travel_mm = nearest.travel_mm;
  Sequence chosen = programmed;
  if (options.order == CutOrder::nearest) chosen = nearest;
  if (options.order == CutOrder::optimise) {
    SequenceOptions so;
    so.max_rounds = options.max_rounds;
    chosen = optimise(sp, so);
  }
  r.travel_mm = chosen.travel_mm;
  r.lower_bound_mm = travel_lower_bound(sp);
  r.sequence = chosen.order;
  for (int e : chosen.entry) r.moved_pierces += e != 0;
  if (options.order != CutOrder::program) {
    out.program = rebuild(program, l, chosen);
    r.reordered = true;
  }
  summarise(program, r);
  return out;
}

}  // namespace machplan::motion
