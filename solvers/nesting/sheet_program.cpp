#include "solvers/nesting/sheet_program.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/offset.h"
#include "engine/motion/make_job.h"
#include "solvers/motion/cut_order.h"

namespace machplan::nesting {

namespace {

using Eigen::Vector2d;

constexpr double kHalfPi = 0.5 * std::numbers::pi;
// Lead lengths tried, as fractions of the one asked for, before a lead is called cramped.
constexpr double kLeadFractions[] = {1.0, 0.75, 0.5, 0.3};

// One loop to cut, as it lies on the sheet (kerf applied) and in the direction of travel.
struct Loop {
  Contour contour;
  bool hole = false;
  Eigen::AlignedBox2d box;
};

Vector2d left_of(const Vector2d& t) { return {-t.y(), t.x()}; }

// The waste side of a cut travelling along t: left of it when the part is kept on the right.
Vector2d waste_side(const Vector2d& t, const SheetProgramOptions& o) { return o.part_on_right ? left_of(t) : -left_of(t); }

// The loops of one placed copy: its holes, then its outline.
void add_loops(const NestPart& part, const Placement& pl, const SheetProgramOptions& o, std::vector<Loop>& loops,
               std::vector<std::string>& warnings) {
  auto add = [&](const Contour& drawn, bool hole) {
    std::vector<Contour> pieces{place(drawn, pl)};
    if (o.kerf_mm > 0 && o.compensate_kerf) {
      OffsetResult r = offset_contour(pieces[0], hole ? -0.5 * o.kerf_mm : 0.5 * o.kerf_mm);
      if (r.vanished())
        warnings.push_back(fmt::format("{} copy {}: a hole of {:.1f} mm is narrower than the kerf ({:g} mm): cut as drawn",
                                       part.file, pl.copy + 1, bounding_box(drawn).sizes().minCoeff(), o.kerf_mm));
      else
        pieces = std::move(r.contours);
    }
    for (Contour& c : pieces) {
      // place() keeps outlines counter-clockwise and holes clockwise: the part on the left.
      if (o.part_on_right) c = c.reversed();
      const Eigen::AlignedBox2d box = bounding_box(c);
      loops.push_back({std::move(c), hole, box});
    }
  };
  for (const Contour& h : part.holes) add(h, true);
  add(part.outer, false);
}

// True when every span is an arc about one centre with one radius: a full circle.
bool is_circle(const Contour& c) {
  const Segment first = c.span(0);
  if (!first.is_arc()) return false;
  double sweep = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    if (!s.is_arc() || (s.center - first.center).norm() > 1e-6 || std::abs(s.radius - first.radius) > 1e-6) return false;
    sweep += s.sweep;
  }
  return std::abs(std::abs(sweep) - 2 * std::numbers::pi) < 1e-6;
}

// `c` started at parameter t of span i (the span split there).
Contour started_at(const Contour& c, std::size_t i, double t) {
  const std::size_t n = c.size();
  const Segment s = c.span(i);
  const double sweep = s.is_arc() ? s.sweep : 0.0;
  std::vector<Vector2d> v{point_at(s, t)};
  std::vector<double> b{std::tan((1 - t) * sweep / 4)};
  for (std::size_t k = 1; k < n; ++k) {
    v.push_back(c.vertices()[(i + k) % n]);
    b.push_back(c.bulges()[(i + k) % n]);
  }
  if (t > 1e-9) {
    v.push_back(s.start);
    b.push_back(std::tan(t * sweep / 4));
  }
  return Contour(std::move(v), std::move(b));
}

// Entry points (span, parameter), in order of preference: the middles of straight spans,
// longest first, then of arcs, longest first; a span longer than 4 `margin` also at its
// quarters (which are then at least `margin` from its ends).
std::vector<std::pair<std::size_t, double>> entries(const Contour& c, double margin) {
  struct E {
    bool arc;
    double len, t;
    std::size_t span;
  };
  std::vector<E> e;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Segment s = c.span(i);
    const double len = length(s);
    if (len < 1e-6) continue;
    e.push_back({s.is_arc(), len, 0.5, i});
    if (len >= 4 * margin + 1e-9)
      for (double t : {0.25, 0.75}) e.push_back({s.is_arc(), 0.5 * len, t, i});
  }
  std::stable_sort(e.begin(), e.end(), [](const E& a, const E& b) { return a.arc != b.arc ? !a.arc : a.len > b.len; });
  std::vector<std::pair<std::size_t, double>> out;
  for (const E& x : e) out.emplace_back(x.span, x.t);
  return out;
}

// A lead as built: its shape and length (Lead) and, for an arc, how far it turns (a quarter
// turn; half a turn for the lead from the centre of a small round hole).
struct LeadPath {
  Lead lead;
  double sweep = kHalfPi;
};

// A point of a lead at P (travel direction t there, waste side w), at fraction f of its way
// from P. A lead-in (out = false) comes from behind, a lead-out goes ahead.
Vector2d lead_point(const Vector2d& P, const Vector2d& t, const Vector2d& w, const LeadPath& l, bool out, double f) {
  const double L = l.lead.length_mm;
  if (l.lead.shape == LeadShape::line) return P + f * L * w;
  const double a = f * l.sweep;
  return P + L * w + L * (-std::cos(a) * w + (out ? 1.0 : -1.0) * std::sin(a) * t);
}

// Its distance from a straight contour, as a multiple of the lead's length.
double lead_depth(const LeadPath& l, double f) { return l.lead.shape == LeadShape::line ? f : 1.0 - std::cos(f * l.sweep); }

class LeadPlanner {
 public:
  LeadPlanner(const std::vector<Loop>& loops, const Sheet& sheet, const SheetProgramOptions& o)
      : loops_(loops), sheet_(sheet), o_(o) {
    if (!sheet.remnant) return;  // a remnant's edges and cut-outs: kept clear of as the other cuts
    edges_.push_back({sheet.remnant->outer, false, bounding_box(sheet.remnant->outer)});
    for (const Contour& h : sheet.remnant->holes) edges_.push_back({h, true, bounding_box(h)});
  }

  // How much room a lead of loop k has beyond the clearance (negative: too little), or -inf
  // when it crosses its own loop or leaves the sheet.
  // A lead must stay on the waste side, and at least half as far from its own contour as
  // beside a straight one (so its pierce point is not on the part's edge).
  double room(std::size_t k, const Vector2d& P, const Vector2d& t, const LeadPath& lead, bool out) const {
    const Vector2d w = waste_side(t, o_);
    double least = std::numeric_limits<double>::infinity();
    for (double f : {0.25, 0.5, 0.75, 1.0}) {
      const Vector2d q = lead_point(P, t, w, lead, out, f);
      if (q.x() < 0 || q.y() < 0 || q.x() > sheet_.width_mm || q.y() > sheet_.height_mm) return -kInf;
      if (distance(loops_[k].contour, q) < 0.5 * lead_depth(lead, f) * lead.lead.length_mm - 1e-6) return -kInf;
      if (contains(loops_[k].contour, q) != loops_[k].hole) return -kInf;
      least = std::min(least, others_distance(k, q, least));
    }
    return least - o_.clearance_mm;
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();

  // The distance from q to the nearest loop but k (or remnant edge), when below `cap`.
  double others_distance(std::size_t k, const Vector2d& q, double cap) const {
    for (std::size_t j = 0; j < loops_.size(); ++j) {
      if (j == k || loops_[j].box.exteriorDistance(q) >= cap) continue;
      cap = std::min(cap, distance(loops_[j].contour, q));
    }
    for (const Loop& e : edges_)
      if (e.box.exteriorDistance(q) < cap) cap = std::min(cap, distance(e.contour, q));
    return cap;
  }

  const std::vector<Loop>& loops_;
  std::vector<Loop> edges_;
  const Sheet& sheet_;
  const SheetProgramOptions& o_;
};

class Builder {
 public:
  explicit Builder(const SheetProgramOptions& o) : o_(o) {}

  void rapid(const Vector2d& to) { add(Move::Kind::rapid, to); }
  void torch(bool on) {
    Move m;
    m.kind = on ? Move::Kind::torch_on : Move::Kind::torch_off;
    m.spindle_speed = on ? 1.0 : 0.0;
    m.line = ++line_;
    p.moves.push_back(m);
  }
  void line(const Vector2d& to) { add(Move::Kind::line, to); }
  void arc(const Vector2d& to, const Vector2d& centre, bool clockwise) {
    add(Move::Kind::arc, to);
    p.moves.back().center = centre;
    p.moves.back().clockwise = clockwise;
  }
  void span(const Segment& s) {
    if (s.is_arc()) arc(s.end, s.center, s.sweep < 0);
    else line(s.end);
  }
  // The lead at P (tangent t, waste side w) from its free end to P, or from P out.
  void lead(const Vector2d& P, const Vector2d& t, const Vector2d& w, const LeadPath& l, bool out) {
    if (l.lead.length_mm <= 0) return;
    const Vector2d end = out ? lead_point(P, t, w, l, true, 1.0) : P;
    if (l.lead.shape == LeadShape::line) return line(end);
    arc(end, P + l.lead.length_mm * w, cross(t, w) < 0);
  }
  Vector2d at() const { return p.moves.empty() ? Vector2d::Zero() : Vector2d(p.moves.back().end.head<2>()); }

  Program p;

 private:
  void add(Move::Kind kind, const Vector2d& to) {
    Move m;
    m.kind = kind;
    m.end = Eigen::Vector3d(to.x(), to.y(), 0.0);
    if (kind != Move::Kind::rapid) m.feed_mm_per_min = o_.feed_mm_per_min;
    m.line = ++line_;
    p.moves.push_back(m);
  }

  const SheetProgramOptions& o_;
  int line_ = 0;
};

// The direction of travel at the start of `c`.
Vector2d start_direction(const Contour& c) { return start_tangent(c.span(0)).normalized(); }

// The lead from the centre of round hole k (entered at P): a line of its radius, or half a
// circle of half its radius; nothing for another loop.
std::optional<LeadPath> centre_lead(const std::vector<Loop>& loops, std::size_t k, const Lead& l) {
  const Contour& c = loops[k].contour;
  if (!loops[k].hole || l.length_mm <= 0 || !is_circle(c)) return std::nullopt;
  const double r = c.span(0).radius;
  if (l.shape == LeadShape::line) return LeadPath{{l.shape, std::min(l.length_mm, r)}};
  return LeadPath{{l.shape, std::min(l.length_mm, 0.5 * r)}, 2 * kHalfPi};
}

// The lead `l` at P (tangent t) of loop k, shortened until it has room; counted in `sp`. A
// lead-in of a round hole too small for it starts at the hole's centre instead.
LeadPath fitted(const LeadPlanner& planner, const std::vector<Loop>& loops, std::size_t k, const Vector2d& P, const Vector2d& t,
                const Lead& l, bool out, SheetProgram& sp) {
  if (l.length_mm <= 0) return {l};
  if (planner.room(k, P, t, {l}, out) >= 0) return {l};
  if (!out)
    if (const auto centre = centre_lead(loops, k, l)) return *centre;
  for (double f : kLeadFractions) {
    const LeadPath s{{l.shape, l.length_mm * f}};
    if (planner.room(k, P, t, s, out) >= 0) {
      ++sp.shortened;
      return s;
    }
  }
  ++sp.cramped;
  return {{l.shape, l.length_mm * kLeadFractions[std::size(kLeadFractions) - 1]}};
}

// Where loop k is entered: the loop started there, and the lead-in when it is set by the rule for
// holes with no room (a line from the middle of the hole's box).
struct Entry {
  Contour loop;
  std::optional<LeadPath> lead;
};

// Loop k entered where its lead-in has room (see the file comment). A round hole with no room
// is entered anywhere (its lead comes from its centre, `fitted`); another hole with no room,
// where a line from the middle of its box meets its edge, when that line has room.
Entry entered(const LeadPlanner& planner, const std::vector<Loop>& loops, std::size_t k, const SheetProgramOptions& o) {
  const Contour& c = loops[k].contour;
  const auto cand = entries(c, o.corner_margin_mm);
  if (o.lead_in.length_mm <= 0 || cand.empty()) return {c, std::nullopt};
  auto room = [&](std::pair<std::size_t, double> e, const LeadPath& l) {
    const Segment s = c.span(e.first);
    const Vector2d P = point_at(s, e.second);
    return planner.room(k, P, tangent_at(s, P).normalized(), l, false);
  };
  std::pair<std::size_t, double> best = cand.front();
  double best_room = -std::numeric_limits<double>::infinity();
  for (double f : kLeadFractions) {
    const LeadPath l{{o.lead_in.shape, o.lead_in.length_mm * f}};
    for (const auto& e : cand) {
      const double r = room(e, l);
      if (r >= 0) return {started_at(c, e.first, e.second), std::nullopt};
      if (f == kLeadFractions[std::size(kLeadFractions) - 1] && r > best_room) best_room = r, best = e;
    }
    if (f == 1.0 && centre_lead(loops, k, o.lead_in)) break;  // a round hole: from its centre
  }
  if (loops[k].hole && !is_circle(c)) {
    const Vector2d q = loops[k].box.center();
    const ContourPoint cp = closest_point(c, q);
    const Segment s = c.span(cp.span);
    const std::pair<std::size_t, double> e{cp.span, parameter_at(s, cp.point)};
    const LeadPath line{{LeadShape::line, cp.distance}};
    if (contains(c, q) && cp.distance > 1e-3 && room(e, line) >= 0) return {started_at(c, e.first, e.second), line};
  }
  return {started_at(c, best.first, best.second), std::nullopt};
}

// The cut of loop k: rapid to the pierce point, lead-in, the loop, overcut, lead-out.
void add_cut(Builder& b, const LeadPlanner& planner, const std::vector<Loop>& loops, std::size_t k,
             const SheetProgramOptions& o, SheetProgram& sp) {
  const Entry entry = entered(planner, loops, k, o);
  const Contour& c = entry.loop;
  const Vector2d P = c.vertices().front();
  const Vector2d t = start_direction(c);
  const Vector2d w = waste_side(t, o);
  const LeadPath in = entry.lead ? *entry.lead : fitted(planner, loops, k, P, t, o.lead_in, false, sp);
  b.rapid(in.lead.length_mm > 0 ? lead_point(P, t, w, in, false, 1.0) : P);
  b.torch(true);
  b.lead(P, t, w, in, false);
  const bool circle = is_circle(c);
  if (circle) {
    const Segment s = c.span(0);
    b.arc(P, s.center, s.sweep < 0);
  } else {
    for (std::size_t i = 0; i < c.size(); ++i) b.span(c.span(i));
  }
  // The overcut: the loop again from its start, for overcut_mm (at most half of it).
  double left = std::min(o.overcut_mm, 0.5 * perimeter(c));
  Vector2d tq = t;
  for (std::size_t i = 0; left > 1e-9 && i < c.size(); ++i) {
    const Segment s = c.span(i);
    const double len = length(s);
    const double f = std::min(1.0, left / std::max(len, 1e-12));
    const Vector2d end = point_at(s, f);
    if (s.is_arc()) b.arc(end, s.center, s.sweep < 0);
    else b.line(end);
    tq = tangent_at(s, end).normalized();
    left -= f * len;
  }
  const Vector2d Q = b.at();
  const Vector2d wq = waste_side(tq, o);
  b.lead(Q, tq, wq, fitted(planner, loops, k, Q, tq, o.lead_out, true, sp), true);
  b.torch(false);
  ++sp.cuts;
}

// The sweep of arc move m from `from`, rad, signed (counter-clockwise positive), as make_job
// reads it (a full turn when it ends where it starts).
double arc_sweep(const Move& m, const Vector2d& from) {
  double sweep = 0.0;
  for (const Segment& s : motion::move_segments(m, from)) sweep += s.sweep;
  return sweep;
}

// Consecutive arcs about one centre, one way round, joined into one arc of at most a turn: a
// round hole whose entry the cut order moved is one full circle again (QtPlasmaC's hole rules
// see a hole only then). Events keep their places.
void join_arcs(Program& p) {
  std::vector<Move> out;
  std::vector<std::size_t> index(p.moves.size() + 1);
  Vector2d at = p.start.head<2>(), from = at;
  double sweep = 0.0;
  for (std::size_t i = 0; i < p.moves.size(); ++i) {
    const Move& m = p.moves[i];
    const bool arc = m.kind == Move::Kind::arc && m.plane == Move::Plane::xy && m.turns == 0;
    const double r = arc ? (at - m.center).norm() : 0.0;
    Move* last = out.empty() ? nullptr : &out.back();
    const bool joins = arc && last && last->kind == Move::Kind::arc && last->plane == Move::Plane::xy && last->turns == 0 &&
                       last->clockwise == m.clockwise && (last->center - m.center).norm() < 1e-7 &&
                       std::abs((from - m.center).norm() - r) < 1e-7 && std::abs(sweep + arc_sweep(m, at)) <= 2 * std::numbers::pi + 1e-9 &&
                       last->feed_mm_per_min == m.feed_mm_per_min && (at - from).norm() > 1e-9;
    index[i] = joins ? out.size() - 1 : out.size();
    if (joins) {
      sweep += arc_sweep(m, at);
      last->end = m.end;
    } else {
      from = at;
      sweep = arc ? arc_sweep(m, at) : 0.0;
      out.push_back(m);
    }
    if (is_motion(m)) at = m.end.head<2>();
  }
  index[p.moves.size()] = out.size();
  for (ProgramEvent& e : p.events) e.before_move = index[e.before_move];
  p.moves = std::move(out);
}

// M62 P2 before and M63 P2 after every cut of a full circle of at most `diameter_mm`: THC held
// off there, where the slowed torch would read a long arc as too high and dive.
void hold_thc_in_small_holes(Program& p, double diameter_mm) {
  std::vector<ProgramEvent> added;
  Vector2d at = p.start.head<2>();
  std::size_t on = 0;
  bool small = false;
  for (std::size_t i = 0; i < p.moves.size(); ++i) {
    const Move& m = p.moves[i];
    if (m.kind == Move::Kind::torch_on) on = i, small = false;
    if (m.kind == Move::Kind::arc && (m.end.head<2>() - at).norm() < 1e-9 && 2 * (at - m.center).norm() <= diameter_mm + 1e-9)
      small = true;
    if (m.kind == Move::Kind::torch_off && small) {
      for (auto [index, value] : {std::pair{on, 1.0}, {i + 1, 0.0}}) {
        ProgramEvent e;
        e.kind = ProgramEvent::Kind::digital_output;
        e.number = 2;
        e.value = value;
        e.synchronized = true;
        e.before_move = index;
        added.push_back(e);
      }
    }
    if (is_motion(m)) at = m.end.head<2>();
  }
  added.insert(added.end(), p.events.begin(), p.events.end());
  std::stable_sort(added.begin(), added.end(), [](const ProgramEvent& a, const ProgramEvent& b) { return a.before_move < b.before_move; });
  p.events = std::move(added);
}

ProgramEvent event(ProgramEvent::Kind kind, int number, double value, int mode = 0, std::string text = {}) {
  ProgramEvent e;
  e.kind = kind;
  e.number = number;
  e.value = value;
  e.mode = mode;
  e.text = std::move(text);
  return e;
}

// QtPlasmaC's material and hole words, at the top of the program.
std::vector<ProgramEvent> preamble(const SheetProgramOptions& o) {
  using K = ProgramEvent::Kind;
  std::vector<ProgramEvent> e;
  if (o.material > 0) {
    e.push_back(event(K::user_m_code, 190, o.material));
    e.push_back(event(K::wait_input, 3, 1.0, 3));
  }
  if (o.hole_mode > 0) {
    e.push_back(event(K::parameter, 0, o.hole_mode, 21, "holes"));
    e.push_back(event(K::parameter, 0, o.hole_diameter_mm, 21, "h_diameter"));
    e.push_back(event(K::parameter, 0, o.hole_velocity_pct, 21, "h_velocity"));
    e.push_back(event(K::parameter, 0, o.hole_overcut_mm, 21, "oclength"));
  }
  return e;
}

}  // namespace

const char* to_string(LeadShape s) { return s == LeadShape::line ? "line" : "arc"; }

std::optional<LeadShape> lead_shape_from(std::string_view name) {
  if (name == "line") return LeadShape::line;
  if (name == "arc") return LeadShape::arc;
  return std::nullopt;
}

void SheetProgramOptions::validate() const {
  require_field((feed_mm_per_min > 0 && feed_mm_per_min <= 100000) || feed_mm_per_min == kMaterialCutFeed,
                "feed_mm_per_min", feed_mm_per_min, "must be in (0, 100000] mm/min");
  require_field(lead_in.length_mm >= 0 && lead_in.length_mm <= 100, "lead_in.length_mm", lead_in.length_mm, "must be in [0, 100] mm");
  require_field(lead_out.length_mm >= 0 && lead_out.length_mm <= 100, "lead_out.length_mm", lead_out.length_mm,
                "must be in [0, 100] mm");
  require_field(overcut_mm >= 0 && overcut_mm <= 50, "overcut_mm", overcut_mm, "must be in [0, 50] mm");
  require_field(kerf_mm >= 0 && kerf_mm <= 20, "kerf_mm", kerf_mm, "must be in [0, 20] mm");
  require_field(clearance_mm > 0 && clearance_mm <= 100, "clearance_mm", clearance_mm, "must be in (0, 100] mm");
  require_field(corner_margin_mm >= 0 && corner_margin_mm <= 100, "corner_margin_mm", corner_margin_mm, "must be in [0, 100] mm");
  require_field(material >= 0 && material <= 999999, "material", material, "must be in 0 .. 999999");
  require_field(hole_mode >= 0 && hole_mode <= 4, "hole_mode", hole_mode, "must be in 0 .. 4");
  require_field(hole_diameter_mm > 0 && hole_diameter_mm <= 1000, "hole_diameter_mm", hole_diameter_mm, "must be in (0, 1000] mm");
  require_field(hole_velocity_pct >= 1 && hole_velocity_pct <= 100, "hole_velocity_pct", hole_velocity_pct, "must be in [1, 100] %");
  require_field(hole_overcut_mm >= 0 && hole_overcut_mm <= 50, "hole_overcut_mm", hole_overcut_mm, "must be in [0, 50] mm");
}

SheetProgram sheet_program(const std::vector<NestPart>& parts, const std::vector<Placement>& placements, int sheet,
                           const Sheet& geometry, const SheetProgramOptions& o) {
  o.validate();
  SheetProgram sp;
  std::vector<Loop> loops;
  for (const Placement& pl : placements)
    if (pl.sheet == sheet) add_loops(parts[pl.part], pl, o, loops, sp.warnings);
  const LeadPlanner planner(loops, geometry, o);
  Builder b(o);
  b.p.source = fmt::format("sheet {}", sheet + 1);
  for (std::size_t k = 0; k < loops.size(); ++k) add_cut(b, planner, loops, k, o, sp);
  b.rapid(Vector2d::Zero());
  b.p.ends_with_program_end = true;
  motion::CutOrderOptions order;
  order.edge_clearance_mm = o.clearance_mm;
  order.corner_margin_mm = o.corner_margin_mm;
  motion::OrderedProgram ordered = motion::order_cuts(b.p, order);
  if (ordered.report.summary.done()) {
    sp.program = std::move(ordered.program);
    join_arcs(sp.program);
    if (o.hole_mode > 0) hold_thc_in_small_holes(sp.program, o.hole_diameter_mm);
  } else {
    sp.program = std::move(b.p);
    sp.warnings.push_back("cuts in the nest's order: " + ordered.report.summary.message);
  }
  sp.order_summary = ordered.report.summary.done() ? ordered.report.summary.brief_report() : "";
  std::vector<ProgramEvent> first = preamble(o);
  first.insert(first.end(), sp.program.events.begin(), sp.program.events.end());
  sp.program.events = std::move(first);
  return sp;
}

}  // namespace machplan::nesting
