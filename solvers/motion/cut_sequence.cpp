#include "solvers/motion/cut_sequence.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Geometry>

#include "engine/common/error.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
constexpr double kGain = 1e-9;  // a move must shorten the travel by more than this, mm

double dist(const Vector2d& a, const Vector2d& b) { return (a - b).norm(); }

// Nearest cuts of each cut by the distance between their program pierce points.
std::vector<std::vector<int>> neighbours(const SequenceProblem& p, std::size_t count) {
  const std::size_t n = p.cuts.size();
  std::vector<std::vector<int>> out(n);
  std::vector<std::pair<double, int>> d;
  for (std::size_t i = 0; i < n; ++i) {
    d.clear();
    for (std::size_t j = 0; j < n; ++j)
      if (j != i) d.emplace_back(dist(p.cuts[i].pierce[0], p.cuts[j].pierce[0]), static_cast<int>(j));
    const std::size_t m = std::min(count, d.size());
    std::partial_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m), d.end());
    for (std::size_t k = 0; k < m; ++k) out[i].push_back(d[k].second);
  }
  return out;
}

// Local search on the order with the candidates fixed (step 3 of the file comment).
class Improver {
 public:
  Improver(const SequenceProblem& p, Sequence& s) : p_(p), s_(s), n_(static_cast<int>(p.cuts.size())) {
    children_.resize(p.cuts.size());
    for (int i = 0; i < n_; ++i)
      if (p.cuts[static_cast<std::size_t>(i)].parent >= 0) children_[static_cast<std::size_t>(p.cuts[static_cast<std::size_t>(i)].parent)].push_back(i);
    near_ = neighbours(p, 10);
    reindex();
  }

  // Or-opt moves until none gains; returns the gain.
  double or_opt() {
    double total = 0.0;
    for (bool again = true; again;) {
      again = false;
      for (int len = 1; len <= 3; ++len)
        for (int i = 0; i + len <= n_; ++i) {
          const double g = best_insertion(i, len);
          if (g > kGain) {
            total += g;
            again = true;
          }
        }
    }
    return total;
  }

  // Block 2-opt moves until none gains; returns the gain.
  double block_two_opt() {
    double total = 0.0;
    for (bool again = true; again;) {
      again = false;
      blocks();
      const int b = static_cast<int>(block_start_.size());
      for (int first = 0; first < b; ++first) {
        for (int last : near_blocks(first)) {
          if (last <= first) continue;
          const double g = reverse_gain(first, last);
          if (g > kGain && reversal_keeps_precedence(first, last)) {
            reverse_blocks(first, last);
            total += g;
            again = true;
            blocks();
            break;
          }
        }
      }
    }
    return total;
  }

 private:
  const Vector2d& pierce(int pos) const {
    return p_.cuts[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(pos)])].pierce[static_cast<std::size_t>(s_.entry[static_cast<std::size_t>(pos)])];
  }
  const Vector2d& exit(int pos) const {
    return p_.cuts[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(pos)])].exit[static_cast<std::size_t>(s_.entry[static_cast<std::size_t>(pos)])];
  }
  // The edge from position a's exit (a = -1: the start) to position b's pierce (b = n: the end;
  // 0 without one).
  double edge(int a, int b) const {
    const Vector2d& from = a < 0 ? p_.start : exit(a);
    if (b >= n_) return p_.end ? dist(from, *p_.end) : 0.0;
    return dist(from, pierce(b));
  }
  double edge_to(const Vector2d& from, int b) const {
    if (b >= n_) return p_.end ? dist(from, *p_.end) : 0.0;
    return dist(from, pierce(b));
  }
  double edge_from(int a, const Vector2d& to) const { return dist(a < 0 ? p_.start : exit(a), to); }

  void reindex() {
    pos_.assign(p_.cuts.size(), 0);
    for (int k = 0; k < n_; ++k) pos_[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(k)])] = k;
  }

  // Moving the run [i, i + len) between positions j and j + 1 (j outside the run) keeps every
  // cut before its parent.
  bool move_keeps_precedence(int i, int len, int j) const {
    for (int k = i; k < i + len; ++k) {
      const int c = s_.order[static_cast<std::size_t>(k)];
      if (j > i) {  // later: the cuts in (i + len - 1, j] come before the run
        const int parent = p_.cuts[static_cast<std::size_t>(c)].parent;
        if (parent >= 0 && pos_[static_cast<std::size_t>(parent)] >= i + len && pos_[static_cast<std::size_t>(parent)] <= j) return false;
      } else {  // earlier: the cuts in [j + 1, i) come after the run
        for (int child : children_[static_cast<std::size_t>(c)])
          if (pos_[static_cast<std::size_t>(child)] > j && pos_[static_cast<std::size_t>(child)] < i) return false;
      }
    }
    return true;
  }

  // Tries the run [i, i + len) next to the neighbours of its ends; applies the best move that
  // gains. Returns the gain (0: none).
  double best_insertion(int i, int len) {
    const int last = i + len - 1;
    const Vector2d& in = pierce(i);
    const Vector2d& out = exit(last);
    const double removed = edge(i - 1, i) + edge(last, last + 1) - edge(i - 1, last + 1);
    double best = kGain;
    int best_j = -2;
    const auto consider = [&](int j) {
      if (j >= i - 1 && j <= last) return;  // inside or next to the run: no move
      if (j < -1 || j >= n_) return;
      const double added = edge_from(j, in) + edge_to(out, j + 1) - edge(j, j + 1);
      const double gain = removed - added;
      if (gain > best && move_keeps_precedence(i, len, j)) best = gain, best_j = j;
    };
    for (int end : {i, last})
      for (int b : near_[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(end)])]) {
        consider(pos_[static_cast<std::size_t>(b)]);
        consider(pos_[static_cast<std::size_t>(b)] - 1);
      }
    consider(-1);
    if (best_j == -2) return 0.0;
    apply_move(i, len, best_j);
    return best;
  }

  void apply_move(int i, int len, int j) {
    auto& o = s_.order;
    auto& e = s_.entry;
    const auto rot = [&](std::vector<int>& v) {
      if (j > i) std::rotate(v.begin() + i, v.begin() + i + len, v.begin() + j + 1);
      else std::rotate(v.begin() + j + 1, v.begin() + i, v.begin() + i + len);
    };
    rot(o);
    rot(e);
    reindex();
  }

  // Parts: runs of cuts each ending with a cut that has no parent.
  void blocks() {
    block_start_.clear();
    block_id_.assign(static_cast<std::size_t>(n_), 0);
    int start = 0;
    for (int k = 0; k < n_; ++k) {
      block_id_[static_cast<std::size_t>(k)] = static_cast<int>(block_start_.size());
      if (p_.cuts[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(k)])].parent < 0) {
        block_start_.push_back(start);
        start = k + 1;
      }
    }
    if (start < n_) block_start_.push_back(start);  // cannot happen in an order that keeps precedence
    block_start_.push_back(n_);
  }
  int block_end(int b) const { return block_start_[static_cast<std::size_t>(b) + 1] - 1; }

  // The 8 blocks whose entries lie nearest the exit before block `first`.
  std::vector<int> near_blocks(int first) const {
    const int b = static_cast<int>(block_start_.size()) - 1;
    const Vector2d from = block_start_[static_cast<std::size_t>(first)] == 0 ? p_.start : exit(block_start_[static_cast<std::size_t>(first)] - 1);
    std::vector<std::pair<double, int>> d;
    for (int q = first + 1; q < b; ++q) d.emplace_back(dist(from, pierce(block_start_[static_cast<std::size_t>(q)])), q);
    const std::size_t m = std::min<std::size_t>(8, d.size());
    std::partial_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m), d.end());
    std::vector<int> out;
    for (std::size_t k = 0; k < m; ++k) out.push_back(d[k].second);
    return out;
  }

  double reverse_gain(int first, int last) const {
    const int a = block_start_[static_cast<std::size_t>(first)], z = block_end(last);
    double before = edge(a - 1, a) + edge(z, z + 1), after = 0.0;
    for (int q = first; q < last; ++q) before += edge(block_end(q), block_start_[static_cast<std::size_t>(q) + 1]);
    after += edge_from(a - 1, pierce(block_start_[static_cast<std::size_t>(last)]));
    for (int q = last; q > first; --q) after += edge_from(block_end(q), pierce(block_start_[static_cast<std::size_t>(q) - 1]));
    after += edge_to(exit(block_end(first)), z + 1);
    return before - after;
  }

  bool reversal_keeps_precedence(int first, int last) const {
    const int a = block_start_[static_cast<std::size_t>(first)], z = block_end(last);
    for (int k = a; k <= z; ++k) {
      const int parent = p_.cuts[static_cast<std::size_t>(s_.order[static_cast<std::size_t>(k)])].parent;
      if (parent < 0) continue;
      const int pp = pos_[static_cast<std::size_t>(parent)];
      if (pp < a || pp > z) continue;
      if (block_id_[static_cast<std::size_t>(pp)] != block_id_[static_cast<std::size_t>(k)]) return false;
    }
    return true;
  }

  void reverse_blocks(int first, int last) {
    const int a = block_start_[static_cast<std::size_t>(first)], z = block_end(last);
    std::vector<int> o, e;
    for (int q = last; q >= first; --q)
      for (int k = block_start_[static_cast<std::size_t>(q)]; k <= block_end(q); ++k) {
        o.push_back(s_.order[static_cast<std::size_t>(k)]);
        e.push_back(s_.entry[static_cast<std::size_t>(k)]);
      }
    std::copy(o.begin(), o.end(), s_.order.begin() + a);
    std::copy(e.begin(), e.end(), s_.entry.begin() + a);
    (void)z;
    reindex();
  }

  const SequenceProblem& p_;
  Sequence& s_;
  int n_;
  std::vector<std::vector<int>> children_, near_;
  std::vector<int> pos_, block_start_, block_id_;
};

// A small index of points for nearest-point queries: sorted by x, scanned outwards until the x
// distance alone exceeds the best found.
struct SortedPoints {
  std::vector<std::pair<Vector2d, int>> pts;  // point, owner (-1: the start)
  explicit SortedPoints(std::vector<std::pair<Vector2d, int>> p) : pts(std::move(p)) {
    std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first.x() < b.first.x(); });
  }
  // Nearest point to q whose owner `allowed` accepts; +infinity when none.
  template <class F>
  double nearest(const Vector2d& q, F&& allowed) const {
    const auto at = std::lower_bound(pts.begin(), pts.end(), q.x(), [](const auto& a, double x) { return a.first.x() < x; });
    double best = kInf;
    for (auto it = at; it != pts.end() && it->first.x() - q.x() < best; ++it)
      if (allowed(it->second)) best = std::min(best, dist(it->first, q));
    for (auto it = at; it != pts.begin();) {
      --it;
      if (q.x() - it->first.x() >= best) break;
      if (allowed(it->second)) best = std::min(best, dist(it->first, q));
    }
    return best;
  }
};

// Bound (a): every cut entered once, from a cut that may precede it; and the first cut of
// each part (a cut with no children) from outside the part.
double entry_bound(const SequenceProblem& p) {
  const std::size_t n = p.cuts.size();
  std::vector<int> root(n), leaf(n, 1);
  for (std::size_t i = 0; i < n; ++i) {
    int r = static_cast<int>(i);
    while (p.cuts[static_cast<std::size_t>(r)].parent >= 0) r = p.cuts[static_cast<std::size_t>(r)].parent;
    root[i] = r;
    if (p.cuts[i].parent >= 0) leaf[static_cast<std::size_t>(p.cuts[i].parent)] = 0;
  }
  const auto ancestor = [&](int a, std::size_t of) {
    for (int q = p.cuts[of].parent; q >= 0; q = p.cuts[static_cast<std::size_t>(q)].parent)
      if (q == a) return true;
    return false;
  };
  std::vector<std::pair<Vector2d, int>> exits{{p.start, -1}};
  for (std::size_t i = 0; i < n; ++i)
    for (const Vector2d& e : p.cuts[i].exit) exits.emplace_back(e, static_cast<int>(i));
  const SortedPoints index(std::move(exits));
  std::vector<double> first_extra(n, kInf);  // per part: the least extra of entering it from outside
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    double in = kInf, outside = kInf;
    for (const Vector2d& q : p.cuts[i].pierce) {
      in = std::min(in, index.nearest(q, [&](int o) { return o != static_cast<int>(i) && !ancestor(o, i); }));
      if (leaf[i]) outside = std::min(outside, index.nearest(q, [&](int o) { return o < 0 || root[static_cast<std::size_t>(o)] != root[i]; }));
    }
    sum += in;
    if (leaf[i]) first_extra[static_cast<std::size_t>(root[i])] = std::min(first_extra[static_cast<std::size_t>(root[i])], outside - in);
  }
  for (std::size_t r = 0; r < n; ++r)
    if (std::isfinite(first_extra[r])) sum += first_extra[r];
  if (p.end && n > 0) {
    double best = kInf;  // the last cut has no parent
    for (const auto& c : p.cuts)
      if (c.parent < 0)
        for (const Vector2d& e : c.exit) best = std::min(best, dist(e, *p.end));
    sum += best;
  }
  return sum;
}

// Bound (b): the minimum spanning tree of start, cuts and end.
double tree_bound(const SequenceProblem& p) {
  struct Node {
    std::vector<Vector2d> in, out;  // pierce points, exit points
    Eigen::AlignedBox2d box;
  };
  std::vector<Node> nodes;
  nodes.push_back({{p.start}, {p.start}, Eigen::AlignedBox2d(p.start, p.start)});
  if (p.end) nodes.push_back({{*p.end}, {*p.end}, Eigen::AlignedBox2d(*p.end, *p.end)});
  for (const auto& c : p.cuts) {
    Node n{c.pierce, c.exit, {}};
    for (const Vector2d& q : c.pierce) n.box.extend(q);
    for (const Vector2d& q : c.exit) n.box.extend(q);
    nodes.push_back(std::move(n));
  }
  const auto weight = [&](const Node& a, const Node& b) {
    double w = kInf;
    for (const Vector2d& x : a.out)
      for (const Vector2d& y : b.in) w = std::min(w, dist(x, y));
    for (const Vector2d& x : b.out)
      for (const Vector2d& y : a.in) w = std::min(w, dist(x, y));
    return w;
  };
  const std::size_t m = nodes.size();
  std::vector<double> key(m, kInf);
  std::vector<char> in_tree(m, 0);
  key[0] = 0.0;
  double total = 0.0;
  for (std::size_t step = 0; step < m; ++step) {
    std::size_t u = m;
    for (std::size_t v = 0; v < m; ++v)
      if (!in_tree[v] && (u == m || key[v] < key[u])) u = v;
    in_tree[u] = 1;
    total += key[u];
    for (std::size_t v = 0; v < m; ++v) {
      if (in_tree[v] || nodes[u].box.exteriorDistance(nodes[v].box) >= key[v]) continue;
      key[v] = std::min(key[v], weight(nodes[u], nodes[v]));
    }
  }
  return total;
}

}  // namespace

double travel_mm(const SequenceProblem& p, const std::vector<int>& order, const std::vector<int>& entry) {
  double sum = 0.0;
  Vector2d at = p.start;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const auto& c = p.cuts[static_cast<std::size_t>(order[k])];
    sum += dist(at, c.pierce[static_cast<std::size_t>(entry[k])]);
    at = c.exit[static_cast<std::size_t>(entry[k])];
  }
  if (p.end && !order.empty()) sum += dist(at, *p.end);
  return sum;
}

bool respects_precedence(const SequenceProblem& p, const std::vector<int>& order) {
  std::vector<int> pos(p.cuts.size(), -1);
  for (std::size_t k = 0; k < order.size(); ++k) pos[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  for (std::size_t i = 0; i < p.cuts.size(); ++i)
    if (p.cuts[i].parent >= 0 && pos[i] > pos[static_cast<std::size_t>(p.cuts[i].parent)]) return false;
  return true;
}

Sequence program_sequence(const SequenceProblem& p) {
  Sequence s;
  s.order.resize(p.cuts.size());
  std::iota(s.order.begin(), s.order.end(), 0);
  s.entry.assign(p.cuts.size(), 0);
  s.travel_mm = travel_mm(p, s.order, s.entry);
  return s;
}

Sequence nearest_neighbour(const SequenceProblem& p, bool programmed_pierces) {
  const std::size_t n = p.cuts.size();
  std::vector<int> pending(n, 0);
  for (const auto& c : p.cuts) {
    MACHPLAN_ASSERT(!c.pierce.empty() && c.pierce.size() == c.exit.size(), "a cut needs candidates");
    if (c.parent >= 0) ++pending[static_cast<std::size_t>(c.parent)];
  }
  std::vector<char> done(n, 0);
  Sequence s;
  Vector2d at = p.start;
  for (std::size_t step = 0; step < n; ++step) {
    double best = kInf;
    int bi = -1, bk = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (done[i] || pending[i] > 0) continue;
      const std::size_t kn = programmed_pierces ? 1 : p.cuts[i].pierce.size();
      for (std::size_t k = 0; k < kn; ++k) {
        const double d = dist(at, p.cuts[i].pierce[k]);
        if (d < best) best = d, bi = static_cast<int>(i), bk = static_cast<int>(k);
      }
    }
    MACHPLAN_ASSERT(bi >= 0, "the parents of the cuts form a cycle");
    done[static_cast<std::size_t>(bi)] = 1;
    if (p.cuts[static_cast<std::size_t>(bi)].parent >= 0) --pending[static_cast<std::size_t>(p.cuts[static_cast<std::size_t>(bi)].parent)];
    s.order.push_back(bi);
    s.entry.push_back(bk);
    at = p.cuts[static_cast<std::size_t>(bi)].exit[static_cast<std::size_t>(bk)];
  }
  s.travel_mm = travel_mm(p, s.order, s.entry);
  return s;
}

void choose_entries(const SequenceProblem& p, Sequence& s) {
  const std::size_t n = s.order.size();
  s.entry.assign(n, 0);
  if (n == 0) {
    s.travel_mm = travel_mm(p, s.order, s.entry);
    return;
  }
  std::vector<std::vector<double>> cost(n);
  std::vector<std::vector<int>> from(n);
  for (std::size_t m = 0; m < n; ++m) {
    const auto& c = p.cuts[static_cast<std::size_t>(s.order[m])];
    cost[m].assign(c.pierce.size(), kInf);
    from[m].assign(c.pierce.size(), 0);
    for (std::size_t k = 0; k < c.pierce.size(); ++k) {
      if (m == 0) {
        cost[m][k] = dist(p.start, c.pierce[k]);
        continue;
      }
      const auto& prev = p.cuts[static_cast<std::size_t>(s.order[m - 1])];
      for (std::size_t j = 0; j < prev.exit.size(); ++j) {
        const double v = cost[m - 1][j] + dist(prev.exit[j], c.pierce[k]);
        if (v < cost[m][k]) cost[m][k] = v, from[m][k] = static_cast<int>(j);
      }
    }
  }
  const auto& last = p.cuts[static_cast<std::size_t>(s.order[n - 1])];
  double best = kInf;
  int bk = 0;
  for (std::size_t k = 0; k < last.exit.size(); ++k) {
    const double v = cost[n - 1][k] + (p.end ? dist(last.exit[k], *p.end) : 0.0);
    if (v < best) best = v, bk = static_cast<int>(k);
  }
  for (std::size_t m = n; m-- > 0;) {
    s.entry[m] = bk;
    bk = from[m][static_cast<std::size_t>(bk)];
  }
  s.travel_mm = travel_mm(p, s.order, s.entry);
}

namespace {

// Steps 2 to 4 from one start.
Sequence improve(const SequenceProblem& p, Sequence s, const SequenceOptions& options) {
  choose_entries(p, s);
  if (s.order.size() < 2) return s;
  for (int round = 0; round < options.max_rounds; ++round) {
    const double before = s.travel_mm;
    Improver improver(p, s);
    improver.or_opt();
    improver.block_two_opt();
    choose_entries(p, s);
    if (before - s.travel_mm < 1e-3) break;
  }
  return s;
}

}  // namespace

Sequence optimise(const SequenceProblem& p, const SequenceOptions& options) {
  // From the nearest neighbour over every candidate, over the programmed ones, and from the
  // program's own order when it keeps the precedences: the shortest result wins, so the
  // answer is never longer than any of those three.
  std::vector<Sequence> starts = {nearest_neighbour(p, false), nearest_neighbour(p, true)};
  if (const Sequence prog = program_sequence(p); respects_precedence(p, prog.order)) starts.push_back(prog);
  Sequence best;
  best.travel_mm = kInf;
  for (Sequence& start : starts) {
    Sequence s = improve(p, std::move(start), options);
    if (s.travel_mm < best.travel_mm - 1e-9) best = std::move(s);
  }
  MACHPLAN_ASSERT(respects_precedence(p, best.order), "the optimised order breaks a precedence");
  return best;
}

double travel_lower_bound(const SequenceProblem& p) {
  if (p.cuts.empty()) return 0.0;
  return std::max(entry_bound(p), tree_bound(p));
}

}  // namespace machplan::motion
