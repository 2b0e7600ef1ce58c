#include "solvers/motion/rapids.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "engine/geometry/nesting.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

// How deep a route must go into a cut part to count as crossing it (not merely leaving its
// edge), mm.
constexpr double kCrossingDepthMm = 1e-3;

double stretch_length(const Stretch& s) {
  double sum = 0.0;
  for (const Segment& g : s.segments) sum += length(g);
  return sum;
}

// Appends span g to a vertex/bulge list (its start vertex and bulge), splitting arcs of more
// than half a turn so that every bulge stays within [-1, 1].
void append_span(const Segment& g, std::vector<Vector2d>& v, std::vector<double>& b) {
  if (!g.is_arc()) {
    v.push_back(g.start);
    b.push_back(0.0);
    return;
  }
  if (std::abs(g.sweep) > std::numbers::pi) {
    v.push_back(g.start);
    b.push_back(std::tan(g.sweep / 8.0));
    v.push_back(point_at(g, 0.5));
    b.push_back(std::tan(g.sweep / 8.0));
    return;
  }
  v.push_back(g.start);
  b.push_back(std::tan(g.sweep / 4.0));
}

int first_line(const Stretch& s, int fallback) { return s.source_lines.empty() ? fallback : s.source_lines.front(); }

// The job's zones: the declared ones (always on), then every closed cut that becomes a zone
// once cut (part outlines, and holes whose slug may tip), each with its label.
struct JobZones {
  std::optional<ZoneSet> set;
  std::vector<std::string> labels;
  std::size_t declared = 0;
  std::vector<std::size_t> zone_of_stretch;  // zone index, or npos: no zone
  std::size_t open_cuts = 0, small_slugs = 0;
};

constexpr std::size_t kNone = static_cast<std::size_t>(-1);

JobZones job_zones(const Job& job, const std::vector<Contour>& declared, const RapidOptions& options,
                   bool zones_from_cuts) {
  JobZones z;
  z.declared = declared.size();
  z.zone_of_stretch.assign(job.stretches.size(), kNone);
  std::vector<Contour> contours = declared;
  for (std::size_t i = 0; i < declared.size(); ++i) z.labels.push_back(fmt::format("declared zone {}", i + 1));
  if (zones_from_cuts) {
    std::vector<Contour> loops;
    std::vector<std::size_t> loop_stretch;
    for (std::size_t i = 0; i < job.stretches.size(); ++i) {
      const Stretch& s = job.stretches[i];
      if (!s.cutting || s.rapid || s.segments.empty()) continue;
      if (auto loop = closed_loop(s)) {
        loops.push_back(std::move(*loop));
        loop_stretch.push_back(i);
      } else {
        ++z.open_cuts;
      }
    }
    // A hole lies inside an odd number of larger closed cuts: a part nested in another part's
    // hole lies inside two and is a part again.
    const Nesting nesting = nest_contours(loops);
    for (std::size_t k = 0; k < loops.size(); ++k) {
      const Stretch& s = job.stretches[loop_stretch[k]];
      const int line = first_line(s, 0);
      if (nesting.depth[k] % 2 == 1) {
        const Vector2d size = bounding_box(loops[k]).sizes();
        if (size.maxCoeff() <= options.slug_tip_size_mm) {
          ++z.small_slugs;
          continue;
        }
        z.labels.push_back(fmt::format("slug of the hole cut at line {} ({:.1f} x {:.1f} mm)", line, size.x(), size.y()));
      } else {
        z.labels.push_back(fmt::format("part cut at line {}", line));
      }
      z.zone_of_stretch[loop_stretch[k]] = contours.size();
      contours.push_back(std::move(loops[k]));
    }
  }
  z.set.emplace(std::move(contours), options.clearance_mm);
  for (std::size_t j = z.declared; j < z.set->size(); ++j) z.set->set_active(j, false);  // not cut yet
  return z;
}

// The cut parts (active zones past the declared ones) that hold p well inside.
std::vector<std::size_t> cut_parts_holding(const JobZones& z, const Vector2d& p) {
  std::vector<std::size_t> out;
  for (std::size_t j : z.set->holding(p))
    if (j >= z.declared && distance(z.set->contour(j), p) > kCrossingDepthMm) out.push_back(j);
  return out;
}

// The route of a rapid stretch as a polyline, and whether it is all straight lines.
std::vector<Vector2d> route_of(const Stretch& s, bool& straight_lines) {
  straight_lines = true;
  std::vector<Vector2d> route{s.segments.front().start};
  for (const Segment& g : s.segments) {
    straight_lines = straight_lines && !g.is_arc();
    route.push_back(g.end);
  }
  return route;
}

// The torch_off step before move step `k` (none when a torch_on or the start comes first).
std::size_t torch_off_before(const Job& job, std::size_t k) {
  for (std::size_t i = k; i-- > 0;) {
    if (job.steps[i].kind == Step::Kind::torch_off) return i;
    if (job.steps[i].kind == Step::Kind::torch_on) return kNone;
  }
  return kNone;
}

// One rapid: planned among the active zones with the cut parts it must enter left out, and,
// when that finds no route, among the declared zones only. Replaces the stretch's segments
// when the plan is kept, and names the cut parts the final route crosses.
RapidReport plan_one(Job& job, std::size_t step_index, JobZones& z, const RapidOptions& options,
                     Termination& termination, bool& ended) {
  const Step& step = job.steps[step_index];
  Stretch& s = job.stretches[step.stretch];
  ZoneSet& zones = *z.set;
  RapidReport r;
  r.stretch = step.stretch;
  r.source_line = first_line(s, step.source_line);
  r.from = s.segments.front().start;
  r.to = s.segments.back().end;
  r.straight_length_mm = (r.to - r.from).norm();
  r.programmed_length_mm = stretch_length(s);

  // The cut parts it starts or ends inside are crossed: leave them out of the plan.
  std::vector<std::size_t> entered = cut_parts_holding(z, r.to);
  for (std::size_t j : cut_parts_holding(z, r.from))
    if (std::find(entered.begin(), entered.end(), j) == entered.end()) entered.push_back(j);
  std::vector<std::size_t> off = entered;
  for (std::size_t j : off) zones.set_active(j, false);
  RapidPlan plan = plan_rapid(r.from, r.to, zones, options, termination, z.declared);
  const auto ended_by_caller = [](const RapidPlan& p) { return !p.ok() && p.status != Status::infeasible; };
  if (!plan.ok() && !ended_by_caller(plan)) {
    // No route round the other cut parts either: cross them too (declared zones still hold).
    std::vector<std::size_t> more;
    for (std::size_t j = z.declared; j < zones.size(); ++j)
      if (zones.active(j)) more.push_back(j);
    if (!more.empty()) {
      for (std::size_t j : more) zones.set_active(j, false);
      const RapidPlan retry = plan_rapid(r.from, r.to, zones, options, termination, z.declared);
      if (retry.ok() || ended_by_caller(retry)) plan = retry;
      off.insert(off.end(), more.begin(), more.end());
      if (!retry.ok()) {
        for (std::size_t j : more) zones.set_active(j, true);
        off.resize(entered.size());
      }
    }
  }
  ended = ended_by_caller(plan);
  r.zone_count = 0;
  for (std::size_t j = 0; j < zones.size(); ++j) r.zone_count += zones.active(j) ? 1 : 0;
  r.status = plan.status;
  r.straight = plan.straight;
  r.straight_blocked = plan.straight_blocked;
  r.message = plan.message;

  // Keep the programmed route when it is straight lines and clear of every zone, or when it
  // is the one straight move the plan found clear (step 1b of rapid_planner.h).
  bool lines = true;
  const std::vector<Vector2d> programmed = route_of(s, lines);
  const double programmed_clearance = zones.polyline_distance(programmed);
  const bool one_straight = programmed.size() == 2 && lines;
  r.programmed_clear = lines && (programmed_clearance >= options.clearance_mm ||
                                 (one_straight && plan.ok() && plan.straight));
  if (r.programmed_clear) {
    r.min_clearance_mm = programmed_clearance;
    if (!(plan.ok() && plan.straight)) r.message = "the programmed route is clear; kept";
  } else if (plan.ok()) {
    const double feed = s.feed_mm_per_s.empty() ? 0.0 : s.feed_mm_per_s.front();
    const int line = r.source_line;
    s.segments.clear();
    s.feed_mm_per_s.clear();
    s.source_lines.clear();
    for (std::size_t i = 1; i < plan.polyline.size(); ++i) {
      s.segments.push_back(make_segment(plan.polyline[i - 1], plan.polyline[i], 0.0));
      s.feed_mm_per_s.push_back(feed);
      s.source_lines.push_back(line);
    }
    r.replaced = true;
    r.min_clearance_mm = plan.min_clearance_mm;
  } else {
    r.min_clearance_mm = programmed_clearance;
  }
  r.length_mm = stretch_length(s);
  r.extra_length_mm = r.length_mm - r.straight_length_mm;
  if (r.replaced && r.detour()) {
    // Why: the zones the straight move comes too near (those it merely leaves or reaches at
    // an end are named too: their band held the end point).
    for (std::size_t j = 0; j < zones.size(); ++j)
      if (zones.active(j) && zones.segment_distance(r.from, r.to, j, options.clearance_mm) < options.clearance_mm) {
        if (!r.reason.empty()) r.reason += "; ";
        r.reason += z.labels[j];
      }
  }

  // The cut parts left out of the plan that the final route actually crosses.
  for (std::size_t j : off) zones.set_active(j, true);
  bool unused = true;
  const std::vector<Vector2d> final_route = route_of(s, unused);
  std::sort(off.begin(), off.end());
  for (std::size_t j : off)
    if (zones.enters(final_route, j, kCrossingDepthMm)) r.crossed.push_back(z.labels[j]);
  if (!r.crossed.empty() && options.travel_height_over_cut_mm > 0.0) {
    const std::size_t k = torch_off_before(job, step_index);
    if (k != kNone) {
      job.steps[k].height_mm = std::max(job.steps[k].height_mm, options.travel_height_over_cut_mm);
      r.travel_height_mm = job.steps[k].height_mm;
    }
  }
  return r;
}

void add_up(RapidsReport& report, const RapidReport& r) {
  if (r.replaced && r.detour()) {
    ++report.detours;
    report.detour_extra_mm += r.extra_length_mm;
  }
  report.crossings += r.crossed.empty() ? 0 : 1;
  report.blocked += r.straight_blocked ? 1 : 0;
  report.replaced += r.replaced ? 1 : 0;
  report.failed += (!r.replaced && !r.programmed_clear && !(r.status == Status::done && r.straight)) ? 1 : 0;
  report.straight_length_mm += r.straight_length_mm;
  report.programmed_length_mm += r.programmed_length_mm;
  report.length_mm += r.length_mm;
}

void summarise(RapidsReport& report, const Termination& termination, bool ended) {
  Summary& s = report.summary;
  if (ended) {
    s.status = status_of(termination.reason());
    s.message = fmt::format("{}: the rapids from the {}th on are left as programmed", termination.describe(),
                            report.rapids.size() + 1);
  } else if (report.failed > 0) {
    s.status = Status::infeasible;
    s.message = fmt::format("{} rapid{} without a clear route, left as programmed", report.failed,
                            report.failed == 1 ? "" : "s");
  }
  const std::size_t straight = report.rapids.size() - report.detours;
  s.brief = fmt::format("{} rapids: {} as straight or programmed, {} round zones (+{:.1f} mm), {} over cut parts, {} "
                        "without a clear route; {:.1f} mm in all (straight {:.1f} mm)",
                        report.rapids.size(), straight, report.detours, report.detour_extra_mm, report.crossings,
                        report.failed, report.length_mm, report.straight_length_mm);
  std::string out = fmt::format("{:>7} {:>5} {:>16} {:>10} {:>10} {:>10} {:>8}  {}\n", "stretch", "line", "route",
                                "straight", "programmed", "final", "clear", "why");
  for (const RapidReport& r : report.rapids) {
    const std::string clear =
        std::isinf(r.min_clearance_mm) ? std::string("-") : fmt::format("{:.2f}", r.min_clearance_mm);
    out += fmt::format("{:>7} {:>5} {:>16} {:>10.2f} {:>10.2f} {:>10.2f} {:>8}  {}; {}\n", r.stretch, r.source_line,
                       r.route(), r.straight_length_mm, r.programmed_length_mm, r.length_mm, clear, r.why(),
                       r.message);
  }
  out += fmt::format(
      "{} rapids: {} blocked straight, {} re-routed, {} without a clear route; {} zones from cuts, {} small slugs "
      "crossed, {} open cuts; {} over cut parts\n"
      "length: straight {:.2f} mm, programmed {:.2f} mm, final {:.2f} mm; {} detours, {:.2f} mm extra\n",
      report.rapids.size(), report.blocked, report.replaced, report.failed, report.cut_zones, report.small_slugs,
      report.open_cuts, report.crossings, report.straight_length_mm, report.programmed_length_mm, report.length_mm,
      report.detours, report.detour_extra_mm);
  if (!s.message.empty()) out += s.message + "\n";
  s.full = std::move(out);
}

}  // namespace

std::optional<Loop> find_loop(const std::vector<Segment>& segs, double tolerance_mm) {
  for (std::size_t j = 0; j < segs.size(); ++j)
    for (std::size_t i = 0; i <= j; ++i) {
      if ((segs[j].end - segs[i].start).norm() > tolerance_mm) continue;
      // A single line cannot close; a zero-length segment closes nothing.
      if (length(segs[j]) == 0.0) continue;
      std::vector<Vector2d> v;
      std::vector<double> b;
      for (std::size_t k = i; k <= j; ++k) append_span(segs[k], v, b);
      try {
        Contour c(std::move(v), std::move(b));
        if (orientation(c, 1e-6) == Orientation::degenerate) return std::nullopt;
        return Loop{i, j, std::move(c)};
      } catch (const InputError&) {
        return std::nullopt;  // non-finite or absurd coordinates: no zone
      }
    }
  return std::nullopt;
}

std::optional<Contour> closed_loop(const Stretch& stretch, double tolerance_mm) {
  std::optional<Loop> loop = find_loop(stretch.segments, tolerance_mm);
  if (!loop) return std::nullopt;
  return std::move(loop->contour);
}

std::string RapidReport::why() const {
  const std::string over =
      crossed.empty() ? std::string()
                      : fmt::format(" over {}{}", fmt::join(crossed, "; "),
                                    travel_height_mm > 0 ? fmt::format(" (torch at {:g} mm)", travel_height_mm) : "");
  if (replaced && detour())
    return fmt::format("round {} (+{:.1f} mm){}", reason.empty() ? "the zones at its ends" : reason, extra_length_mm, over);
  if (programmed_clear) return (programmed_length_mm > straight_length_mm + 1e-9 ? "as programmed" : "straight") + over;
  if (replaced) return "straight" + over;
  return fmt::format("NOT CLEAR, left as programmed ({})", to_string(status));
}

const char* RapidReport::route() const {
  if (status != Status::done) return to_string(status);
  return straight ? "straight" : "detour";
}

RapidsReport plan_rapids(Job& job, const std::vector<Contour>& declared_zones, const RapidOptions& options,
                         bool zones_from_cuts, Termination& termination, Progress* progress) {
  options.validate();
  RapidsReport report;
  JobZones z = job_zones(job, declared_zones, options, zones_from_cuts);
  report.open_cuts = z.open_cuts;
  report.small_slugs = z.small_slugs;
  std::vector<char> done(job.stretches.size(), 0);
  std::size_t rapid_total = 0, rapid_done = 0;
  for (const Stretch& s : job.stretches) rapid_total += s.rapid && !s.segments.empty();
  bool ended = false;
  for (std::size_t k = 0; k < job.steps.size() && !ended; ++k) {
    const Step& step = job.steps[k];
    if (step.kind != Step::Kind::move || step.stretch >= job.stretches.size() || done[step.stretch]) continue;
    done[step.stretch] = 1;
    const Stretch& s = job.stretches[step.stretch];
    if (s.segments.empty()) continue;
    if (s.cutting && !s.rapid) {
      if (z.zone_of_stretch[step.stretch] != kNone) {
        z.set->set_active(z.zone_of_stretch[step.stretch], true);
        ++report.cut_zones;
      }
      continue;
    }
    if (!s.rapid) continue;
    if (termination.should_end()) {
      ended = true;
      break;
    }
    RapidReport r = plan_one(job, k, z, options, termination, ended);
    if (ended) break;
    add_up(report, r);
    report.rapids.push_back(std::move(r));
    if (rapid_total > 0) report_progress(progress, static_cast<double>(++rapid_done) / static_cast<double>(rapid_total));
  }
  summarise(report, termination, ended);
  return report;
}

}  // namespace machplan::motion
