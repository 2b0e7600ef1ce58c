// Stage 3 of the DXF reader (engine/programs/internal/dxf_stages.h): pieces into nested
// contours, with the drawing's faults healed or reported.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/chaining.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/nesting.h"
#include "engine/programs/internal/dxf_stages.h"

namespace machplan::dxf {
namespace {

using Eigen::Vector2d;

// Removes the pieces marked gone, keeping the order of the others.
void drop_gone(std::vector<Piece>& pieces, const std::vector<bool>& gone) {
  std::vector<Piece> kept;
  for (std::size_t i = 0; i < pieces.size(); ++i)
    if (!gone[i]) kept.push_back(std::move(pieces[i]));
  pieces = std::move(kept);
}

// Stage 3 over the pieces of one drawing.
class Assembler {
 public:
  Assembler(Drawing& d, std::vector<Piece> pieces)
      : d_(d), opt_(d.options()), out_(d.out()), tol_(opt_.chain_tolerance_mm), pieces_(std::move(pieces)) {}

  // Pieces with the same geometry, either direction, within the tolerance.
  bool same(const Piece& a, const Piece& b) const {
    if (a.closed != b.closed || a.vertices.size() != b.vertices.size()) return false;
    const std::size_t n = a.vertices.size();
    for (int dir : {1, -1}) {
      for (std::size_t k = 0; k < (a.closed ? n : 1); ++k) {
        bool ok = true;
        for (std::size_t i = 0; i < n && ok; ++i) {
          const std::size_t j = dir == 1 ? (k + i) % n : (a.closed ? (k + n - i) % n : n - 1 - i);
          ok = (a.vertices[i] - b.vertices[j]).norm() <= tol_;
        }
        for (std::size_t i = 0; i < a.bulges.size() && ok; ++i) {
          const double bj = dir == 1 ? b.bulges[(k + i) % b.bulges.size()]
                                     : -b.bulges[a.closed ? (k + 2 * n - i - 1) % n : b.bulges.size() - 1 - i];
          ok = std::abs(a.bulges[i] - bj) <= 1e-6 * (1 + std::abs(bj));
        }
        if (ok) return true;
      }
    }
    return false;
  }

  void drop_duplicates() {
    std::vector<std::size_t> order(pieces_.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    auto minx = [&](std::size_t i) {
      double m = pieces_[i].vertices.front().x();
      for (const auto& p : pieces_[i].vertices) m = std::min(m, p.x());
      return m;
    };
    std::vector<double> key(pieces_.size());
    for (std::size_t i = 0; i < key.size(); ++i) key[i] = minx(i);
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return key[a] < key[b] || (key[a] == key[b] && a < b); });
    std::vector<bool> gone(pieces_.size(), false);
    for (std::size_t x = 0; x < order.size(); ++x) {
      if (gone[order[x]]) continue;
      for (std::size_t y = x + 1; y < order.size() && key[order[y]] - key[order[x]] <= tol_; ++y) {
        const std::size_t a = std::min(order[x], order[y]), b = std::max(order[x], order[y]);
        if (gone[b] || gone[a] || !same(pieces_[a], pieces_[b])) continue;
        gone[b] = true;  // keep the one earlier in the file
        problem(ProfileProblem::Severity::warning, "duplicate", {pieces_[a].parts[0], pieces_[b].parts[0]},
                fmt::format("{} repeats {}; the copy is dropped", where(pieces_[b].parts[0]), where(pieces_[a].parts[0])),
                pieces_[b].vertices.front());
      }
    }
    drop_gone(pieces_, gone);
  }

  // Overlapping collinear lines and concentric arcs (single spans, open): a span lying within
  // another is dropped, a line overlapping another line's end is cut back to the part the other
  // does not cover. Pairs are found by their boxes (sweep and prune), in file order.
  void merge_collinear_overlaps() {
    const auto single = [&](const Piece& p) { return !p.closed && p.vertices.size() == 2; };
    std::vector<Eigen::AlignedBox2d> boxes(pieces_.size());
    for (std::size_t i = 0; i < pieces_.size(); ++i)
      if (single(pieces_[i])) {
        boxes[i] = bounding_box(make_segment(pieces_[i].vertices[0], pieces_[i].vertices[1], pieces_[i].bulges[0]));
        boxes[i].min().array() -= tol_;
        boxes[i].max().array() += tol_;
      }
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) { pairs.emplace_back(std::min(a, b), std::max(a, b)); });
    std::sort(pairs.begin(), pairs.end());
    std::vector<bool> gone(pieces_.size(), false);
    for (const auto& [a, b] : pairs) {
      if (gone[a] || gone[b]) continue;
      const bool arcs = pieces_[a].bulges[0] != 0.0 && pieces_[b].bulges[0] != 0.0;
      if (arcs) merge_arcs(a, b, gone);
      else if (pieces_[a].bulges[0] == 0.0 && pieces_[b].bulges[0] == 0.0) merge_lines(a, b, gone);
    }
    drop_gone(pieces_, gone);
  }

  void note_merged(std::size_t dropped, std::size_t other, const std::string& what) {
    problem(ProfileProblem::Severity::warning, "merged_overlap", {pieces_[other].parts[0], pieces_[dropped].parts[0]},
            fmt::format("{} lies along {} over its whole length{}; it is dropped", where(pieces_[dropped].parts[0]),
                        where(pieces_[other].parts[0]), what),
            pieces_[dropped].vertices[0]);
  }

  // Two lines, the earlier `a`: see merge_collinear_overlaps.
  void merge_lines(std::size_t a, std::size_t b, std::vector<bool>& gone) {
    const Piece& keep = pieces_[a];
    Piece& later = pieces_[b];
    const Vector2d p0 = keep.vertices[0], d = keep.vertices[1] - keep.vertices[0];
    const double len = d.norm();
    if (!(len > tol_)) return;
    const Vector2d u = d / len;
    // Both ends of the later line on the earlier one's line, within the tolerance.
    const auto off = [&](const Vector2d& q) { return std::abs(cross(u, q - p0)); };
    if (off(later.vertices[0]) > tol_ || off(later.vertices[1]) > tol_) return;
    const double t0 = u.dot(later.vertices[0] - p0), t1 = u.dot(later.vertices[1] - p0);
    const double lo = std::min(t0, t1), hi = std::max(t0, t1);
    if (hi - tol_ <= 0.0 || lo + tol_ >= len) return;  // they meet at most at an end
    if (lo >= -tol_ && hi <= len + tol_) {
      gone[b] = true;
      note_merged(b, a, "");
      return;
    }
    if (lo < -tol_ && hi > len + tol_) {  // the earlier lies within the later
      gone[a] = true;
      note_merged(a, b, "");
      return;
    }
    // Cut the later line back to the part beyond the earlier one's end it overlaps.
    const bool beyond_end = hi > len + tol_;
    const Vector2d cut = beyond_end ? keep.vertices[1] : keep.vertices[0];
    const bool first_inside = beyond_end ? (t0 < t1) : (t0 > t1);  // the later line's start lies on the earlier
    (first_inside ? later.vertices[0] : later.vertices[1]) = cut;
    problem(ProfileProblem::Severity::warning, "merged_overlap", {keep.parts[0], later.parts[0]},
            fmt::format("{} overlaps {} by {:.4f} mm; the later line is cut back to {}", where(later.parts[0]),
                        where(keep.parts[0]), beyond_end ? len - lo : hi, fmt_pt(cut)),
            cut);
  }

  // Two arcs, the earlier `a`: one lying on the other's circle within its range is dropped.
  void merge_arcs(std::size_t a, std::size_t b, std::vector<bool>& gone) {
    const Segment sa = make_segment(pieces_[a].vertices[0], pieces_[a].vertices[1], pieces_[a].bulges[0]);
    const Segment sb = make_segment(pieces_[b].vertices[0], pieces_[b].vertices[1], pieces_[b].bulges[0]);
    if (!sa.is_arc() || !sb.is_arc() || (sa.center - sb.center).norm() > tol_ || std::abs(sa.radius - sb.radius) > tol_) return;
    const auto within = [&](const Segment& inner, const Segment& outer) {
      for (double t : {0.0, 0.5, 1.0}) {
        const Vector2d q = point_at(inner, t);
        if ((closest_point(outer, q) - q).norm() > tol_) return false;
      }
      return true;
    };
    if (within(sb, sa)) {
      gone[b] = true;
      note_merged(b, a, " (the same circle)");
    } else if (within(sa, sb)) {
      gone[a] = true;
      note_merged(a, b, " (the same circle)");
    }
  }

  // Closed chains that trace the same outline (every vertex and span middle of each within
  // the tolerance of the other, whatever their split into spans): the later is dropped.
  void drop_coincident_closed() {
    std::vector<Eigen::AlignedBox2d> boxes;
    std::vector<std::optional<Contour>> cs;
    for (const Piece& pc : closed_) {
      std::optional<Contour> c;
      try {
        c = Contour(pc.vertices, pc.bulges);
      } catch (const InputError&) {  // no contour (a degenerate chain): nothing to compare it with
      }
      boxes.push_back(c ? bounding_box(*c) : Eigen::AlignedBox2d());
      cs.push_back(std::move(c));
    }
    const auto on = [&](const Contour& a, const Contour& b) {
      for (std::size_t i = 0; i < a.size(); ++i)
        if (distance(b, a.vertices()[i]) > tol_ || distance(b, point_at(a.span(i), 0.5)) > tol_) return false;
      return true;
    };
    std::vector<bool> gone(closed_.size(), false);
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) { pairs.emplace_back(std::min(a, b), std::max(a, b)); });
    std::sort(pairs.begin(), pairs.end());
    for (const auto& [a, b] : pairs) {
      if (gone[a] || gone[b] || !cs[a] || !cs[b]) continue;
      if ((boxes[a].min() - boxes[b].min()).cwiseAbs().maxCoeff() > tol_ ||
          (boxes[a].max() - boxes[b].max()).cwiseAbs().maxCoeff() > tol_)
        continue;
      if (!on(*cs[a], *cs[b]) || !on(*cs[b], *cs[a])) continue;
      gone[b] = true;
      problem(ProfileProblem::Severity::warning, "duplicate", {closed_[a].parts.front(), closed_[b].parts.front()},
              fmt::format("the outline of {} ({} entities) repeats the one of {}: drawn twice; the copy is dropped",
                          where(closed_[b].parts.front()), closed_[b].parts.size(), where(closed_[a].parts.front())),
              closed_[b].vertices.front());
    }
    drop_gone(closed_, gone);
  }

  // Chaining at the chain tolerance, then healing: the chains still open are chained again at
  // the join tolerance, and each join it makes is reported. What stays open is reported.
  void chain() {
    Chaining first = chain_runs(pieces_, tol_);
    closed_ = std::move(first.closed);
    std::vector<Piece> open = std::move(first.open);
    if (!open.empty() && opt_.join_tolerance_mm > tol_) {
      Chaining healed = chain_runs(open, opt_.join_tolerance_mm, tol_);
      for (Piece& c : healed.closed) closed_.push_back(std::move(c));
      open = std::move(healed.open);
      for (const ChainJoin& j : healed.joins) {
        problem(ProfileProblem::Severity::warning, "joined", {j.from, j.to},
                fmt::format("{} joined to {} across a gap of {:.4f} mm at {} (join tolerance {:g} mm)", where(j.from),
                            j.from == j.to ? std::string("itself") : where(j.to), j.gap_mm, fmt_pt(j.at),
                            opt_.join_tolerance_mm),
                j.at);
        out_.problems.back().gap_mm = j.gap_mm;
      }
    }
    report_open(open);
  }

  // Each open chain with the gap between its own ends (how far it is from closing) and the
  // distance to the nearest end of another open chain. Ends sorted by x; the search around
  // each stops once the x distance alone exceeds the best found.
  void report_open(const std::vector<Piece>& open) {
    struct End { double x, y; std::size_t chain; };
    std::vector<End> ends;
    for (std::size_t i = 0; i < open.size(); ++i)
      for (const Vector2d& p : {open[i].front(), open[i].back()}) ends.push_back({p.x(), p.y(), i});
    std::sort(ends.begin(), ends.end(), [](const End& a, const End& b) { return a.x < b.x || (a.x == b.x && a.chain < b.chain); });
    std::vector<double> nearest(open.size(), std::numeric_limits<double>::infinity());
    for (std::size_t a = 0; a < ends.size(); ++a) {
      double best = nearest[ends[a].chain];
      auto try_end = [&](std::size_t b) {
        if (ends[b].chain != ends[a].chain) best = std::min(best, std::hypot(ends[b].x - ends[a].x, ends[b].y - ends[a].y));
      };
      for (std::size_t b = a + 1; b < ends.size() && ends[b].x - ends[a].x < best; ++b) try_end(b);
      for (std::size_t b = a; b-- > 0 && ends[a].x - ends[b].x < best;) try_end(b);
      nearest[ends[a].chain] = best;
    }
    const bool heal = opt_.join_tolerance_mm > tol_;
    for (std::size_t i = 0; i < open.size(); ++i) {
      const Piece& c = open[i];
      const double gap = (c.back() - c.front()).norm();
      const std::string near =
          std::isfinite(nearest[i]) ? fmt::format("; nearest end of another open chain is {:.4f} mm away", nearest[i]) : "";
      problem(ProfileProblem::Severity::error, "open_chain", c.parts,
              fmt::format("open chain of {} entit{} starting at {}: its ends {} and {} are {:.4f} mm apart, more than "
                          "the {} {:g} mm{}",
                          c.parts.size(), c.parts.size() == 1 ? "y" : "ies", where(c.parts.front()),
                          fmt_pt(c.front()), fmt_pt(c.back()), gap, heal ? "join tolerance" : "tolerance",
                          heal ? opt_.join_tolerance_mm : tol_, near),
              c.back());
      out_.problems.back().gap_mm = gap;
    }
  }

  void finish() {
    const auto E = ProfileProblem::Severity::error;
    for (auto& pc : closed_) {
      ProfileContour pcn;
      try {
        pcn.contour = Contour(pc.vertices, pc.bulges);
      } catch (const InputError& e) {
        throw InputError(d_.source(), line_of(pc.parts.front()), fmt::format("{}: {}", where(pc.parts.front()), e.what()));
      }
      pcn.area_mm2 = signed_area(pcn.contour);
      pcn.perimeter_mm = perimeter(pcn.contour);
      for (auto e : pc.parts) pcn.handles.push_back(label(e));
      pcn.layer = layer_of(pc.parts.front());
      const std::size_t ci = out_.contours.size();
      if (std::abs(pcn.area_mm2) <= tol_ * tol_)
        problem(E, "zero_area", pc.parts,
                fmt::format("contour {} starting at {} encloses no area", ci, where(pc.parts.front())), pc.vertices.front());
      const auto hits = self_intersections(pcn.contour, 0.1 * tol_);
      if (!hits.empty())
        problem(E, "self_intersection", pc.parts,
                fmt::format("contour {} starting at {} crosses itself at {}{}", ci, where(pc.parts.front()),
                            fmt_pt(hits.front().point), hits.size() > 1 ? fmt::format(" and {} more place(s)", hits.size() - 1) : ""),
                hits.front().point);
      out_.contours.push_back(std::move(pcn));
      contour_entities_.push_back(pc.parts);
    }
    // Pairs of contours whose (grown) boxes meet: they may cross or touch. Any other pair is
    // disjoint.
    auto& cs = out_.contours;
    std::vector<Eigen::AlignedBox2d> grown;
    for (const auto& c : cs) {
      const Eigen::AlignedBox2d box = bounding_box(c.contour);
      grown.emplace_back(box.min() - Vector2d::Constant(tol_), box.max() + Vector2d::Constant(tol_));
    }
    struct Crossing { std::size_t a, b; std::vector<Vector2d> points; };
    std::vector<Crossing> crossings;
    for_each_intersecting_pair(grown, [&](std::size_t a, std::size_t b) {
      if (a > b) std::swap(a, b);
      auto pts = contour_intersections(cs[a].contour, cs[b].contour, 0.1 * tol_);
      if (!pts.empty()) crossings.push_back({a, b, std::move(pts)});
    });
    std::sort(crossings.begin(), crossings.end(), [](const Crossing& x, const Crossing& y) {
      return x.a < y.a || (x.a == y.a && x.b < y.b);
    });
    for (const auto& [a, b, pts] : crossings) {
      problem(E, "overlap", {},
              fmt::format("contours {} and {} cross or touch at {}{}", a, b, fmt_pt(pts.front()),
                          pts.size() > 1 ? fmt::format(" and {} more place(s)", pts.size() - 1) : ""),
              pts.front());
      auto& h = out_.problems.back().handles;
      for (auto e : contour_entities_[a]) h.push_back(label(e));
      for (auto e : contour_entities_[b]) h.push_back(label(e));
    }
    // Nesting: the smallest contour that holds another's first vertex, and does not cross
    // it, is its parent; the depth counts the parents up to the top.
    std::vector<Contour> contours;
    for (const auto& c : cs) contours.push_back(c.contour);
    std::vector<std::pair<std::size_t, std::size_t>> crossing_pairs;
    for (const auto& x : crossings) crossing_pairs.emplace_back(x.a, x.b);
    const Nesting nesting = nest_contours(contours, crossing_pairs);
    for (std::size_t i = 0; i < cs.size(); ++i) {
      cs[i].parent = nesting.parent[i];
      cs[i].children = nesting.children[i];
    }
    for (auto& c : cs) {
      int depth = 0;
      for (int p = c.parent; p >= 0 && depth <= static_cast<int>(cs.size()); p = cs[static_cast<std::size_t>(p)].parent) ++depth;
      c.depth = depth;
    }
    if (cs.empty()) problem(E, "no_contours", {}, "the drawing holds no closed contour");
  }

 private:
  std::string where(std::size_t k) const { return d_.where(k); }
  std::string label(std::size_t k) const { return d_.label(k); }
  int line_of(std::size_t k) const { return d_.line_of(k); }
  const std::string& layer_of(std::size_t k) const { return d_.instance(k).layer; }
  void problem(ProfileProblem::Severity s, std::string kind, const std::vector<std::size_t>& insts, std::string message,
               std::optional<Vector2d> at = std::nullopt) {
    d_.problem(s, std::move(kind), insts, std::move(message), at);
  }

  Drawing& d_;
  const DxfOptions& opt_;
  ProfileReadResult& out_;
  double tol_;
  std::vector<Piece> pieces_;
  std::vector<Piece> closed_;
  std::vector<std::vector<std::size_t>> contour_entities_;
};

}  // namespace

void assemble(Drawing& d, std::vector<Piece> pieces) {
  Assembler as(d, std::move(pieces));
  as.drop_duplicates();
  as.merge_collinear_overlaps();
  as.chain();
  as.drop_coincident_closed();
  as.finish();
}

}  // namespace machplan::dxf
