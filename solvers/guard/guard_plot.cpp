// The paper's Figure 8 for a guard run: the part's profile (grey), the prohibited region's
// boundary (the offset profile, red), the operator's roughing strokes (blue, an invasion's
// closest point as a red dot, a success's as a black one) and the finishing path (green).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "solvers/common/picture.h"
#include "solvers/guard/guard_run.h"

namespace machplan::guard {
namespace {

void trace_points(Canvas& cr, const PlotView& v, const std::vector<Eigen::Vector2d>& pts) {
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (i == 0) cr.move_to(v.sx(pts[i].x()), v.sy(pts[i].y()));
    else cr.line_to(v.sx(pts[i].x()), v.sy(pts[i].y()));
  }
}

double legend(Canvas& cr, double x, double y, double r, double g, double b, const std::string& label) {
  cr.set_source_rgb(r, g, b);
  cr.set_line_width(2.5);
  cr.move_to(x, y - 4);
  cr.line_to(x + 26, y - 4);
  cr.stroke();
  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, x + 32, y, label, 12);
  cr.set_font_size(12);
  return x + 32 + cr.text_advance(label) + 22;
}

void draw(Canvas& cr, double W, double H, const GuardRunResult& r) {
  cr.set_source_rgb(1, 1, 1);
  cr.paint();
  Eigen::AlignedBox2d box;
  for (const Contour& c : r.boundary) box.extend(bounding_box(c));
  for (const Contour& c : r.profile) box.extend(bounding_box(c));
  for (const Attempt& a : r.attempts)
    for (const auto& p : a.path_mm) box.extend(p);
  if (box.isEmpty()) box.extend(Eigen::Vector2d::Zero());
  const double top = 60, bottom = 56, side = 30;
  const double margin = 0.05 * std::max({box.sizes().x(), box.sizes().y(), 1.0});
  box.extend(box.min() - Eigen::Vector2d::Constant(margin));
  box.extend(box.max() + Eigen::Vector2d::Constant(margin));
  const double scale = std::min((W - 2 * side) / box.sizes().x(), (H - top - bottom) / box.sizes().y());
  const double uw = box.sizes().x() * scale, uh = box.sizes().y() * scale;
  const PlotView v{side + (W - 2 * side - uw) / 2 - scale * box.min().x(), top + (H - top - bottom - uh) / 2 + uh + scale * box.min().y(),
                   scale};

  // Profile (the part as drawn).
  cr.set_fill_rule(Canvas::FillRule::even_odd);
  for (const Contour& c : r.profile) trace_contour(cr, v, c);
  // Outside machining: the part is the material; inside: the pocket is empty.
  cr.set_source_rgba(0.5, 0.5, 0.5, r.options.region.side == MachiningSide::outside ? 0.35 : 0.0);
  cr.fill_preserve();
  cr.set_source_rgb(0.3, 0.3, 0.3);
  cr.set_line_width(1.2);
  cr.stroke();
  // The prohibited region, lightly filled (outside machining: inside the offset profile;
  // inside machining: everything outside the pocket's offset), then its boundary.
  cr.save();
  if (r.options.region.side == MachiningSide::inside) {
    cr.rectangle(0, 0, W, H);
    for (const Contour& c : r.boundary) trace_contour(cr, v, c);
  } else {
    for (const Contour& c : r.boundary) trace_contour(cr, v, c);
  }
  cr.set_source_rgba(0.9, 0.2, 0.1, 0.12);
  cr.fill();
  cr.restore();
  for (const Contour& c : r.boundary) trace_contour(cr, v, c);
  cr.set_source_rgb(0.85, 0.1, 0.05);
  cr.set_line_width(1.5);
  cr.stroke();
  // Roughing strokes.
  cr.set_line_width(0.9);
  for (const Attempt& a : r.attempts) {
    trace_points(cr, v, a.path_mm);
    cr.set_source_rgba(0.1, 0.3, 0.85, 0.7);
    cr.stroke();
  }
  for (const Attempt& a : r.attempts) {
    cr.arc(v.sx(a.closest_at_mm.x()), v.sy(a.closest_at_mm.y()), 2.2, 0, 2 * M_PI);
    if (a.success) cr.set_source_rgb(0, 0, 0);
    else cr.set_source_rgb(0.95, 0.05, 0.05);
    cr.fill();
  }
  // Finishing passes.
  cr.set_line_width(2.0);
  for (const FinishPass& f : r.finish) {
    trace_points(cr, v, f.path_mm);
    if (f.allowance_mm > 0) cr.set_source_rgb(0.6, 0.75, 0.1);
    else cr.set_source_rgb(0.05, 0.6, 0.2);
    cr.stroke();
  }

  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, side, 24,
            fmt::format("{} - {} machining, R {} mm, strategy {}, T {} mm, L {} ms, {} mm/s", r.profile_source,
                        to_string(r.options.region.side), r.options.region.tool_radius_mm,
                        executor::to_string(r.options.guard.strategy), r.options.guard.tolerance_mm,
                        r.options.guard.latency_s * 1000, r.options.feed_mm_per_s),
            14);
  draw_text(cr, side, 44,
            fmt::format("attempts {}, successes {} ({:.1f} %), max invasion {:.3f} mm, under-cut mean {:.3f} / max {:.3f} mm",
                        r.attempts.size(), r.successes, r.success_percent(), r.max_invasion_mm, r.mean_undercut_mm,
                        r.max_undercut_mm),
            12);
  double x = side;
  const double y = H - 20;
  x = legend(cr, x, y, 0.3, 0.3, 0.3, "profile");
  x = legend(cr, x, y, 0.85, 0.1, 0.05, "offset profile (prohibited region)");
  x = legend(cr, x, y, 0.1, 0.3, 0.85, "roughing strokes");
  legend(cr, x, y, 0.05, 0.6, 0.2, "finishing path");
}

}  // namespace

void write_guard_plot(const GuardRunResult& r, const std::string& path, const std::string& field) {
  write_picture(path, field, 1000, 800, [&](Canvas& cr) { draw(cr, 1000, 800, r); });
}

}  // namespace machplan::guard
