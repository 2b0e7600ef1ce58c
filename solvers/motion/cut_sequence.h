// The order of a job's cuts as a routing problem: which cut next, and where to pierce it, so
// that the torch travels least between cuts, inner contours always before the contour that
// encloses them. solvers/motion/cut_order.h builds this problem from a part program and puts
// the answer back into it; this file is the problem and its solvers alone.
//
// Problem. Cuts (clusters) i = 0 .. n-1. Cut i may be entered at any of its candidates
// k = 0 .. K_i - 1: the torch travels (a rapid, straight, at a cost of its length) to the
// candidate's pierce point p(i, k), cuts, and leaves it at the candidate's exit point
// e(i, k). Candidate 0 is always the program's own. The torch starts at `start` and, when
// `end` is set, must reach it after the last cut. Precedence: a cut with parent j must be cut
// before j (a hole before the outline that holds it; parents form a forest). The travel of an
// order (i_1 .. i_n) with candidates (k_1 .. k_n) is
//
//     |start - p(i_1, k_1)| + sum |e(i_m, k_m) - p(i_m+1, k_m+1)| + |e(i_n, k_n) - end|.
//
// This is a generalised travelling-salesman path with precedence constraints, NP-hard; the
// solvers below are heuristics, and `travel_lower_bound` says how far from optimal a
// solution can be.
//
// Algorithm of optimise():
//   1. Start: the nearest neighbour among the cuts whose inner cuts are all done, over every
//      candidate, from where the torch is (ties: the lower cut, then the lower candidate).
//   2. Candidates for a fixed order: a shortest path through the layers of candidates (one
//      layer per cut in order), exact, O(n K^2).
//   3. Order for fixed candidates: or-opt moves (a run of 1 to 3 consecutive cuts moved
//      between two others, kept in its direction; insertion points next to the 10 nearest
//      cuts of the run's ends) and block 2-opt (the order of whole parts, each a run of cuts
//      ending with a top-level outline, reversed between two parts; endpoints among the 8
//      nearest parts), each taken when it shortens the travel and keeps every precedence. A
//      precedence test is O(length of the run), not O(n).
//   4. Steps 2 and 3 alternate until a round gains less than 1 um (or `max_rounds`).
//   Steps 2 to 4 run from three starts: the nearest neighbour over every candidate, over the
//   programmed candidates only, and the program's own order when it keeps the precedences;
//   the shortest result is the answer, never longer than any of the three.
//   optimise() is deterministic (no random choices).
//
// Bound. travel_lower_bound() is the larger of two bounds no order can beat: (a) every cut
// is entered once, from the start or from the exit of a cut that may come before it (not one
// that holds it): the sum over cuts of the shortest such entry; besides, the first cut of
// each part (a tree of the precedence forest), which has no inner cuts, is entered from
// outside the part, so for each part the least extra that costs over its shortest entry is
// added; and the last cut, one with no parent, reaches `end`; (b) the travel's rapids join the
// start, the cuts and the end into a path, a spanning tree: the minimum spanning tree of the
// nodes with, between two cuts, the least distance between a pierce of one and an exit of
// the other (Prim's algorithm, pairs pruned by their boxes). Precedences are ignored, so the
// bound is below the constrained optimum too.
//
// Work: nearest_neighbour O(n^2 K); a round of step 3 about O(n (3 x 10 + 8 x parts' length));
// the bound O(n^2) box tests and far fewer exact ones. 1,000 cuts order in well under a
// second (bench/cut_order_bench.cpp).
//
// Thread safety: pure functions.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace machplan::motion {

struct SequenceProblem {
  struct Cut {
    std::vector<Eigen::Vector2d> pierce, exit;  // per candidate; candidate 0 is the program's
    int parent = -1;                            // must come after this cut; -1: none
  };
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  std::optional<Eigen::Vector2d> end;
  std::vector<Cut> cuts;
};

struct Sequence {
  std::vector<int> order;  // cut indices
  std::vector<int> entry;  // per position in `order`: the candidate taken
  double travel_mm = 0.0;
};

// The travel of `order` with `entry` (see the file comment).
double travel_mm(const SequenceProblem& p, const std::vector<int>& order, const std::vector<int>& entry);

// Whether every cut comes before its parent.
bool respects_precedence(const SequenceProblem& p, const std::vector<int>& order);

// The program's own order and candidates: 0, 1, .. n-1, all candidate 0 (it may not respect
// the precedences).
Sequence program_sequence(const SequenceProblem& p);

// Nearest neighbour among the cuts whose children are done; over candidate 0 only
// (`programmed_pierces`), or over every candidate.
Sequence nearest_neighbour(const SequenceProblem& p, bool programmed_pierces);

// The best candidates for a fixed order (step 2 of the file comment); fills entry and travel.
void choose_entries(const SequenceProblem& p, Sequence& s);

struct SequenceOptions {
  int max_rounds = 50;  // rounds of steps 2 and 3 at most
};

// Steps 1 to 4 of the file comment.
Sequence optimise(const SequenceProblem& p, const SequenceOptions& options = {});

// See "Bound" in the file comment, mm.
double travel_lower_bound(const SequenceProblem& p);

}  // namespace machplan::motion
