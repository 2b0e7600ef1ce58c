#include "solvers/motion/rapids.h"

#include <cmath>
#include <optional>
#include <limits>
#include <numbers>

#include <fmt/format.h>

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

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

}  // namespace

std::optional<Contour> closed_loop(const Stretch& stretch, double tolerance_mm) {
  const auto& segs = stretch.segments;
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
        return c;
      } catch (const InputError&) {
        return std::nullopt;  // non-finite or absurd coordinates: no zone
      }
    }
  return std::nullopt;
}

RapidsReport plan_rapids(Job& job, const std::vector<Contour>& declared_zones, const RapidOptions& options,
                         bool zones_from_cuts) {
  options.validate();
  RapidsReport report;
  std::vector<Contour> zones = declared_zones;
  std::vector<std::string> labels;
  for (std::size_t i = 0; i < declared_zones.size(); ++i) labels.push_back(fmt::format("declared zone {}", i + 1));
  std::vector<char> done(job.stretches.size(), 0);

  // Every closed cut of the job, to tell holes (inside another closed cut) from outlines.
  std::vector<std::optional<Contour>> loops(job.stretches.size());
  std::vector<double> loop_area(job.stretches.size(), 0.0);
  for (std::size_t i = 0; i < job.stretches.size(); ++i) {
    const Stretch& s = job.stretches[i];
    if (s.cutting && !s.rapid && !s.segments.empty()) loops[i] = closed_loop(s);
    if (loops[i]) loop_area[i] = std::abs(signed_area(*loops[i]));
  }
  // A hole lies inside an odd number of larger closed cuts: a part nested in another part's
  // hole lies inside two and is a part again.
  const auto is_hole = [&](std::size_t i) {
    const Vector2d p = loops[i]->vertices().front();
    int depth = 0;
    for (std::size_t j = 0; j < loops.size(); ++j)
      if (j != i && loops[j] && loop_area[j] > loop_area[i] && contains(*loops[j], p)) ++depth;
    return depth % 2 == 1;
  };

  std::size_t rapid_total = 0, rapid_done = 0;
  for (const Stretch& s : job.stretches) rapid_total += s.rapid && !s.segments.empty();
  for (const Step& step : job.steps) {
    if (options.stop.stop_requested()) {
      report.cancelled = true;
      break;
    }
    if (step.kind != Step::Kind::move || step.stretch >= job.stretches.size() || done[step.stretch]) continue;
    done[step.stretch] = 1;
    Stretch& s = job.stretches[step.stretch];
    if (s.segments.empty()) continue;

    if (s.cutting && !s.rapid) {
      if (!zones_from_cuts) continue;
      if (!loops[step.stretch]) {
        ++report.open_cuts;
        continue;
      }
      const Contour& loop = *loops[step.stretch];
      const int line = s.source_lines.empty() ? step.source_line : s.source_lines.front();
      if (is_hole(step.stretch)) {
        const Eigen::Vector2d size = bounding_box(loop).sizes();
        if (size.maxCoeff() <= options.slug_tip_size_mm) {
          ++report.small_slugs;
          continue;
        }
        labels.push_back(fmt::format("slug of the hole cut at line {} ({:.1f} x {:.1f} mm)", line, size.x(), size.y()));
      } else {
        labels.push_back(fmt::format("part cut at line {}", line));
      }
      zones.push_back(loop);
      ++report.cut_zones;
      continue;
    }
    if (!s.rapid) continue;

    RapidReport r;
    r.stretch = step.stretch;
    r.source_line = s.source_lines.empty() ? step.source_line : s.source_lines.front();
    r.from = s.segments.front().start;
    r.to = s.segments.back().end;
    r.straight_length_mm = (r.to - r.from).norm();
    r.programmed_length_mm = stretch_length(s);
    r.zone_count = zones.size();

    const RapidPlan plan = plan_rapid(r.from, r.to, zones, options, declared_zones.size());
    if (plan.status == RapidStatus::cancelled) {
      report.cancelled = true;
      break;
    }
    if (options.progress && rapid_total > 0) options.progress(static_cast<double>(++rapid_done) / rapid_total);
    r.status = plan.status;
    r.straight_blocked = plan.straight_blocked;
    r.message = plan.message;

    // Keep the programmed route when it is straight lines and clear of every zone, or when
    // it is the one straight move the plan found clear (step 1b of rapid_planner.h).
    bool programmed_clear = true;
    std::vector<Vector2d> programmed{r.from};
    for (const Segment& g : s.segments) {
      programmed_clear = programmed_clear && !g.is_arc();
      programmed.push_back(g.end);
    }
    const double programmed_clearance = polyline_clearance_mm(programmed, zones);
    const bool programmed_straight = programmed.size() == 2 && programmed_clear;
    programmed_clear = programmed_clear && (programmed_clearance >= options.clearance_mm ||
                                            (programmed_straight && plan.status == RapidStatus::straight));

    if (programmed_clear) {
      r.programmed_clear = true;
      r.min_clearance_mm = programmed_clearance;
      if (plan.status != RapidStatus::straight) r.message = "the programmed route is clear; kept";
    } else if (plan.ok()) {
      const double feed = s.feed_mm_per_s.empty() ? 0.0 : s.feed_mm_per_s.front();
      const int line = s.source_lines.empty() ? step.source_line : s.source_lines.front();
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
    if (r.replaced && plan.status == RapidStatus::planned) {
      // Why: the zones the straight move comes too near (those it merely leaves or reaches
      // at an end are named too: their band held the end point).
      for (std::size_t j = 0; j < zones.size(); ++j)
        if (region_distance_mm(r.from, r.to, zones[j]) < options.clearance_mm) {
          if (!r.reason.empty()) r.reason += "; ";
          r.reason += labels[j];
        }
      ++report.detours;
      report.detour_extra_mm += r.extra_length_mm;
    }

    report.blocked += r.straight_blocked ? 1 : 0;
    report.replaced += r.replaced ? 1 : 0;
    report.failed += (!plan.ok() && !programmed_clear) ? 1 : 0;
    report.straight_length_mm += r.straight_length_mm;
    report.programmed_length_mm += r.programmed_length_mm;
    report.length_mm += r.length_mm;
    report.rapids.push_back(std::move(r));
  }
  return report;
}

std::string RapidsReport::summary() const {
  std::string out = fmt::format("{:>7} {:>5} {:>16} {:>10} {:>10} {:>10} {:>8}  {}\n", "stretch", "line", "status",
                                "straight", "programmed", "final", "clear", "note");
  for (const RapidReport& r : rapids) {
    const std::string clear =
        std::isinf(r.min_clearance_mm) ? std::string("-") : fmt::format("{:.2f}", r.min_clearance_mm);
    out += fmt::format("{:>7} {:>5} {:>16} {:>10.2f} {:>10.2f} {:>10.2f} {:>8}  {}{}{}\n", r.stretch, r.source_line,
                       to_string(r.status), r.straight_length_mm, r.programmed_length_mm, r.length_mm, clear,
                       r.replaced ? "re-routed; " : (r.programmed_clear ? "as programmed; " : "NOT CLEAR; "),
                       r.message, r.reason.empty() ? std::string() : fmt::format(" (+{:.2f} mm round {})", r.extra_length_mm, r.reason));
  }
  out += fmt::format(
      "{} rapids: {} blocked straight, {} re-routed, {} without a clear route; {} zones from cuts, {} small slugs "
      "crossed, {} open cuts\n"
      "length: straight {:.2f} mm, programmed {:.2f} mm, final {:.2f} mm; {} detours, {:.2f} mm extra\n",
      rapids.size(), blocked, replaced, failed, cut_zones, small_slugs, open_cuts, straight_length_mm,
      programmed_length_mm, length_mm, detours, detour_extra_mm);
  return out;
}

}  // namespace machplan::motion
