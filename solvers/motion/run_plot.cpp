#include "solvers/motion/run_plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "solvers/common/picture.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;

// screen = (ox + scale * x, oy - scale * y), as in solvers/placement/report/plot.cpp.
using View = PlotView;

void trace_stretch(Canvas& cr, const View& v, const Stretch& st) {
  for (std::size_t i = 0; i < st.segments.size(); ++i) trace_segment(cr, v, st.segments[i], i == 0);
}

void extend(Eigen::AlignedBox2d& box, const Stretch& st) {
  for (const Segment& s : st.segments) box.extend(bounding_box(s));
}

// Nearest point of the stretch's segments to p.
Vector2d nearest_on(const Stretch& st, const Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  Vector2d q = p;
  for (const Segment& s : st.segments) {
    const Vector2d c = closest_point(s, p);
    const double d = (c - p).squaredNorm();
    if (d < best) best = d, q = c;
  }
  return q;
}

// What the picture frames: the cutting stretches and the declared zones, or every stretch
// when nothing is cut.
Eigen::AlignedBox2d job_extent(const RunOutcome& run) {
  Eigen::AlignedBox2d box;
  for (const Stretch& st : run.job.stretches)
    if (st.cutting && !st.rapid) extend(box, st);
  for (const NoGoZone& z : run.declared_zones) box.extend(bounding_box(z.contour));
  if (box.isEmpty()) {
    box.extend(run.job.start_mm);
    for (const Stretch& st : run.job.stretches) extend(box, st);
  }
  return box;
}

// Draws one legend entry at x and returns where the next one starts.
double legend_item(Canvas& cr, double x, double y, double r, double g, double b, bool dashed, const std::string& label,
                   double width = 2.0) {
  cr.save();
  cr.set_source_rgb(r, g, b);
  cr.set_line_width(width);
  if (dashed) {
    const double dash[] = {6.0, 4.0};
    cr.set_dash(dash, 2, 0);
  }
  cr.move_to(x, y - 4);
  cr.line_to(x + 28, y - 4);
  cr.stroke();
  cr.restore();
  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, x + 34, y, label, 12);
  return x + 34 + cr.text_advance(label) + 24;
}

// The job as planned: rapids dashed blue, feed moves with the torch off (a frame, a marking
// pass) green, the cutting path black with its pierce points.
void draw_planned(Canvas& cr, const View& v, const Job& job) {
  const double dash[] = {6.0, 4.0};
  const auto draw_stretches = [&](auto take) {
    for (const Stretch& st : job.stretches)
      if (take(st)) {
        trace_stretch(cr, v, st);
        cr.stroke();
      }
  };
  cr.set_line_width(1.0);
  cr.set_source_rgb(0.2, 0.4, 0.85);
  cr.set_dash(dash, 2, 0);
  draw_stretches([](const Stretch& st) { return st.rapid; });
  cr.set_dash(nullptr, 0, 0);
  cr.set_source_rgb(0.1, 0.6, 0.2);
  cr.set_line_width(1.5);
  draw_stretches([](const Stretch& st) { return !st.cutting && !st.rapid; });
  cr.set_source_rgb(0, 0, 0);
  cr.set_line_width(1.0);
  draw_stretches([](const Stretch& st) { return st.cutting && !st.rapid; });
  for (const Stretch& st : job.stretches)
    if (st.cutting && !st.rapid) {
      const Vector2d p = st.segments.front().start;
      cr.arc(v.sx(p.x()), v.sy(p.y()), 3.0, 0, 2 * M_PI);
      cr.stroke();
    }
}

void draw(Canvas& cr, double W, double H, const RunOutcome& run, double K) {
  const Job& job = run.job;
  const executor::ExecutionResult& res = run.result;
  cr.set_source_rgb(1, 1, 1);
  cr.paint();

  // Extent: the cuts and the declared zones; rapids from and to a far-away home leave the
  // frame (clipped) rather than shrink the parts to a corner.
  Eigen::AlignedBox2d box = job_extent(run);
  const double top = 64, bottom = 70, side = 40;
  const double span = std::max({box.sizes().x(), box.sizes().y(), 1.0});
  const double margin = 0.08 * span;
  box.extend(box.min() - Vector2d::Constant(margin));
  box.extend(box.max() + Vector2d::Constant(margin));
  const double scale = std::min((W - 2 * side) / box.sizes().x(), (H - top - bottom) / box.sizes().y());
  const double used_w = box.sizes().x() * scale, used_h = box.sizes().y() * scale;
  View v{side + (W - 2 * side - used_w) / 2 - scale * box.min().x(), top + (H - top - bottom - used_h) / 2 + used_h + scale * box.min().y(),
         scale};

  // Frame of the drawn area; everything up to the title is clipped to it.
  cr.set_source_rgb(0.97, 0.97, 0.97);
  cr.rectangle(v.sx(box.min().x()), v.sy(box.max().y()), used_w, used_h);
  cr.fill_preserve();
  cr.save();
  cr.clip();

  // Parts cut (closed cuts), then declared zones.
  cr.set_line_width(1.0);
  for (const Contour& c : run.cut_zones) {
    trace_contour(cr, v, c);
    cr.set_source_rgba(0.55, 0.55, 0.55, 0.18);
    cr.set_fill_rule(Canvas::FillRule::even_odd);
    cr.fill();
  }
  for (const NoGoZone& z : run.declared_zones) {
    trace_contour(cr, v, z.contour);
    cr.set_source_rgba(0.9, 0.2, 0.1, 0.3);
    cr.fill_preserve();
    cr.set_source_rgb(0.75, 0.1, 0.05);
    cr.stroke();
    const Eigen::AlignedBox2d b = bounding_box(z.contour);
    cr.set_source_rgb(0.6, 0.05, 0.0);
    draw_text(cr, v.sx(b.min().x()), v.sy(b.max().y()) - 4, z.name, 11);
  }

  // Outline before kerf compensation.
  if (run.kerf) {
    cr.set_source_rgb(0.6, 0.6, 0.6);
    cr.set_line_width(0.8);
    for (const Stretch& st : run.programmed.stretches)
      if (st.cutting && !st.rapid) {
        trace_stretch(cr, v, st);
        cr.stroke();
      }
  }

  draw_planned(cr, v, job);

  // Executed path while the torch burned, error magnified K times.
  cr.set_source_rgb(0.85, 0.1, 0.1);
  cr.set_line_width(1.3);
  cr.set_line_join(Canvas::LineJoin::round);
  bool open = false;
  int last_step = -2;
  for (const executor::TraceSample& s : res.trace) {
    const bool cutting = s.step >= 0 && static_cast<std::size_t>(s.step) < job.steps.size() &&
                         job.steps[s.step].kind == Step::Kind::move && job.stretches[job.steps[s.step].stretch].cutting &&
                         s.torch_fire && s.arc_ok;
    if (!cutting || s.step != last_step) {
      if (open) cr.stroke();
      open = false;
    }
    last_step = s.step;
    if (!cutting) continue;
    const Stretch& st = job.stretches[job.steps[s.step].stretch];
    const Vector2d p = std::isnan(s.true_mm.x()) ? s.measured_mm : s.true_mm;
    const Vector2d q = nearest_on(st, p);
    const Vector2d d = q + K * (p - q);
    if (!open) cr.move_to(v.sx(d.x()), v.sy(d.y()));
    else cr.line_to(v.sx(d.x()), v.sy(d.y()));
    open = true;
  }
  if (open) cr.stroke();
  cr.restore();  // end of the clip

  // Title.
  const bool truth = !std::isnan(res.max_true_contour_error_mm());
  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, side, 26,
       fmt::format("{} on {}, {} mode: {}   cycle {:.2f} s ({:.3f} x the lower bound)", res.source, res.machine,
                   executor::to_string(res.mode), run.faulted() ? "FAULTED" : "completed", res.cycle_time_s, run.cycle_ratio),
       15);
  draw_text(cr, side, 48,
       fmt::format("max contour error, torch on: {:.4f} mm from the encoders{}, rms {:.4f} mm over {} cuts;   "
                   "error drawn x{:g}",
                   res.max_contour_error_mm(),
                   truth ? fmt::format(", {:.4f} mm true", res.max_true_contour_error_mm()) : std::string(),
                   run.rms_contour_error_mm, res.cuts.size(), K),
       13);
  for (const executor::FaultReport& f : res.faults) {
    cr.set_source_rgb(0.8, 0, 0);
    draw_text(cr, side, H - bottom + 18, fmt::format("FAULT {}: {}", executor::to_string(f.kind), f.message), 12);
    const Vector2d p = f.last_known_mm;
    cr.arc(v.sx(p.x()), v.sy(p.y()), 7, 0, 2 * M_PI);
    cr.stroke();
  }

  // Legend and scale bar.
  const double ly = H - 22;
  double lx = side;
  lx = legend_item(cr, lx, ly, 0, 0, 0, false, "programmed torch path (o: pierce)", 1.0);
  lx = legend_item(cr, lx, ly, 0.85, 0.1, 0.1, false, fmt::format("executed, torch on (error x{:g})", K), 1.3);
  lx = legend_item(cr, lx, ly, 0.2, 0.4, 0.85, true, "rapids as planned", 1.0);
  if (std::any_of(job.stretches.begin(), job.stretches.end(), [](const Stretch& st) { return !st.cutting && !st.rapid; }))
    lx = legend_item(cr, lx, ly, 0.1, 0.6, 0.2, false, "feed, torch off", 1.5);
  if (run.kerf)
    lx = legend_item(cr, lx, ly, 0.6, 0.6, 0.6, false, fmt::format("outline before kerf ({:g} mm)", run.kerf->kerf_width_mm),
                     0.8);
  if (!run.declared_zones.empty()) lx = legend_item(cr, lx, ly, 0.75, 0.1, 0.05, false, "no-go zones", 6.0);
  if (!run.cut_zones.empty()) legend_item(cr, lx, ly, 0.8, 0.8, 0.8, false, "parts cut", 6.0);
  // Scale bar: a round length near a fifth of the drawn width.
  const double bar = round_step(0.2 * box.sizes().x());
  draw_scale_bar(cr, W - side - bar * scale, H - 40, scale, bar);
}

}  // namespace

void write_run_plot(const std::string& path, const RunOutcome& run, double magnify) {
  if (!(std::isfinite(magnify) && magnify > 0 && magnify <= 1e6))
    throw InputError::field("magnify", fmt::format("{} must be a number > 0 and <= 1e6", magnify));
  // Canvas shaped like the job (within limits), so a long sheet does not shrink to a strip.
  const Eigen::AlignedBox2d box = job_extent(run);
  const double aspect = std::clamp(box.sizes().y() / std::max(box.sizes().x(), 1.0), 0.45, 1.2);
  const double W = 1400, H = std::round(134 + (W - 80) * aspect);
  write_picture(path, "plot", W, H, [&](Canvas& cr) { draw(cr, W, H, run, magnify); });
}

}  // namespace machplan::motion
