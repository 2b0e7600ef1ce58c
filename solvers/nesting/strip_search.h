// Shortening the last sheet by overlap minimisation with a shrinking strip, after Egeblad et al.
// (2007), Umetani et al. (2009) and the sparrow nester of Gardeyn and Wauters (2025).
//
// The search starts from a feasible nest (the bottom-left fill). Over and over it cuts the used
// length of the last sheet by a ratio, moves the parts that stood out past the new end back in
// (overlapping others), and then separates: every part that collides moves to the best of
// sampled places (anywhere in the strip, near where it is, then refined by coordinate descent,
// in every rotation allowed; a part that turns freely also at random angles, its angle refined
// with its place), the best being the least weighted overlap with the others. Pairs
// that keep colliding weigh more each round (guided local search), so the parts stop trading
// the same overlaps. When no pair collides, the shorter nest is the new best and the strip
// shrinks again; when separation stalls, the search goes back to the best nest and shrinks by
// less (then again by more, from a nest with two parts swapped).
//
// Collisions are decided exactly, on the shapes' polygons (internal/shape.h) as the bottom-left fill
// decides them, so every nest the search keeps is one the certificate accepts. Only how much two
// colliding parts overlap is estimated, from how deep their poles go into each other: a measure
// that is smooth, cheap, and zero only when they part.
//
// Movers: each round of separation, several movers (threads) each move the colliding parts from
// the same nest, in an order of their own, and the search goes on from the one that leaves the
// least weighted overlap, as sparrow's separator does. Against two searches side by side from
// different seeds it gave 0.8 points more density on average over the 13 ESICUP instances at 60 s
// (with compressing's shorter separations, as sparrow's), up to 2.9 on one, and at most 0.3 less on any.
//
// Work: each exact collision test, its steps and each pair of poles counts as set below (of
// nominal work), each round the longest mover's, so a seed and a deadline give the same nest on
// any machine.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "engine/common/progress.h"
#include "engine/common/termination.h"

#include "solvers/nesting/bottom_left.h"

namespace machplan::nesting {

// The nominal work of one exact collision test here (its steps charged as kMeetsStepCostS of
// bottom_left.h besides), of one pair of poles tested for overlap and of one measured: fitted to
// the CPU time of the search on a 2.6 GHz core, on five ESICUP instances and a job of 129 real
// parts (within 10 %; the bundled job's parts, with many arcs, take about 30 % more).
constexpr double kSearchTestCostS = 0.36e-6;
constexpr double kDeepPairCostS = 0.4e-9;
constexpr double kPoleCostS = 0.9e-9;

struct StripSearchStats {
  int shrinks_tried = 0, shrinks_kept = 0;
  std::int64_t moves = 0;
  std::int64_t tests = 0;       // exact collision tests
  std::int64_t meets_steps = 0;  // their steps: edges scanned, pairs of edges tested, vertices
  std::int64_t deep_pairs = 0;  // pairs of poles tested for overlap (whether two parts surely collide)
  std::int64_t pole_pairs = 0;  // pairs of poles measured (how much two colliding parts overlap)
  double start_length_mm = 0.0;  // the last sheet's used length before the search
  std::string note;              // why the search did not run, when it did not
};

// What nest() says while it runs, read from any thread: how much of the deadline's work is
// spent, how many sheets the fill used and the shortest used length of
// the last one found so far.
struct NestProgress {
  Progress share;
  std::atomic<int> sheets{0};
  std::atomic<double> last_length_mm{0.0};

  // A shorter last sheet: kept when it is shorter than the one reported.
  void offer_length(double mm) noexcept;
};

// The most parts on the last sheet the search takes (it keeps a weight per pair of them).
constexpr std::size_t kMostParts = 2000;

// The nest machplan gives: the bottom-left fill with restarts for a tenth of `t`'s deadline
// (a fiftieth when one fill puts every part on one sheet: restarts then only shorten it, which
// the search does better), then the strip search for the rest, with `workers` movers on as many
// threads (one: the search moves the parts itself).
// Without a deadline (a budget, or nothing): one fill.
NestResult nest(const NestRequest& request, Termination& t, std::uint64_t seed, int workers = 2,
                StripSearchStats* stats = nullptr, NestProgress* progress = nullptr);

}  // namespace machplan::nesting
