#include "engine/geometry/offset.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/span_index.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

Vector2d unit(double angle) { return {std::cos(angle), std::sin(angle)}; }

Segment make_line(const Vector2d& a, const Vector2d& b) {
  Segment s;
  s.start = a;
  s.end = b;
  return s;
}

// An arc given by centre, radius, start angle and sweep; end points computed from them.
Segment make_arc(const Vector2d& c, double r, double start_angle, double sweep) {
  Segment s;
  s.kind = Segment::Kind::arc;
  s.center = c;
  s.radius = r;
  s.start_angle = std::atan2(std::sin(start_angle), std::cos(start_angle));
  s.sweep = sweep;
  s.start = c + r * unit(start_angle);
  s.end = c + r * unit(start_angle + sweep);
  return s;
}

// The piece of `s` between parameters t0 < t1 whose end points are p0, p1 (exact values
// shared with the neighbouring pieces).
Segment sub_segment(const Segment& s, double t0, double t1, const Vector2d& p0, const Vector2d& p1) {
  if (!s.is_arc()) return make_line(p0, p1);
  Segment r = s;
  r.start_angle = s.start_angle + t0 * s.sweep;
  r.sweep = (t1 - t0) * s.sweep;
  r.start = p0;
  r.end = p1;
  return r;
}

double bulge_of(const Segment& s) { return s.is_arc() ? std::tan(s.sweep / 4.0) : 0.0; }

// The offset of one span of the counter-clockwise working contour.
struct SpanOffset {
  bool has_segment = true;  // false: an arc that collapsed to its centre
  bool collapsed = false;   // the arc's offset radius would be <= tolerance
  double offset_radius = 0.0;
  Segment seg;
  Vector2d start = Vector2d::Zero(), end = Vector2d::Zero();
};

// How a corner between the offsets of span j and span j+1 is closed.
struct Corner {
  enum class Kind { none, arc, trim } kind = Kind::none;
  Segment arc;                      // Kind::arc (forward or backward)
  Vector2d at = Vector2d::Zero();   // Kind::trim: the intersection
  double t_before = 1.0, t_after = 0.0;  // its parameters on span j's and span j+1's offset
};

// One piece of the raw offset: a span offset or a corner arc.
struct Raw {
  Segment seg;
  std::size_t span = 0;  // index in the cleaned contour (corner: the span ending there)
  bool corner = false;
};

struct Split {
  double t;
  Vector2d p;
};

struct Piece {
  Segment seg;
  std::size_t raw = 0;
  double t0 = 0.0, t1 = 1.0;
};

Eigen::AlignedBox2d grown_box(const Segment& s, double by) {
  const auto b = bounding_box(s);
  return {b.min() - Vector2d::Constant(by), b.max() + Vector2d::Constant(by)};
}

}  // namespace

void OffsetOptions::validate() const {
  if (!std::isfinite(tolerance_mm) || !(tolerance_mm > 0.0) || tolerance_mm > 0.1)
    throw InputError::field("tolerance_mm", fmt::format("is {}, must be finite, > 0 and <= 0.1 mm", tolerance_mm));
}

const char* to_string(OffsetProblem::Kind k) {
  switch (k) {
    case OffsetProblem::Kind::arc_collapsed: return "arc_collapsed";
    case OffsetProblem::Kind::feature_too_small: return "feature_too_small";
    case OffsetProblem::Kind::contour_vanished: return "contour_vanished";
    case OffsetProblem::Kind::vertex_dropped: return "vertex_dropped";
    case OffsetProblem::Kind::gap_too_narrow: return "gap_too_narrow";
  }
  return "?";
}

namespace {

// Step 1 of offset_contour: the counter-clockwise working copy without spans shorter than the
// tolerance, and where each of its spans came from.
struct WorkingContour {
  bool ccw = true;
  Contour clean;
  std::vector<std::size_t> to_orig;  // cleaned span index -> original span index
};

WorkingContour working_copy(const Contour& contour, bool ccw, double tol) {
  const std::size_t n = contour.size();
  const Contour work = ccw ? contour : contour.reversed();
  WorkingContour w;
  w.ccw = ccw;
  std::vector<Vector2d> cv;
  std::vector<double> cb;
  for (std::size_t k = 0; k < n; ++k) {
    if (length(work.span(k)) <= tol) continue;
    cv.push_back(work.vertices()[k]);
    cb.push_back(work.bulges()[k]);
    w.to_orig.push_back(ccw ? k : n - 1 - k);
  }
  w.clean = Contour(cv, cb);
  return w;
}

// Step 2: each span offset by d on its own (an arc whose offset radius falls to the tolerance
// collapses: to its mirror image, pruned later, or to its centre).
std::vector<SpanOffset> offset_spans(const std::vector<Segment>& spans, double d, double tol) {
  std::vector<SpanOffset> off(spans.size());
  for (std::size_t j = 0; j < spans.size(); ++j) {
    const Segment& s = spans[j];
    SpanOffset& o = off[j];
    if (!s.is_arc()) {
      const Vector2d t = (s.end - s.start).normalized(), nrm(t.y(), -t.x());
      o.seg = make_line(s.start + d * nrm, s.end + d * nrm);
    } else {
      const double rr = s.radius + (s.sweep > 0 ? d : -d);
      o.offset_radius = rr;
      if (rr > tol) {
        o.seg = make_arc(s.center, rr, s.start_angle, s.sweep);
      } else {
        o.collapsed = true;
        if (rr < -tol) {
          o.seg = make_arc(s.center, -rr, s.start_angle + kPi, s.sweep);  // mirror image, pruned later
        } else {
          o.has_segment = false;
          o.seg = make_line(s.center, s.center);
        }
      }
    }
    o.start = o.seg.start;
    o.end = o.seg.end;
  }
  return off;
}

// Closes corner j with an arc of radius |d| round the vertex, forward or backward by theta.
void set_corner_arc(Corner& c, const std::vector<Segment>& spans, const std::vector<SpanOffset>& off, std::size_t j,
                    double ad, double theta) {
  const std::size_t k = (j + 1) % spans.size();
  const Vector2d v = spans[k].start;
  const Vector2d e = off[j].end, s = off[k].start;
  Segment a = make_arc(v, ad, std::atan2(e.y() - v.y(), e.x() - v.x()), theta);
  a.start = e;
  a.end = s;
  c.kind = Corner::Kind::arc;
  c.arc = a;
}

// A concave corner: where the offsets of spans j and k meet nearest the corner, if they do.
std::optional<Corner> trim_corner(const SpanOffset& oj, const SpanOffset& ok, double eps) {
  std::optional<Corner> best;
  if (!oj.has_segment || !ok.has_segment) return best;
  const Intersection hit = intersect(oj.seg, ok.seg, eps);
  if (hit.overlap) return best;
  const double lj = length(oj.seg), lk = length(ok.seg);
  double best_cut = 0.0;
  for (const auto& p : hit.points) {
    const double tj = parameter_at(oj.seg, p), tk = parameter_at(ok.seg, p);
    const double cut = (1.0 - tj) * lj + tk * lk;
    if (!best || cut < best_cut) {
      best_cut = cut;
      best = Corner{Corner::Kind::trim, {}, p, tj, tk};
    }
  }
  return best;
}

// Step 3: corner j joins the offset of span j to that of span j+1 at their vertex: nothing
// (tangent continuous: the next offset's start is snapped), an arc (convex, or no trim point),
// or a trim at the offsets' intersection (concave).
std::vector<Corner> close_corners(const std::vector<Segment>& spans, std::vector<SpanOffset>& off, double d,
                                  double tol, double eps) {
  const std::size_t m = spans.size();
  const double ad = std::abs(d);
  std::vector<Corner> corners(m);
  std::vector<double> turn(m);
  for (std::size_t j = 0; j < m; ++j) {
    const std::size_t k = (j + 1) % m;
    const Vector2d t1 = end_tangent(spans[j]), t2 = start_tangent(spans[k]);
    const double cr = cross(t1, t2), dt = t1.dot(t2);
    double theta = std::atan2(cr, dt);
    if (dt < 0 && std::abs(cr) <= 1e-12) theta = d > 0 ? kPi : -kPi;  // a cusp: go round its tip
    turn[j] = theta;
    Corner& c = corners[j];
    if ((off[j].end - off[k].start).norm() <= tol) {
      c.kind = Corner::Kind::none;  // tangent continuous: snap the next offset's start
      off[k].start = off[j].end;
      off[k].seg.start = off[j].end;
      if (!off[k].has_segment) off[k].end = off[k].seg.end = off[j].end;
      continue;
    }
    if (d * theta > 0) {
      set_corner_arc(c, spans, off, j, ad, theta);
      continue;
    }
    if (const std::optional<Corner> best = trim_corner(off[j], off[k], eps))
      c = *best;
    else
      set_corner_arc(c, spans, off, j, ad, theta);
  }
  // A span offset trimmed at both ends past itself is wholly invalid: its corners fall back
  // to arcs (removing trims only lengthens the other spans, so one pass is enough).
  std::vector<bool> revert(m, false);
  for (std::size_t j = 0; j < m; ++j) {
    if (!off[j].has_segment) continue;
    const std::size_t before = (j + m - 1) % m;
    const double lo = corners[before].kind == Corner::Kind::trim ? corners[before].t_after : 0.0;
    const double hi = corners[j].kind == Corner::Kind::trim ? corners[j].t_before : 1.0;
    const double len = length(off[j].seg);
    if ((hi - lo) * len <= tol) revert[before] = revert[j] = true;
  }
  for (std::size_t j = 0; j < m; ++j)
    if (revert[j] && corners[j].kind == Corner::Kind::trim) set_corner_arc(corners[j], spans, off, j, ad, turn[j]);
  return corners;
}

// The raw offset as one closed chain: each span's offset between its trims, then its corner arc.
std::vector<Raw> raw_offset(const std::vector<SpanOffset>& off, const std::vector<Corner>& corners, double tol) {
  const std::size_t m = off.size();
  std::vector<Raw> raw;
  for (std::size_t j = 0; j < m; ++j) {
    const std::size_t before = (j + m - 1) % m;
    if (off[j].has_segment) {
      const bool trim_lo = corners[before].kind == Corner::Kind::trim;
      const bool trim_hi = corners[j].kind == Corner::Kind::trim;
      const double lo = trim_lo ? corners[before].t_after : 0.0, hi = trim_hi ? corners[j].t_before : 1.0;
      const Vector2d p0 = trim_lo ? corners[before].at : off[j].start;
      const Vector2d p1 = trim_hi ? corners[j].at : off[j].end;
      raw.push_back({sub_segment(off[j].seg, lo, hi, p0, p1), j, false});
    }
    if (corners[j].kind == Corner::Kind::arc) raw.push_back({corners[j].arc, j, true});
  }
  const std::size_t nr = raw.size();
  for (std::size_t i = 0; i < nr; ++i)
    MACHPLAN_ASSERT((raw[i].seg.end - raw[(i + 1) % nr].seg.start).norm() <= 4 * tol,
                    "raw offset piece {} ends {} mm from the next one's start", i,
                    (raw[i].seg.end - raw[(i + 1) % nr].seg.start).norm());
  return raw;
}

// Step 4: the raw offset split at its self-intersections.
std::vector<Piece> split_at_crossings(const std::vector<Raw>& raw, double tol, double eps) {
  const std::size_t nr = raw.size();
  std::vector<std::vector<Split>> splits(nr);
  std::vector<Eigen::AlignedBox2d> boxes;
  for (const auto& r : raw) boxes.push_back(grown_box(r.seg, 2 * eps));
  // Only pairs whose boxes meet (a sweep over the boxes), in a fixed order so that the
  // splits, and therefore the result, do not depend on the sweep's order.
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) { pairs.push_back({std::min(a, b), std::max(a, b)}); });
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [a, b] : pairs) {
    const Intersection hit = intersect(raw[a].seg, raw[b].seg, eps);
    for (const auto& p : hit.points) {
      bool at_joint = false;
      if (b == a + 1) at_joint = at_joint || (p - raw[a].seg.end).norm() <= tol;
      if (a == 0 && b == nr - 1) at_joint = at_joint || (p - raw[b].seg.end).norm() <= tol;
      if (at_joint) continue;
      splits[a].push_back({parameter_at(raw[a].seg, p), p});
      splits[b].push_back({parameter_at(raw[b].seg, p), p});
    }
  }
  std::vector<Piece> pieces;
  for (std::size_t i = 0; i < nr; ++i) {
    auto& sp = splits[i];
    std::sort(sp.begin(), sp.end(), [](const Split& x, const Split& y) { return x.t < y.t; });
    const Segment& s = raw[i].seg;
    Split last{0.0, s.start};
    for (const auto& x : sp) {
      if ((x.p - last.p).norm() <= tol || (x.p - s.end).norm() <= tol || x.t <= last.t) continue;
      pieces.push_back({sub_segment(s, last.t, x.t, last.p, x.p), i, last.t, x.t});
      last = x;
    }
    pieces.push_back({sub_segment(s, last.t, 1.0, last.p, s.end), i, last.t, 1.0});
  }
  return pieces;
}

// Step 5: the pieces at distance >= |d| from the contour, on the correct side.
std::vector<std::size_t> pieces_at_distance(const std::vector<Piece>& pieces, const Contour& clean, double d,
                                            double tol) {
  const bool want_inside = d < 0;
  const double ad = std::abs(d);
  const SpanIndex clean_index({clean});  // distance and side in O(log n) instead of O(n)
  std::vector<std::size_t> kept;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    bool ok = true;
    for (double f : {0.25, 0.5, 0.75}) {
      const Vector2d q = point_at(pieces[p].seg, f);
      if (clean_index.nearest(q).distance < ad - tol || (clean_index.winding(q) != 0) != want_inside) {
        ok = false;
        break;
      }
    }
    if (ok) kept.push_back(p);
  }
  return kept;
}

// The kept pieces of step 6 and how to find the one that continues a chain.
struct KeptPieces {
  const std::vector<Piece>& pieces;
  const std::vector<std::size_t>& kept;
  std::vector<std::pair<double, std::size_t>> by_x;  // kept pieces by the x of their start
  std::vector<bool> used;

  KeptPieces(const std::vector<Piece>& p, const std::vector<std::size_t>& k) : pieces(p), kept(k), used(k.size(), false) {
    for (std::size_t q = 0; q < kept.size(); ++q) by_x.push_back({pieces[kept[q]].seg.start.x(), q});
    std::sort(by_x.begin(), by_x.end());
  }
  const Piece& at(std::size_t q) const { return pieces[kept[q]]; }

  // The unused piece starting within ctol of `end`: the one after `cur` if it does, else the
  // nearest (ties to the last).
  std::optional<std::size_t> next(std::size_t cur, const Vector2d& end, double ctol) const {
    std::optional<std::size_t> found;
    const std::size_t follow = (cur + 1) % kept.size();
    if (!used[follow] && (at(follow).seg.start - end).norm() <= ctol) return follow;
    double best = ctol;
    auto it = std::lower_bound(by_x.begin(), by_x.end(), std::make_pair(end.x() - ctol, std::size_t{0}));
    for (; it != by_x.end() && it->first <= end.x() + ctol; ++it) {
      const std::size_t q = it->second;
      if (used[q]) continue;
      const double g = (at(q).seg.start - end).norm();
      if (g < best || (g == best && (!found || q > *found))) {  // as the former scan: ties to the last
        best = g;
        found = q;
      }
    }
    return found;
  }
};

// Neighbouring pieces of one raw piece that a crossing cut apart, joined again.
std::vector<Piece> merge_cut_pieces(const std::vector<std::size_t>& chain, const KeptPieces& kp,
                                    const std::vector<Raw>& raw) {
  std::vector<Piece> merged;
  for (std::size_t q : chain) {
    const Piece& pc = kp.at(q);
    if (!merged.empty() && merged.back().raw == pc.raw && merged.back().t1 == pc.t0) {
      Piece& b = merged.back();
      b.seg = sub_segment(raw[pc.raw].seg, b.t0, pc.t1, b.seg.start, pc.seg.end);
      b.t1 = pc.t1;
    } else {
      merged.push_back(pc);
    }
  }
  if (merged.size() > 1 && merged.back().raw == merged.front().raw && merged.back().t1 == merged.front().t0) {
    Piece& b = merged.back();
    b.seg = sub_segment(raw[b.raw].seg, b.t0, merged.front().t1, b.seg.start, merged.front().seg.end);
    b.t1 = merged.front().t1;
    merged.erase(merged.begin());
  }
  return merged;
}

// Step 6: the kept pieces chained into closed contours (slivers dropped), with the original
// span of each of their spans; `surviving` gets the length of each span's own offset that
// survives.
void chain_offset_pieces(const std::vector<Piece>& pieces, const std::vector<std::size_t>& kept,
                         const std::vector<Raw>& raw, const WorkingContour& w, double d, double tol,
                         OffsetResult& result, std::vector<double>& surviving) {
  const double ctol = 2 * tol;
  KeptPieces kp(pieces, kept);
  for (std::size_t first = 0; first < kept.size(); ++first) {
    if (kp.used[first]) continue;
    std::vector<std::size_t> chain{first};
    kp.used[first] = true;
    const Vector2d origin = kp.at(first).seg.start;
    while (true) {
      const Vector2d at = kp.at(chain.back()).seg.end;
      if ((at - origin).norm() <= ctol) break;
      const std::optional<std::size_t> next = kp.next(chain.back(), at, ctol);
      // Where the offset region pinches to zero width (an arc whose radius equals |d| between
      // two corners, spans that touch at the offset distance), the tolerance tests can keep a
      // piece on one side of the pinch and drop its twin: the pieces then do not close. That
      // is refused with the place named, never guessed.
      if (!next)
        throw InputError("", 0,
                         fmt::format("offset by {} mm: the offset region pinches to zero width near ({:.4f}, {:.4f}) "
                                     "and its pieces do not close; offset by a slightly different distance",
                                     d, at.x(), at.y()));
      kp.used[*next] = true;
      chain.push_back(*next);
    }
    const std::vector<Piece> merged = merge_cut_pieces(chain, kp, raw);
    std::vector<Vector2d> vs;
    std::vector<double> bs;
    std::vector<std::size_t> src;
    for (const auto& pc : merged) {
      if (length(pc.seg) <= tol) continue;
      vs.push_back(pc.seg.start);
      bs.push_back(bulge_of(pc.seg));
      src.push_back(w.to_orig[raw[pc.raw].span]);
    }
    if (vs.size() < 2) continue;
    Contour out(std::move(vs), std::move(bs));
    if (!(std::abs(signed_area(out)) > tol * perimeter(out))) continue;  // a sliver
    for (const auto& pc : merged)
      if (!raw[pc.raw].corner) surviving[raw[pc.raw].span] += length(pc.seg);
    if (!w.ccw) {
      out = out.reversed();
      std::reverse(src.begin(), src.end());
    }
    result.contours.push_back(std::move(out));
    result.source_spans.push_back(std::move(src));
  }
}

// The problems, named by original span: collapsed arcs, a vanished contour, and each run of
// spans none of whose offset survives.
void report_offset_problems(const std::vector<Segment>& spans, const std::vector<SpanOffset>& off,
                            const std::vector<double>& surviving, const WorkingContour& w, std::size_t n, double d,
                            double tol, OffsetResult& result) {
  const std::size_t m = spans.size();
  const double ad = std::abs(d);
  const auto& to_orig = w.to_orig;
  for (std::size_t j = 0; j < m; ++j)
    if (off[j].collapsed)
      result.problems.push_back(
          {OffsetProblem::Kind::arc_collapsed, to_orig[j], 1,
           fmt::format("span {}: an arc of radius {:.6g} mm cannot be offset by {:.6g} mm (its offset radius "
                       "would be {:.6g} mm); it is lost",
                       to_orig[j], spans[j].radius, d, off[j].offset_radius)});
  if (result.contours.empty()) {
    result.problems.push_back({OffsetProblem::Kind::contour_vanished, OffsetProblem::kNoSpan, 0,
                               fmt::format("the contour vanishes when offset by {:.6g} mm: it is nowhere wider "
                                           "than {:.6g} mm",
                                           d, 2 * ad)});
    return;
  }
  std::vector<bool> lost(m);
  for (std::size_t j = 0; j < m; ++j) lost[j] = surviving[j] <= tol;
  std::size_t start = 0;
  while (start < m && lost[(start + m - 1) % m]) ++start;  // a span whose predecessor survives
  if (start == m) start = 0;                               // everything lost (cannot happen here)
  for (std::size_t step = 0; step < m;) {
    const std::size_t j = (start + step) % m;
    if (!lost[j]) {
      ++step;
      continue;
    }
    std::size_t count = 0;
    bool any_plain = false;
    while (step + count < m && lost[(start + step + count) % m]) {
      any_plain = any_plain || !off[(start + step + count) % m].collapsed;
      ++count;
    }
    const std::size_t last = (start + step + count - 1) % m;
    if (any_plain) {
      const std::size_t a = w.ccw ? to_orig[j] : to_orig[last];
      const std::size_t b = w.ccw ? to_orig[last] : to_orig[j];
      const std::size_t spanned = (b + n - a) % n + 1;
      result.problems.push_back(
          {OffsetProblem::Kind::feature_too_small, a, spanned,
           a == b ? fmt::format("span {}: narrower than {:.6g} mm, none of its offset survives", a, 2 * ad)
                  : fmt::format("spans {} to {}: a feature narrower than {:.6g} mm, none of their offset survives",
                                a, b, 2 * ad)});
    }
    step += count;
  }
}

}  // namespace

OffsetResult offset_contour(const Contour& contour, double d, const OffsetOptions& options) {
  options.validate();
  if (!std::isfinite(d) || std::abs(d) > kMaxCoordinateMm)
    throw InputError::field("distance_mm", fmt::format("is {}, must be finite and within {} mm", d, kMaxCoordinateMm));
  const double tol = options.tolerance_mm;
  if (const auto crossings = self_intersections(contour, tol); !crossings.empty()) {
    const auto& x = crossings.front();
    throw InputError("", 0,
                     fmt::format("offset: the contour crosses itself at ({:.6f}, {:.6f}) mm, spans {} and {}",
                                 x.point.x(), x.point.y(), x.span_a, x.span_b));
  }

  const double area0 = signed_area(contour), per0 = perimeter(contour);
  if (contour.empty() || !(std::abs(area0) > tol * per0))
    throw InputError("", 0,
                     fmt::format("offset: the contour encloses no area ({} mm^2 for a perimeter of {} mm)", area0,
                                 per0));
  OffsetResult result;
  const std::size_t n = contour.size();
  if (d == 0.0) {
    result.contours.push_back(contour);
    std::vector<std::size_t> ids(n);
    for (std::size_t i = 0; i < n; ++i) ids[i] = i;
    result.source_spans.push_back(std::move(ids));
    return result;
  }

  const WorkingContour w = working_copy(contour, area0 > 0, tol);  // 1.
  const std::vector<Segment> spans = w.clean.segments();
  // Intersection tolerance: far below the user's, so that only true crossings split pieces.
  const double eps = 1e-3 * tol;
  std::vector<SpanOffset> off = offset_spans(spans, d, tol);                       // 2.
  const std::vector<Corner> corners = close_corners(spans, off, d, tol, eps);      // 3.
  const std::vector<Raw> raw = raw_offset(off, corners, tol);
  const std::vector<Piece> pieces = split_at_crossings(raw, tol, eps);             // 4.
  const std::vector<std::size_t> kept = pieces_at_distance(pieces, w.clean, d, tol);  // 5.
  std::vector<double> surviving(spans.size(), 0.0);  // length of each span's own offset that survives
  chain_offset_pieces(pieces, kept, raw, w, d, tol, result, surviving);            // 6.
  report_offset_problems(spans, off, surviving, w, n, d, tol, result);
  return result;
}

}  // namespace machplan

namespace machplan {
namespace {

// A piece of one input contour between two crossings (or the whole contour when it crosses
// nothing), as the run of (sub)spans it covers.
struct MergePiece {
  std::vector<Segment> segs;
  std::size_t contour = 0;
  bool closed = false;  // the whole contour
};

// The live spans (longer than the tolerance) of every contour.
struct LiveSpans {
  struct Live {
    std::size_t contour, pos;  // pos: index among the contour's live spans
    Segment seg;
  };
  std::vector<Live> live;
  std::vector<std::size_t> first;  // first[k]: index of contour k's first live span; first[size] = live.size()

  LiveSpans(const std::vector<Contour>& contours, double tol) : first(contours.size() + 1, 0) {
    for (std::size_t k = 0; k < contours.size(); ++k) {
      first[k] = live.size();
      std::size_t pos = 0;
      for (std::size_t i = 0; i < contours[k].size(); ++i) {
        Segment s = contours[k].span(i);
        if (length(s) <= tol) continue;
        live.push_back({k, pos++, s});
      }
    }
    first[contours.size()] = live.size();
  }
  std::size_t count(std::size_t k) const { return first[k + 1] - first[k]; }
};

// The crossings between live spans, by a sweep over the span boxes: the split points of each
// live span, and one crossing per pair of contours that cross in `crossings`.
std::vector<std::vector<Split>> find_crossings(const LiveSpans& ls, double tol, double eps,
                                               std::vector<MergeResult::Crossing>& crossings) {
  const auto& live = ls.live;
  std::vector<std::vector<Split>> splits(live.size());
  std::vector<Eigen::AlignedBox2d> boxes;
  boxes.reserve(live.size());
  for (const auto& l : live) boxes.push_back(grown_box(l.seg, 2 * eps));
  std::vector<std::pair<std::pair<std::size_t, std::size_t>, Vector2d>> pairs;
  for_each_intersecting_pair(boxes, [&](std::size_t x, std::size_t y) {
    if (x > y) std::swap(x, y);
    const LiveSpans::Live& a = live[x];
    const LiveSpans::Live& b = live[y];
    const Intersection hit = intersect(a.seg, b.seg, eps);
    if (hit.empty()) return;
    const std::size_t m = a.contour == b.contour ? ls.count(a.contour) : 0;
    for (const auto& p : hit.points) {
      bool at_joint = false;
      if (a.contour == b.contour) {
        if (b.pos == a.pos + 1) at_joint = (p - a.seg.end).norm() <= tol;
        if (a.pos == 0 && b.pos == m - 1) at_joint = at_joint || (p - b.seg.end).norm() <= tol;
      }
      if (at_joint) continue;
      splits[x].push_back({parameter_at(a.seg, p), p});
      splits[y].push_back({parameter_at(b.seg, p), p});
      pairs.push_back({{std::min(a.contour, b.contour), std::max(a.contour, b.contour)}, p});
    }
  });
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& u, const auto& v) { return u.first < v.first; });
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (i == 0 || pairs[i].first != pairs[i - 1].first)
      crossings.push_back({pairs[i].first.first, pairs[i].first.second, pairs[i].second});
  return splits;
}

// Contour k cut at its split points (sorted here) into pieces; the whole contour as one closed
// piece when nothing crosses it.
void cut_contour(const LiveSpans& ls, std::size_t k, std::vector<std::vector<Split>>& splits,
                 std::vector<MergePiece>& pieces) {
  const auto& live = ls.live;
  const std::size_t b0 = ls.first[k], m = ls.count(k);
  if (m == 0) return;
  bool any = false;
  for (std::size_t i = b0; i < b0 + m; ++i) {
    auto& sp = splits[i];
    std::sort(sp.begin(), sp.end(), [](const Split& x, const Split& y) { return x.t < y.t; });
    any = any || !sp.empty();
  }
  if (!any) {
    MergePiece pc;
    pc.contour = k;
    pc.closed = true;
    for (std::size_t i = b0; i < b0 + m; ++i) pc.segs.push_back(live[i].seg);
    pieces.push_back(std::move(pc));
    return;
  }
  // Walk once round the contour starting at its first split point, cutting at each split.
  std::size_t s0 = b0;
  while (splits[s0].empty()) ++s0;
  MergePiece cur;
  cur.contour = k;
  bool started = false;
  for (std::size_t step = 0; step <= m; ++step) {
    const std::size_t i = b0 + (s0 - b0 + step) % m;
    const Segment& s = live[i].seg;
    const bool last_round = step == m;  // back on the first split span: only up to its first split
    Split from{0.0, s.start};
    std::size_t from_index = 0;
    if (!started) {
      from = splits[i].front();
      from_index = 1;
      started = true;
    }
    const auto& sp = splits[i];
    for (std::size_t q = from_index; q < sp.size() + (last_round ? 0 : 1); ++q) {
      const bool is_split = q < sp.size();
      const Split to = is_split ? sp[q] : Split{1.0, s.end};
      if (to.t > from.t && (to.p - from.p).norm() > 0.0) cur.segs.push_back(sub_segment(s, from.t, to.t, from.p, to.p));
      from = to;
      if (is_split) {
        if (!cur.segs.empty()) pieces.push_back(std::move(cur));
        cur = MergePiece{};
        cur.contour = k;
      }
      if (last_round && is_split) break;
    }
    if (last_round) break;
  }
}

// The pieces with the positive region on their left only.
// A contour that crosses nothing and whose box meets no other contour's box is alone: the
// winding is its own, +1 inside a counter-clockwise one, so it is kept exactly when it runs
// counter-clockwise. Only the others need winding numbers (and the index).
std::vector<std::size_t> pieces_bounding_region(const std::vector<Contour>& contours,
                                                const std::vector<MergePiece>& pieces, double tol) {
  std::vector<bool> alone(contours.size(), true);
  {
    std::vector<Eigen::AlignedBox2d> cboxes;
    for (const auto& c : contours) cboxes.push_back(c.empty() ? Eigen::AlignedBox2d() : bounding_box(c));
    for_each_intersecting_pair(cboxes, [&](std::size_t a, std::size_t b) { alone[a] = alone[b] = false; });
  }
  bool need_index = false;
  for (const auto& pc : pieces) need_index = need_index || !pc.closed || !alone[pc.contour];
  const SpanIndex index = need_index ? SpanIndex(contours) : SpanIndex();
  std::vector<std::size_t> kept;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    const auto& segs = pieces[p].segs;
    if (pieces[p].closed && alone[pieces[p].contour]) {
      if (signed_area(contours[pieces[p].contour]) > 0.0) kept.push_back(p);
      continue;
    }
    // Sample the middle of the longest (sub)span, away from the crossings at the ends.
    std::size_t longest = 0;
    double total = 0.0;
    for (std::size_t i = 0; i < segs.size(); ++i) {
      total += length(segs[i]);
      if (length(segs[i]) > length(segs[longest])) longest = i;
    }
    if (total <= tol) continue;
    const Segment& s = segs[longest];
    const Vector2d q = point_at(s, 0.5);
    const Vector2d t = tangent_at(s, q), left(-t.y(), t.x());
    const double delta = std::min(10.0 * tol, 0.25 * length(s));
    const int wl = index.winding(q + delta * left), wr = index.winding(q - delta * left);
    if (wl > 0 && wr <= 0) kept.push_back(p);
  }
  return kept;
}

// Two input contours can share a piece of boundary running the same way (collinear
// overlapping edges of a mitre offset): both copies pass the winding test, but the boundary
// holds it once. Keeps the first copy.
void drop_shared_copies(const std::vector<MergePiece>& pieces, std::vector<std::size_t>& kept, double ctol) {
  auto mid = [&](const MergePiece& pc) { return point_at(pc.segs[pc.segs.size() / 2], 0.5); };
  std::vector<std::size_t> order(kept.size());
  for (std::size_t q = 0; q < kept.size(); ++q) order[q] = q;
  auto sx = [&](std::size_t q) { return pieces[kept[q]].segs.front().start.x(); };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return sx(a) < sx(b) || (sx(a) == sx(b) && a < b); });
  std::vector<bool> dup(kept.size(), false);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const MergePiece& a = pieces[kept[order[i]]];
    if (dup[order[i]] || a.closed) continue;
    for (std::size_t j = i + 1; j < order.size() && sx(order[j]) <= sx(order[i]) + ctol; ++j) {
      const MergePiece& b = pieces[kept[order[j]]];
      if (dup[order[j]] || b.closed) continue;
      if ((a.segs.front().start - b.segs.front().start).norm() <= ctol &&
          (a.segs.back().end - b.segs.back().end).norm() <= ctol && (mid(a) - mid(b)).norm() <= ctol)
        dup[std::max(order[i], order[j])] = true;
    }
  }
  std::vector<std::size_t> unique;
  for (std::size_t q = 0; q < kept.size(); ++q)
    if (!dup[q]) unique.push_back(kept[q]);
  kept.swap(unique);
}

// A closed run of segments as a contour (spans within the tolerance dropped), unless it is a
// sliver.
void append_contour(const std::vector<Segment>& segs, double tol, std::vector<Contour>& out_contours) {
  std::vector<Vector2d> vs;
  std::vector<double> bs;
  for (const auto& s : segs) {
    if (length(s) <= tol) continue;
    vs.push_back(s.start);
    bs.push_back(bulge_of(s));
  }
  if (vs.size() < 2) return;
  Contour out(std::move(vs), std::move(bs));
  if (!(std::abs(signed_area(out)) > tol * perimeter(out))) return;  // a sliver
  out_contours.push_back(std::move(out));
}

// The open kept pieces chained into closed contours; closed ones stand alone.
void chain_merge_pieces(const std::vector<MergePiece>& pieces, const std::vector<std::size_t>& kept, double tol,
                        double ctol, std::vector<Contour>& out_contours) {
  std::vector<std::pair<double, std::size_t>> by_x;  // start x of open kept pieces
  for (std::size_t q = 0; q < kept.size(); ++q)
    if (!pieces[kept[q]].closed) by_x.push_back({pieces[kept[q]].segs.front().start.x(), q});
  std::sort(by_x.begin(), by_x.end());
  std::vector<bool> used(kept.size(), false);
  auto find_start = [&](const Vector2d& at) -> std::optional<std::size_t> {
    auto it = std::lower_bound(by_x.begin(), by_x.end(), std::make_pair(at.x() - ctol, std::size_t{0}));
    std::optional<std::size_t> best;
    double best_d = ctol;
    for (; it != by_x.end() && it->first <= at.x() + ctol; ++it) {
      if (used[it->second]) continue;
      const double g = (pieces[kept[it->second]].segs.front().start - at).norm();
      if (g <= best_d) {
        best_d = g;
        best = it->second;
      }
    }
    return best;
  };
  for (std::size_t first = 0; first < kept.size(); ++first) {
    if (used[first]) continue;
    used[first] = true;
    const MergePiece& p0 = pieces[kept[first]];
    if (p0.closed) {
      append_contour(p0.segs, tol, out_contours);
      continue;
    }
    std::vector<Segment> segs = p0.segs;
    const Vector2d origin = segs.front().start;
    while ((segs.back().end - origin).norm() > ctol) {
      const auto next = find_start(segs.back().end);
      if (!next)
        throw InputError("", 0,
                         fmt::format("merging offset contours: the region's boundary does not close near "
                                     "({:.4f}, {:.4f}) (contours touching at the offset distance); change the "
                                     "offset slightly",
                                     segs.back().end.x(), segs.back().end.y()));
      used[*next] = true;
      const auto& more = pieces[kept[*next]].segs;
      segs.insert(segs.end(), more.begin(), more.end());
    }
    append_contour(segs, tol, out_contours);
  }
}

}  // namespace

MergeResult merge_positive(const std::vector<Contour>& contours, const OffsetOptions& options) {
  options.validate();
  const double tol = options.tolerance_mm;
  const double eps = 1e-3 * tol;
  const double ctol = 2 * tol;
  MergeResult result;
  const LiveSpans ls(contours, tol);
  std::vector<std::vector<Split>> splits = find_crossings(ls, tol, eps, result.crossings);
  std::vector<MergePiece> pieces;  // between crossings
  for (std::size_t k = 0; k < contours.size(); ++k) cut_contour(ls, k, splits, pieces);
  std::vector<std::size_t> kept = pieces_bounding_region(contours, pieces, tol);
  drop_shared_copies(pieces, kept, ctol);
  chain_merge_pieces(pieces, kept, tol, ctol, result.contours);
  return result;
}

}  // namespace machplan
