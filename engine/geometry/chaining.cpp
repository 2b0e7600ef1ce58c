#include "engine/geometry/chaining.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <unordered_map>

#include "engine/geometry/contour.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

// The free ends of the open runs in a grid of square cells at least the tolerance wide, so
// that every end within the tolerance of a point lies in its cell or the eight around it.
class EndGrid {
 public:
  EndGrid(const std::vector<SpanRun>& runs, double tol) : runs_(runs) {
    double extent = 0;
    for (const auto& p : runs)
      if (!p.closed) extent = std::max({extent, p.front().cwiseAbs().maxCoeff(), p.back().cwiseAbs().maxCoeff()});
    cell_ = std::max(tol, extent / (1 << 28));  // keeps cell indices well inside 32 bits
    for (std::size_t j = 0; j < runs.size(); ++j) {
      if (runs[j].closed) continue;
      cells_[key(runs[j].front())].push_back(2 * j);
      cells_[key(runs[j].back())].push_back(2 * j + 1);
    }
  }
  // Nearest end within `radius` (<= the tolerance) of p among unused runs: (run, at_end,
  // distance); run = size() when none. Ties go to the lower run, then its start.
  std::tuple<std::size_t, bool, double> nearest(const Vector2d& p, double radius, const std::vector<bool>& used) const {
    std::tuple<std::size_t, bool, double> best{runs_.size(), false, std::numeric_limits<double>::infinity()};
    const auto cx = static_cast<std::int64_t>(std::floor(p.x() / cell_)), cy = static_cast<std::int64_t>(std::floor(p.y() / cell_));
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(pack(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (const std::size_t id : it->second) {
          const std::size_t j = id / 2;
          if (used[j]) continue;
          const bool at_end = id % 2 == 1;
          const double d = ((at_end ? runs_[j].back() : runs_[j].front()) - p).norm();
          if (d > radius) continue;
          const auto [bj, bend, bd] = best;
          if (d < bd || (d == bd && (j < bj || (j == bj && !at_end && bend)))) best = {j, at_end, d};
        }
      }
    return best;
  }

 private:
  static std::uint64_t pack(std::int64_t x, std::int64_t y) {
    return (static_cast<std::uint64_t>(x) << 32) ^ (static_cast<std::uint64_t>(y) & 0xffffffffu);
  }
  std::uint64_t key(const Vector2d& p) const {
    return pack(static_cast<std::int64_t>(std::floor(p.x() / cell_)), static_cast<std::int64_t>(std::floor(p.y() / cell_)));
  }
  const std::vector<SpanRun>& runs_;
  double cell_ = 1;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells_;
};

}  // namespace

void SpanRun::reverse() {
  std::reverse(vertices.begin(), vertices.end());
  std::reverse(bulges.begin(), bulges.end());
  for (auto& x : bulges) x = -x;
  if (closed && !bulges.empty()) std::rotate(bulges.begin(), bulges.begin() + 1, bulges.end());
}

double SpanRun::length() const {
  double sum = 0;
  for (std::size_t i = 0; i < bulges.size(); ++i)
    sum += machplan::length(make_segment(vertices[i], vertices[(i + 1) % vertices.size()], bulges[i]));
  return sum;
}

void SpanRun::append(const SpanRun& next) {
  vertices.insert(vertices.end(), next.vertices.begin() + 1, next.vertices.end());
  bulges.insert(bulges.end(), next.bulges.begin(), next.bulges.end());
  parts.insert(parts.end(), next.parts.begin(), next.parts.end());
}

Chaining chain_runs(const std::vector<SpanRun>& runs, double tolerance_mm, double note_gaps_above_mm) {
  const double tol = tolerance_mm;
  Chaining out;
  std::vector<bool> used(runs.size(), false);
  const EndGrid grid(runs, tol);
  const auto note = [&](const SpanRun& c, const SpanRun& n, double gap) {
    if (gap > note_gaps_above_mm) out.joins.push_back({c.parts.back(), n.parts.front(), gap, c.back()});
  };
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (used[i]) continue;
    used[i] = true;
    SpanRun c = runs[i];
    if (c.closed) {
      out.closed.push_back(std::move(c));
      continue;
    }
    bool closed = false;
    for (int pass = 0; pass < 2 && !closed; ++pass) {  // forward from the end, then from the start
      while (true) {
        const double to_start = (c.back() - c.front()).norm();
        auto [j, at_end, d] = grid.nearest(c.back(), tol, used);
        if (to_start <= tol && to_start <= d && c.bulges.size() >= 2) {  // one span cannot close
          closed = true;
          note(c, c, to_start);
          if (pass == 1) c.reverse();  // back to the first run's direction
          break;
        }
        if (j == runs.size()) break;
        used[j] = true;
        SpanRun n = runs[j];
        if (at_end) n.reverse();
        note(c, n, d);
        c.append(n);
      }
      if (!closed && pass == 0) c.reverse();
    }
    if (closed) {
      c.vertices.pop_back();  // the last point is the first again
      c.closed = true;
      out.closed.push_back(std::move(c));
      continue;
    }
    c.reverse();  // back to the drawn direction of the first run where possible
    out.open.push_back(std::move(c));
  }
  return out;
}

}  // namespace machplan
