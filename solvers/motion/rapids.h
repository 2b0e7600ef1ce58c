// Re-routing a Job's rapids round no-go zones (the step between kerf compensation
// and feed planning; see engine/motion/job.h).
//
// plan_rapids walks the Job's steps in order, tracking which stretches have been cut. For
// each rapid stretch (Stretch::rapid) it plans a rapid from the stretch's first point to its
// last (solvers/motion/rapid_planner.h) among these zones:
//
//   - the declared zones (clamps and the like, read with engine/programs/zones.h), and
//   - when zones_from_cuts is set, the closed cutting contours cut before this rapid whose
//     piece may tip up into the torch's way: every outline of a part (a closed cut that an
//     even number of the job's larger closed cuts enclose: none, or a part and its hole when a
//     small part is nested in a large hole), and the holes (enclosed by an odd number) whose
//     slug is larger than RapidOptions::slug_tip_size_mm in x or y. Small slugs drop through
//     the slats or lie flat; rapids between a part's holes, and from its holes to its
//     outline, cross them straight.
//
// A cutting stretch becomes a zone when its path closes: the first segment whose end returns
// to the start of an earlier (or the same) segment of the stretch closes the loop, so a
// lead-in before the loop and a lead-out after it are left out. Lines become vertices with
// bulge 0; arcs become vertices with bulge tan(sweep / 4), an arc sweeping more than half a
// turn being split in two. A stretch that never closes (a slit, an overcut that stops mid-span)
// or whose loop encloses no area gives no zone; it is counted in open_cuts.
//
// Crossing a cut part. A rapid whose target lies inside a part (or slug) already cut, or that
// starts inside one, must cross it: that zone is left out of the rapid's plan, the rapid
// crosses it (straight when nothing else is in the way) and the torch is raised over it:
// when RapidOptions::travel_height_over_cut_mm is above the machine's retract height, the
// torch_off step before the rapid retracts to that height (Step::height_mm). Every other
// zone stays one to go round: declared zones always, and the other cut parts and slugs when
// the rapid can avoid them without entering the part it is heading into. When it cannot (no
// clear route round them), the rapid is planned again among the declared zones only and
// crosses the cut parts in its way, raised as well. The report names the parts crossed.
//
// Each rapid is planned with the cut parts marked as such, so that a straight move that
// only departs from the part just cut, or arrives beside one, is taken as it is (step 1b of
// rapid_planner.h); declared zones are always kept clear of. A re-routed rapid reports its
// extra length and which zones made the detour.
//
// What is replaced. A rapid stretch keeps its programmed segments when they are all straight
// and clear (the program's own route is respected; this includes a straight single-segment
// G0). Otherwise, when the plan succeeds, the segments are replaced by the planned polyline:
// one line per polyline edge, all with the feed and source line of the stretch's first
// segment. When the plan has no route (infeasible) the stretch is left as programmed and the
// failure is reported; the caller decides whether to run the job.
//
// Termination and progress. Every rapid is planned under the caller's Termination (each with
// its own budget of samples, see rapid_planner.h); once that ends (a stop request, its
// deadline or budget) the rapids from the one that saw it on are left as programmed and not
// reported, and the summary's status says what ended the work. `progress` (may be null)
// receives the share of the rapids planned.
//
// Complexity: the job's zones (declared ones and every closed cut that may become one) are
// indexed once (solvers/motion/rapid_zones.h) and switched on as they are cut; the nesting of
// the closed cuts (which are holes) is one ray query per cut (engine/geometry/nesting.h).
// A query of a rapid looks only at the spans near it.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/geometry/contour.h"
#include "engine/motion/job.h"
#include "solvers/motion/rapid_planner.h"

namespace machplan::motion {

struct RapidReport {
  std::size_t stretch = 0;  // index into Job::stretches
  int source_line = 0;      // of the stretch's first segment
  // The plan's: done (straight when `straight`, else a detour), infeasible (no clear route), or
  // what ended the caller's Termination.
  Status status = Status::done;
  bool straight = true;
  Eigen::Vector2d from = Eigen::Vector2d::Zero(), to = Eigen::Vector2d::Zero();
  double straight_length_mm = 0.0;    // |to - from|
  double programmed_length_mm = 0.0;  // the stretch as programmed
  double length_mm = 0.0;             // the stretch after this pass
  bool straight_blocked = false;      // see RapidPlan::straight_blocked
  bool programmed_clear = false;      // the programmed route was kept because it is clear
  bool replaced = false;              // the segments were replaced by the planned polyline
  std::size_t zone_count = 0;         // zones this rapid avoided (declared + from cuts)
  double min_clearance_mm = 0.0;      // see RapidPlan::min_clearance_mm
  double extra_length_mm = 0.0;       // length_mm - straight_length_mm
  // For a detour (re-routed round zones): the zones the straight move came too near, e.g.
  // "part cut at line 40; declared zone 1". Empty otherwise.
  std::string reason;
  // The cut parts and slugs the rapid crosses (its start or target lies inside them, or no
  // route goes round them), e.g. "part cut at line 12"; and the torch height over them, mm
  // (0: the machine's retract height, nothing raised).
  std::vector<std::string> crossed;
  double travel_height_mm = 0.0;
  std::string message;

  // Why the rapid is what it is, one phrase: "straight", "straight over part cut at line 12
  // (torch at 40 mm)", "round part cut at line 40 (+25.3 mm)", "as programmed", or the failure.
  std::string why() const;
  // The plan's route in a word, for the report's table: "straight", "detour", or the status.
  const char* route() const;
  // Re-routed round zones (not straight).
  bool detour() const { return status == Status::done && !straight; }
};

struct RapidsReport {
  std::vector<RapidReport> rapids;
  std::size_t blocked = 0;    // rapids whose straight move was blocked
  std::size_t replaced = 0;   // rapids re-routed
  std::size_t failed = 0;     // rapids with no clear route (left as programmed)
  std::size_t cut_zones = 0;  // closed cutting contours turned into zones
  std::size_t open_cuts = 0;  // cutting stretches that gave no zone
  std::size_t small_slugs = 0;  // closed holes no larger than slug_tip_size_mm: no zone
  std::size_t detours = 0;      // rapids re-routed round zones
  std::size_t crossings = 0;    // rapids that cross cut parts (RapidReport::crossed)
  double detour_extra_mm = 0.0; // their length beyond the straight moves, mm
  double straight_length_mm = 0.0;    // sum over rapids
  double programmed_length_mm = 0.0;  // sum over rapids
  double length_mm = 0.0;             // sum over rapids, after this pass
  // done; infeasible when some rapid has no clear route (failed > 0: left as programmed, the
  // caller decides); cancelled, deadline or budget when the caller's Termination ended the
  // planning. brief: one line; full: a table of the rapids, why each left the straight line,
  // and the totals.
  Summary summary;

  // The caller's Termination ended the planning before every rapid was planned.
  bool ended_early() const {
    return summary.status == Status::cancelled || summary.status == Status::deadline || summary.status == Status::budget;
  }
  bool ok() const { return failed == 0 && !ended_early(); }
};

// Plans every rapid of `job` in place (see the file comment). Throws InputError when the
// options are invalid; a rapid that cannot be planned is a report entry, not an exception.
RapidsReport plan_rapids(Job& job, const std::vector<Contour>& declared_zones, const RapidOptions& options,
                         bool zones_from_cuts, Termination& termination, Progress* progress = nullptr);

// The closed loop of a cut path (see the file comment): segments first .. last (inclusive)
// return to the start of `first`, as a Contour. Nothing when the path never closes or its
// loop encloses no area.
struct Loop {
  std::size_t first = 0, last = 0;
  Contour contour;
};
std::optional<Loop> find_loop(const std::vector<Segment>& segments, double tolerance_mm = 1e-3);

// The closed loop of a cutting stretch as a Contour (see the file comment), or nothing.
// tolerance_mm: how near a segment's end must come to an earlier start to close the loop.
std::optional<Contour> closed_loop(const Stretch& stretch, double tolerance_mm = 1e-3);

}  // namespace machplan::motion
