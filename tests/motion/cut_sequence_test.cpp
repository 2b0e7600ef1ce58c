// solvers/motion/cut_sequence.h against the exact optimum, found here by dynamic programming
// over subsets on small sheets of random parts (a sheet of our own making each time): the
// lower bound is never above the optimum, the heuristic never below it, and close to it.
#include "solvers/motion/cut_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The shortest travel over every order that keeps the precedences and every choice of
// candidates: states (cuts done, last cut, its candidate).
double exact_optimum(const SequenceProblem& p) {
  const int n = static_cast<int>(p.cuts.size());
  const int kmax = 8;
  const std::size_t states = (std::size_t{1} << n) * static_cast<std::size_t>(n * kmax);
  std::vector<double> best(states, kInf);
  const auto at = [&](unsigned mask, int last, int k) { return (static_cast<std::size_t>(mask) * n + last) * kmax + k; };
  const auto ready = [&](unsigned mask, int c) {
    for (int j = 0; j < n; ++j)
      if (p.cuts[static_cast<std::size_t>(j)].parent == c && !(mask & (1u << j))) return false;
    return true;
  };
  for (int c = 0; c < n; ++c)
    if (ready(0, c))
      for (std::size_t k = 0; k < p.cuts[static_cast<std::size_t>(c)].pierce.size(); ++k)
        best[at(1u << c, c, static_cast<int>(k))] = (p.start - p.cuts[static_cast<std::size_t>(c)].pierce[k]).norm();
  for (unsigned mask = 1; mask < (1u << n); ++mask)
    for (int last = 0; last < n; ++last) {
      if (!(mask & (1u << last))) continue;
      const auto& lc = p.cuts[static_cast<std::size_t>(last)];
      for (std::size_t k = 0; k < lc.exit.size(); ++k) {
        const double here = best[at(mask, last, static_cast<int>(k))];
        if (!std::isfinite(here)) continue;
        for (int c = 0; c < n; ++c) {
          if ((mask & (1u << c)) || !ready(mask, c)) continue;
          const auto& cc = p.cuts[static_cast<std::size_t>(c)];
          for (std::size_t q = 0; q < cc.pierce.size(); ++q) {
            double& to = best[at(mask | (1u << c), c, static_cast<int>(q))];
            to = std::min(to, here + (lc.exit[k] - cc.pierce[q]).norm());
          }
        }
      }
    }
  double out = kInf;
  const unsigned all = (1u << n) - 1;
  for (int last = 0; last < n; ++last)
    for (std::size_t k = 0; k < p.cuts[static_cast<std::size_t>(last)].exit.size(); ++k) {
      const double v = best[at(all, last, static_cast<int>(k))];
      out = std::min(out, v + (p.end ? (p.cuts[static_cast<std::size_t>(last)].exit[k] - *p.end).norm() : 0.0));
    }
  return out;
}

// A sheet of `parts` rectangular parts, each with up to `holes` round holes: a hole is pierced
// at its centre and left on its edge (at one of a few angles); an outline is pierced outside a
// side and left on it (a few places round it). Each part is listed outline first, so the
// program's order breaks the precedences.
SequenceProblem random_sheet(std::mt19937& rng, int parts, int holes) {
  std::uniform_real_distribution<double> u(0, 1);
  SequenceProblem p;
  p.start = {0, 0};
  if (u(rng) < 0.5) p.end = Vector2d(0, 0);
  for (int k = 0; k < parts; ++k) {
    const Vector2d corner(40 + 150 * (k % 3) + 20 * u(rng), 40 + 120 * (k / 3) + 20 * u(rng));
    const double w = 80 + 40 * u(rng), h = 60 + 30 * u(rng);
    const int outline = static_cast<int>(p.cuts.size());
    SequenceProblem::Cut o;
    const int places = 1 + static_cast<int>(3 * u(rng));
    for (int q = 0; q < places; ++q) {
      const double s = u(rng);
      const Vector2d on = corner + (s < 0.5 ? Vector2d(2 * s * w, 0) : Vector2d(w, 2 * (s - 0.5) * h));
      const Vector2d out = s < 0.5 ? Vector2d(0, -6) : Vector2d(6, 0);
      o.pierce.push_back(on + out);
      o.exit.push_back(on);
    }
    p.cuts.push_back(o);
    const int nh = static_cast<int>(std::round(holes * u(rng)));
    for (int q = 0; q < nh; ++q) {
      SequenceProblem::Cut hole;
      const Vector2d c = corner + Vector2d((0.2 + 0.6 * u(rng)) * w, (0.2 + 0.6 * u(rng)) * h);
      const double r = 4 + 4 * u(rng);
      const int angles = 1 + static_cast<int>(3 * u(rng));
      for (int a = 0; a < angles; ++a) {
        const double t = 6.283185307 * a / angles + u(rng);
        hole.pierce.push_back(c);
        hole.exit.push_back(c + r * Vector2d(std::cos(t), std::sin(t)));
      }
      hole.parent = outline;
      p.cuts.push_back(hole);
    }
  }
  return p;
}

TEST(CutSequence, ChooseEntriesIsTheBestChoiceForTheOrder) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const SequenceProblem p = random_sheet(rng, 2, 2);
    Sequence s = nearest_neighbour(p, true);
    choose_entries(p, s);
    // Every combination of candidates for this order.
    double best = kInf;
    std::vector<int> e(s.order.size(), 0);
    while (true) {
      best = std::min(best, travel_mm(p, s.order, e));
      std::size_t k = 0;
      for (; k < e.size(); ++k) {
        if (++e[k] < static_cast<int>(p.cuts[static_cast<std::size_t>(s.order[k])].pierce.size())) break;
        e[k] = 0;
      }
      if (k == e.size()) break;
    }
    EXPECT_NEAR(s.travel_mm, best, 1e-9) << trial;
  }
}

TEST(CutSequence, OptimiseKeepsPrecedencesBeatsItsStartsAndStaysNearTheOptimum) {
  std::mt19937 rng(17);
  double worst_gap = 0.0, sum_gap = 0.0, sum_bound = 0.0;
  int trials = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const SequenceProblem p = random_sheet(rng, 2 + trial % 2, 3);
    if (p.cuts.size() > 9 || p.cuts.size() < 2) continue;
    const double optimum = exact_optimum(p);
    const Sequence o = optimise(p);
    const double bound = travel_lower_bound(p);
    ASSERT_TRUE(respects_precedence(p, o.order)) << trial;
    EXPECT_NEAR(o.travel_mm, travel_mm(p, o.order, o.entry), 1e-9);
    EXPECT_LE(bound, optimum + 1e-9) << trial << ": the bound is above the optimum";
    EXPECT_GE(o.travel_mm, optimum - 1e-9) << trial << ": below the optimum";
    EXPECT_LE(o.travel_mm, nearest_neighbour(p, false).travel_mm + 1e-9) << trial;
    EXPECT_LE(o.travel_mm, nearest_neighbour(p, true).travel_mm + 1e-9) << trial;
    const double gap = o.travel_mm / optimum - 1.0;
    sum_bound += bound / optimum;
    worst_gap = std::max(worst_gap, gap);
    sum_gap += gap;
    ++trials;
  }
  std::printf("optimise against the exact optimum on %d small sheets: mean %.2f %%, worst %.2f %% above; the lower "
              "bound is on average %.1f %% of the optimum\n",
              trials, 100 * sum_gap / trials, 100 * worst_gap, 100 * sum_bound / trials);
  ASSERT_GE(trials, 20);
  EXPECT_LE(worst_gap, 0.10);
  EXPECT_LE(sum_gap / trials, 0.02);
}

TEST(CutSequence, InnerCutsComeFirstEvenWhenTheOutlineIsNearer) {
  // The outline's pierce is at the start; its two holes far inside. Nearest neighbour without
  // precedence would cut the outline first.
  SequenceProblem p;
  p.start = {0, 0};
  p.cuts.push_back({{Vector2d(1, 0)}, {Vector2d(1, 1)}, -1});
  p.cuts.push_back({{Vector2d(50, 50)}, {Vector2d(55, 50)}, 0});
  p.cuts.push_back({{Vector2d(80, 50)}, {Vector2d(85, 50)}, 0});
  for (const Sequence& s : {nearest_neighbour(p, true), optimise(p)}) {
    ASSERT_EQ(s.order.size(), 3u);
    EXPECT_EQ(s.order.back(), 0);
    EXPECT_TRUE(respects_precedence(p, s.order));
  }
  EXPECT_FALSE(respects_precedence(p, program_sequence(p).order));
}

}  // namespace
}  // namespace machplan::motion
