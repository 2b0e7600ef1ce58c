// A first nest by bottom-left fill: each copy, largest first, goes to the leftmost place it
// fits on the first sheet that has one (then as low as it goes there), in the best of the
// allowed rotations (the one whose right edge stays leftmost), then slides left and down
// while it fits. Leftmost first because the sheet's used length, along x from its left edge, is
// what the objective keeps short after the number of sheets (the remnant left is the rest).
//
// Collisions are tested on the parts grown by half the spacing and approximated from outside
// (outline.h), with meets() (internal/shape.h) behind an R-tree of their boxes: two parts
// whose polygons do not meet are at least the spacing apart. A part's holes, shrunk by half the
// spacing and approximated from inside, are holes of its polygon: smaller parts go in them
// (part in part) when they keep the spacing from the hole's edge.
//
// The places tried: the sheet's lower left corner, the positions that put the copy's box
// against another part's box (to its right, above it, below it), and in each hole's box its
// lower left corner and its centre; then the slides find the
// interlocking positions boxes miss.
//
// Restarts: the first fill takes the copies largest first; each further one takes the best
// order found so far with a few copies swapped (seeded), and is kept when it needs fewer sheets
// or a shorter last sheet. Until the Termination ends: each collision test is charged as
// kTestCostS of nominal work and each step of its exact test (edges scanned, pairs of edges,
// vertices) as kMeetsStepCostS, so a deadline (set_deadline) and a seed give the same nest on any
// machine; a stop returns the best nest found so far. Without a limit, one fill.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/common/termination.h"

#include "solvers/nesting/certificate.h"
#include "solvers/nesting/part.h"
#include "solvers/nesting/placement.h"

namespace machplan::nesting {

struct NestRequest {
  std::vector<NestPart> parts;
  std::vector<int> quantity;            // per part, >= 1
  std::vector<double> rotations_deg{0.0};  // tried for every part without rotations of its own
  std::vector<std::vector<double>> rotations;  // per part, when given (an empty one: rotations_deg)
  // Parts that turn freely: by any angle in the strip search, and by their rotations and the four
  // that square their box (squaring_rotations) in the fill. Per part when given, else `any_rotation`.
  bool any_rotation = false;
  std::vector<bool> any_rotations;
  bool turns_freely(std::size_t part) const { return any_rotations.empty() ? any_rotation : any_rotations[part]; }
  std::vector<int> priority;            // per part, when given: lower first (must-nest parts), then fillers
  std::vector<bool> mirror;             // per part, when given: mirrored copies tried too
  std::vector<Sheet> sheets;            // one each, filled in this order
  double spacing_mm = 0.0;
  double tolerance_mm = 0.05;           // of the outside polygons (more spacing, never less)
};

struct Unplaced {
  std::size_t part = 0;
  int copy = 0;
  std::string reason;
};

struct NestResult {
  std::vector<Placement> placements;
  std::vector<Unplaced> unplaced;
  int sheets_used = 0;                  // sheets with a part on them
  std::vector<double> used_length_mm;   // per sheet of the request: the parts' right edge (0: none)
  double last_length_mm() const;        // of the last sheet with a part
  int fills = 0;                        // bottom-left fills made (restarts + 1)
};

// The nominal work of one collision test (a box query and the polygon tests it leads to).
// Fitted to the CPU time on a 2.6 GHz core (bench/results/nesting.txt): fills of the bundled
// jobs and of 129 real parts within 10 %.
constexpr double kTestCostS = 0.2e-6;
constexpr double kMeetsStepCostS = 0.93e-9;

// Throws InputError naming the field for a request it cannot take (no part, a quantity < 1,
// a sheet without a usable area, a negative spacing, no rotation, no sheet).
NestResult bottom_left_nest(const NestRequest& request);
// With restarts until `t` ends (see the file comment), from `seed`.
NestResult bottom_left_nest(const NestRequest& request, Termination& t, std::uint64_t seed);

}  // namespace machplan::nesting
