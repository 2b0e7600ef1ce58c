// Joining runs of lines and arcs end to end into chains: how the pieces of a drawing (lines,
// arcs and polylines drawn one by one, in any order and direction) become contours.
//
//   std::vector<SpanRun> runs = ...;          // each with its caller's id in `parts`
//   Chaining c = chain_runs(runs, 0.01);      // ends within 0.01 mm are joined
//   // c.closed: the closed chains (contours), c.open: what could not close.
//
// A closed run is a chain by itself. The open ones are chained: starting from the first
// unused run in input order, the chain's free end is joined to the nearest free end of another
// run within the tolerance (a run is reversed when its end, not its start, is the nearer), and
// the chain closes when its own start is the nearest end within tolerance; when the end meets
// nothing, the chain is grown from its start the same way. A gap below the tolerance is closed
// by keeping the earlier run's point. Ties go to the run earlier in the input, then to its
// start. A chain keeps the direction of its first run where it can.
//
// Work: the free ends sit in a grid of square cells at least one tolerance wide, so that every
// end within the tolerance of a point lies in its cell or the eight around it; chaining n runs
// costs O(n) lookups and O(n) memory, never a pass over the drawing per join.
//
// Thread safety: pure functions.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

namespace machplan {

// An oriented run of spans, as Contour stores them: bulge i is the span from vertex i to
// vertex i + 1 (to vertex 0 for the last one of a closed run), so an open run has
// vertices.size() - 1 bulges and a closed one vertices.size().
struct SpanRun {
  std::vector<Eigen::Vector2d> vertices;
  std::vector<double> bulges;
  bool closed = false;
  // The caller's ids of the runs this one is made of, in chain order (one for an input run).
  std::vector<std::size_t> parts;

  const Eigen::Vector2d& front() const { return vertices.front(); }
  const Eigen::Vector2d& back() const { return vertices.back(); }
  // The same spans the other way round (bulges negated).
  void reverse();
  // Total length of the spans, mm.
  double length() const;
  // Appends `next`, whose first vertex stands for this run's last one.
  void append(const SpanRun& next);
};

// A join across a gap wider than the caller asked to hear about.
struct ChainJoin {
  std::size_t from = 0, to = 0;  // parts: the end of one chain, the start of what joined it
  double gap_mm = 0.0;
  Eigen::Vector2d at = Eigen::Vector2d::Zero();  // the end kept
};

struct Chaining {
  std::vector<SpanRun> closed;  // in the order they were closed
  std::vector<SpanRun> open;    // each in the direction of its first run where possible
  std::vector<ChainJoin> joins; // gaps wider than `note_gaps_above_mm` that were closed
};

// Chains `runs` at `tolerance_mm` (> 0), as described above. Every join whose gap exceeds
// `note_gaps_above_mm` is listed in Chaining::joins (healing wide gaps, a caller reports them).
Chaining chain_runs(const std::vector<SpanRun>& runs, double tolerance_mm,
                    double note_gaps_above_mm = std::numeric_limits<double>::infinity());

}  // namespace machplan
