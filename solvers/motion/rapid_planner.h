// Torch-off moves (rapids) that keep away from no-go zones: clamps, and parts already cut
// that may tip up in the skeleton.
//
// Problem. The tool centre travels from `from` to `to` in the XY plane. Each no-go zone is a
// closed Contour, read as a filled region. A point is *clear* when its distance to every zone
// region (0 inside the region, else the distance to its boundary) is at least
// RapidOptions::clearance_mm; a straight move is clear when every point of it is. A rapid is
// a polyline whose every segment is clear.
//
// Algorithm.
//
//  1. Straight first. If the straight segment from -> to is clear it is the answer
//     (status straight) and OMPL is not called. A rapid with from == to is straight whatever
//     the zones (it moves nothing).
//
//  1b. Leaving a cut part directly. The zones from index first_part_zone on are parts cut
//     before this rapid (declared zones come first and are never relaxed here). A rapid that
//     starts on the part just cut, or ends beside one, is straight when the straight move
//     (a) keeps the full clearance from every zone over its middle, farther than
//     2 clearance_mm from both ends, (b) on each end leg (the first and last 2 clearance_mm)
//     keeps the full clearance from every zone except the parts whose clearance band holds
//     that end, and (c) does not enter those parts' regions. The torch departs from (or
//     arrives at) the part's edge; it never passes over a part it could catch. Status
//     straight, straight_blocked false.
//
//  2. Leaving an end point's zone. A rapid often starts on a contour that was just cut (the
//     torch stops on the part's edge) or ends at a pierce point under or beside a clamp. Such
//     an end point is not clear, so no planner could start there. Rule: the zones whose region
//     is within clearance_mm of the end point are *relaxed* for one short straight "escape"
//     leg that leaves them by the shortest way: from the nearest boundary point along the
//     outward normal to clearance_mm (for a point inside a zone this crosses the zone: there is
//     no other way out). At most a few such pushes are made when the escape point falls into
//     another zone's band. The escape leg must be clear of every zone that was not relaxed,
//     and the escape point must be clear of all zones; otherwise the status is
//     endpoint_blocked. The relaxed zones are reported; every other part of the rapid keeps
//     the full clearance from every zone. With escapes, step 1 tests the segment between the
//     two escape points.
//
//  3. Sampling-based search with OMPL's RRT-Connect in a 2-D RealVectorStateSpace bounded by
//     the machine's travel box. Why RRT-Connect: a rapid is a single query whose zones change
//     from one rapid to the next (each cut adds a part), so PRM's reusable roadmap buys
//     nothing; RRT* spends its time on asymptotic optimality that the exact shortcutting of
//     step 4 delivers far more cheaply in the plane; RRT-Connect's two greedy trees find a
//     path around a few obstacles in a handful of samples and cope with the narrow gaps
//     between clamps. Validity is exact, never sampled along a motion:
//       - a state is valid when it lies in the bounds and, for every zone, it is outside the
//         zone (winding number) and its distance to the contour is >= clearance_mm;
//       - a motion is valid when the exact distance from the segment to every span of every
//         zone (line-line and line-arc distance computed from the span geometry, see
//         segment_distance_mm) is >= clearance_mm and its start is outside the zone. A
//         segment that stays clearance_mm > 0 away from the boundary cannot cross it, so
//         "start outside" makes the whole segment outside. Nothing can hide between samples.
//     Several attempts with derived seeds run one after the other; the shortest result
//     after step 4 is kept (a single tree may go round the long side of a zone).
//
//  4. Shortening: OMPL's PathSimplifier (vertex reduction and shortcutting between points
//     on the path, both with the exact motion check), then a deterministic tightening of our
//     own: greedy string pulling (each vertex is joined to the farthest later vertex it sees)
//     and moving each interior vertex towards the chord of its neighbours by bisection while
//     both adjacent segments stay clear (the path length is convex in the vertex position,
//     so every accepted move shortens the path).
//
//  5. Smoothing: OMPL's B-spline smoothing (repeated subdivision and corner averaging, every
//     change checked with the exact motion check) followed by removal of vertices that are
//     nearly collinear with their neighbours. The result is validated again, segment by
//     segment; should it fail, the unsmoothed path is returned (and the message says so).
//     On a path that is already taut around a zone the corners that touch the clearance band
//     cannot be rounded without entering it, so smoothing mostly rounds the other corners.
//
// Termination. plan_rapid takes the caller's Termination (engine/common/termination.h) and
// gives the search a child of it with a budget of RapidOptions::max_samples sampled states
// over all attempts; every sample is charged to it (one unit, and kSampleWorkS seconds of
// work for a caller's deadline). When the rapid's own budget is spent without a path the
// status is no_path; when the caller's Termination ends first (a stop request, its deadline
// or its budget) the status is `cancelled` and the message says which. Every limit counts
// work, never the wall clock, so the same inputs give the same plan on any machine, however
// loaded.
//
// Determinism. OMPL's RNG::setSeed() only seeds the process-wide generator that hands out
// seeds to RNG instances, and it has an effect only before the first RNG is created in the
// process (later calls log an error and change nothing), so it cannot make two plans in one
// process repeat. We therefore never rely on the global seed: the state sampler, the planner
// and the path simplifier each get a local seed (RNG::setLocalSeed) derived from
// RapidOptions::seed and the attempt number, the trees use the linear nearest-neighbour
// structure (OMPL's default GNAT picks pivots with its own unseeded RNG), and the budget is
// counted in samples. Same inputs + seed -> same polyline, in any process and
// in any order of calls. plan_rapid is thread-safe (it shares nothing but OMPL's
// mutex-protected seed generator).
//
// Units: mm. Nothing here throws on geometry; RapidOptions::validate() throws
// InputError::field naming the field, its value and the rule, and plan_rapid calls it.
//
// Example:
//
//     std::vector<Contour> clamps = {Contour({{-50, -20}, {50, -20}, {50, 20}, {-50, 20}},
//                                            {0, 0, 0, 0})};
//     RapidOptions o;                  // 5 mm clearance, seed 1
//     Termination never;               // no stop, deadline or budget of the caller's
//     RapidPlan p = plan_rapid({-150, 0}, {150, 0}, clamps, o, never);
//     // p.status == Status::done, !p.straight, p.straight_blocked, p.length_mm about 306.2 (the shortest
//     // clear curve is 306.17),
//     // p.min_clearance_mm >= 5
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/geometry/contour.h"
#include "solvers/motion/rapid_zones.h"

namespace machplan::motion {

struct RapidOptions {
  // How far the tool centre keeps from every zone, mm. Must be > 0 (with 0 a segment could
  // graze a boundary and the "outside" test of a motion would no longer be exact).
  double clearance_mm = 5.0;
  // The machine's travel box, mm. Every point of a planned rapid stays inside it. Empty (the
  // default): a box around the end points and all zones, grown by auto_margin_mm.
  Eigen::AlignedBox2d bounds;
  // Margin of the automatic box, mm (>= 0). It must leave room to pass round the outermost
  // zones: at least 2 * clearance_mm is sensible.
  double auto_margin_mm = 50.0;
  // Total number of sampled states over all attempts before giving up, infeasible (>= 1,
  // <= 10 000 000). A rapid round a few zones needs tens to a few hundred.
  int max_samples = 20000;
  // Independent RRT-Connect runs (derived seeds); the shortest shortened path wins (1 .. 100).
  int attempts = 3;
  // Seed of all random choices. Same inputs and seed give the same path.
  std::uint32_t seed = 1;
  // Shorten the planner's path (step 4). Without it the raw tree path is returned.
  bool simplify = true;
  // Smooth the shortened path (step 5).
  bool smooth = true;
  // plan_rapids only (rapids.h): holes whose slug is larger than this in x or y are kept
  // clear of like parts; smaller ones are crossed, mm (>= 0).
  double slug_tip_size_mm = 50.0;
  // plan_rapids only: the torch height over the table while a rapid crosses a part already
  // cut (the machine file's travel_height_over_cut_mm), mm. 0: the machine's usual retract
  // height (nothing is raised); otherwise the torch_off step before such a rapid retracts to
  // this height (Step::height_mm), whichever is higher. In [0, 1000].
  double travel_height_over_cut_mm = 0.0;

  // Throws InputError::field naming the field, its value and the rule it breaks.
  void validate() const;
};

// Work charged per sampled state, s: a nominal figure (about what a sample costs round a few
// zones), so that a caller's deadline in seconds of work bounds rapid planning in the same
// units as everything else, and decides the same way on any machine.
inline constexpr double kSampleWorkS = 50e-6;

struct RapidPlan {
  // done: a clear route (straight, or a detour); infeasible: none (max_samples spent without a
  // path, the goal or start walled in; an end point that cannot leave its zones' clearance
  // band, step 2; from or to outside RapidOptions::bounds), the message says which;
  // cancelled, deadline or budget: the caller's Termination ended the search.
  Status status = Status::infeasible;
  // done only: the route is the straight move, polyline = {from, to}; otherwise a detour (or
  // a straight move between escape legs).
  bool straight = false;
  // from ... to when done; empty otherwise.
  std::vector<Eigen::Vector2d> polyline;
  double length_mm = 0.0;           // length of polyline (0 when empty)
  double straight_length_mm = 0.0;  // |to - from|
  // The straight segment from -> to comes closer than clearance_mm to some zone (always true
  // when an end point lies in a zone's clearance band).
  bool straight_blocked = false;
  // Smallest distance from the polyline, escape legs excluded, to any zone region, mm
  // (+infinity with no zones or an empty polyline). >= clearance_mm when done, except a rapid
  // of zero length.
  double min_clearance_mm = 0.0;
  // Zones (indices into no_go) relaxed for the escape leg at the start / at the end.
  std::vector<std::size_t> start_zones, end_zones;
  bool smoothed = false;  // the smoothing step changed the returned path
  int samples = 0;        // states sampled by the planner (0 when OMPL was not called)
  std::string message;

  bool ok() const { return status == Status::done; }
};

// Plans one rapid; see the file comment. Throws InputError when the options are invalid and
// InternalError when from/to are not finite (the job's positions are); every other outcome
// is a status.
// Zones at index >= first_part_zone are cut parts, which step 1b may leave directly; the
// default makes every zone a declared one. `termination` is the caller's (see Termination).
RapidPlan plan_rapid(const Eigen::Vector2d& from, const Eigen::Vector2d& to,
                     const std::vector<Contour>& no_go, const RapidOptions& options, Termination& termination,
                     std::size_t first_part_zone = static_cast<std::size_t>(-1));

// The same among the active zones of a ZoneSet built once for many rapids (plan_rapids).
// The ZoneSet's clearance is the one used; options.clearance_mm must equal it.
RapidPlan plan_rapid(const Eigen::Vector2d& from, const Eigen::Vector2d& to, const ZoneSet& zones,
                     const RapidOptions& options, Termination& termination,
                     std::size_t first_part_zone = static_cast<std::size_t>(-1));

}  // namespace machplan::motion
