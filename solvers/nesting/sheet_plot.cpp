#include "solvers/nesting/sheet_plot.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "engine/motion/make_job.h"
#include "solvers/common/picture.h"

namespace machplan::nesting {

void plot_sheet(const std::string& path, const std::vector<NestPart>& parts, const std::vector<Placement>& placements,
                int sheet, const Sheet& s, const Program& cuts, const std::string& title) {
  constexpr double kWidth = 1400, kMargin = 40, kTop = 50;
  const double scale = (kWidth - 2 * kMargin) / s.width_mm;
  const double height = kTop + kMargin + scale * s.height_mm;
  const PlotView v{kMargin, kTop + scale * s.height_mm, scale};
  write_picture(path, "out", kWidth, height, [&](Canvas& c) {
    c.set_source_rgb(1, 1, 1);
    c.paint();
    // The sheet's material (a remnant: its outline less its cut-outs) and, dashed, its usable area.
    c.set_fill_rule(Canvas::FillRule::even_odd);
    c.set_source_rgb(0.93, 0.93, 0.93);
    if (s.remnant) {
      trace_contour(c, v, s.remnant->outer);
      for (const Contour& h : s.remnant->holes) trace_contour(c, v, h);
      c.fill_preserve();
      c.set_source_rgb(0.45, 0.45, 0.45);
      c.set_line_width(1.2);
      c.stroke();
    } else {
      c.rectangle(v.sx(0), v.sy(s.height_mm), scale * s.width_mm, scale * s.height_mm);
      c.fill();
    }
    const double dash[] = {4, 3};
    c.set_dash(dash, 2, 0);
    c.set_source_rgb(0.6, 0.6, 0.6);
    c.set_line_width(1);
    if (s.remnant && s.margin_mm > 0) {
      const RemnantRoom room = remnant_room(s);
      for (const Contour& k : room.inside) trace_contour(c, v, k);
      for (const Contour& k : room.cutouts) trace_contour(c, v, k);
    } else if (!s.remnant) {
      c.rectangle(v.sx(s.margin_mm), v.sy(s.height_mm - s.margin_mm), scale * (s.width_mm - 2 * s.margin_mm),
                  scale * (s.height_mm - 2 * s.margin_mm));
    }
    c.stroke();
    c.set_dash(nullptr, 0, 0);
    // The parts: material shaded, holes open.
    for (const Placement& p : placements) {
      if (p.sheet != sheet) continue;
      trace_contour(c, v, place(parts[p.part].outer, p));
      for (const Contour& h : parts[p.part].holes) trace_contour(c, v, place(h, p));
      c.set_source_rgb(0.62, 0.74, 0.84);
      c.fill_preserve();
      c.set_source_rgb(0.1, 0.2, 0.35);
      c.set_line_width(1);
      c.stroke();
    }
    // The cut program: rapids dashed, pierces numbered in cut order, lead-ins and cuts in red.
    Eigen::Vector3d at = cuts.start;
    int pierce = 0;
    for (const Move& m : cuts.moves) {
      if (m.kind == Move::Kind::rapid) {
        const double d[] = {3, 3};
        c.set_dash(d, 2, 0);
        c.set_source_rgba(0.2, 0.35, 0.9, 0.7);
        c.set_line_width(0.8);
        c.move_to(v.sx(at.x()), v.sy(at.y()));
        c.line_to(v.sx(m.end.x()), v.sy(m.end.y()));
        c.stroke();
        c.set_dash(nullptr, 0, 0);
      } else if (m.kind == Move::Kind::torch_on) {
        c.set_source_rgb(0.8, 0.1, 0.1);
        c.arc(v.sx(at.x()), v.sy(at.y()), 2.5, 0, 2 * M_PI);
        c.fill();
        draw_text(c, v.sx(at.x()) + 3, v.sy(at.y()) - 3, std::to_string(++pierce), 9);
      } else if (m.kind == Move::Kind::line || m.kind == Move::Kind::arc) {
        c.set_source_rgb(0.8, 0.1, 0.1);
        c.set_line_width(1);
        bool first = true;
        for (const Segment& g : motion::move_segments(m, at.head<2>())) trace_segment(c, v, g, std::exchange(first, false));
        c.stroke();
      }
      if (is_motion(m)) at = m.end;
    }
    c.set_source_rgb(0, 0, 0);
    draw_text(c, kMargin, 30, title, 15);
    draw_scale_bar(c, kWidth - kMargin - 120, height - 12, scale, round_step(100.0 / scale));
  });
}

}  // namespace machplan::nesting
