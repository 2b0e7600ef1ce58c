#include "solvers/placement/plot.h"

#include <cairo.h>

#include <algorithm>
#include <cmath>

#include "engine/common/error.h"
#include "solvers/common/picture.h"

namespace machplan::placement {

namespace {
constexpr double kDeg = M_PI / 180.0;

using View = PlotView;

void polygon(cairo_t* cr, const View& v, const std::vector<Eigen::Vector2d>& pts) {
  for (std::size_t i = 0; i < pts.size(); ++i) (i ? cairo_line_to : cairo_move_to)(cr, v.sx(pts[i].x()), v.sy(pts[i].y()));
  cairo_close_path(cr);
}

void draw(cairo_t* cr, double W, double H, const Scene& scene, const PlacementResult& r) {
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  const Placement& p = r.placement;
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(p.rotation_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d off = p.offset();
  const Eigen::Vector2d half = scene.machine.table_size_mm / 2;
  const double extent = std::max(half.x(), half.y()) * 1.25;

  // ---- top view (left) ----
  const double panel = std::min(W / 2, H) - 60;
  View top{W * 0.25, H / 2 + 10, panel / (2 * extent)};
  cairo_set_line_width(cr, 1.5);
  cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
  cairo_rectangle(cr, top.sx(-half.x()), top.sy(half.y()), 2 * half.x() * top.scale, 2 * half.y() * top.scale);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 0.4, 0.4, 0.4);
  cairo_stroke(cr);
  // axes through the table centre
  cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  cairo_move_to(cr, top.sx(-half.x()), top.sy(0));
  cairo_line_to(cr, top.sx(half.x()), top.sy(0));
  cairo_move_to(cr, top.sx(0), top.sy(-half.y()));
  cairo_line_to(cr, top.sx(0), top.sy(half.y()));
  cairo_stroke(cr);
  for (const auto& per : scene.peripherals) {
    cairo_set_source_rgba(cr, 0.85, 0.3, 0.2, 0.35);
    polygon(cr, top, per.outline);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.7, 0.2, 0.1);
    cairo_stroke(cr);
    draw_text(cr, top.sx(per.bounds.center().x()) - 30, top.sy(per.bounds.center().y()), per.name, 11);
  }
  // searched region (positions of the workpiece origin)
  const double dash[] = {6.0, 4.0};
  cairo_set_dash(cr, dash, 2, 0);
  cairo_set_source_rgb(cr, 0.2, 0.4, 0.8);
  cairo_rectangle(cr, top.sx(r.region.min().x()), top.sy(r.region.max().y()), r.region.sizes().x() * top.scale,
                  r.region.sizes().y() * top.scale);
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0);
  // workpiece outline at the answer
  const auto& b = scene.workpiece_bounds;
  std::vector<Eigen::Vector2d> outline;
  for (int k : {0, 1, 3, 2})
    outline.push_back((Rz * Eigen::Vector3d(k & 1 ? b.max().x() : b.min().x(), k & 2 ? b.max().y() : b.min().y(), 0) + off).head<2>());
  cairo_set_source_rgba(cr, 0.3, 0.6, 0.3, 0.25);
  polygon(cr, top, outline);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 0.1, 0.45, 0.1);
  cairo_stroke(cr);
  // tool path (every 50th row-wise pose is plenty to show its shape)
  cairo_set_source_rgba(cr, 0.1, 0.3, 0.1, 0.6);
  cairo_set_line_width(cr, 0.5);
  const std::size_t stride = std::max<std::size_t>(1, scene.tips_mm.size() / 20000);
  for (std::size_t i = 0; i < scene.tips_mm.size(); i += stride) {
    const Eigen::Vector3d t = Rz * scene.tips_mm[i] + off;
    (i ? cairo_line_to : cairo_move_to)(cr, top.sx(t.x()), top.sy(t.y()));
  }
  cairo_stroke(cr);
  // paper trail
  if (!r.trail.empty()) {
    cairo_set_source_rgb(cr, 0.8, 0.5, 0.0);
    cairo_set_line_width(cr, 1.5);
    for (std::size_t i = 0; i < r.trail.size(); ++i)
      (i ? cairo_line_to : cairo_move_to)(cr, top.sx(r.trail[i].x_mm), top.sy(r.trail[i].y_mm));
    cairo_stroke(cr);
  }
  // answer
  cairo_set_source_rgb(cr, 0.8, 0.0, 0.0);
  cairo_arc(cr, top.sx(p.x_mm), top.sy(p.y_mm), 5, 0, 2 * M_PI);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  draw_text(cr, 20, 28, fmt::format("top view: {}  x {:.2f}  y {:.2f}  pad {:.1f} mm  rotation {:.0f} deg", to_string(r.status),
                               p.x_mm, p.y_mm, p.pad_mm, p.rotation_deg));
  draw_text(cr, 20, H - 14, "grey: table   red: peripherals   green: workpiece and tool path   dashed blue: searched region   "
                       "orange: paper search trail   red dot: answer", 11);

  // ---- side view (right): x along the table diagonal through the answer, z up ----
  View side{W * 0.75, H * 0.8, panel / (2 * extent)};
  cairo_set_line_width(cr, 1.5);
  cairo_set_source_rgb(cr, 0.4, 0.4, 0.4);
  cairo_move_to(cr, side.sx(-half.x()), side.sy(0));
  cairo_line_to(cr, side.sx(half.x()), side.sy(0));
  cairo_stroke(cr);
  for (const auto& per : scene.peripherals) {
    cairo_set_source_rgba(cr, 0.85, 0.3, 0.2, 0.35);
    cairo_rectangle(cr, side.sx(per.bounds.min().x()), side.sy(per.bounds.max().z()), per.bounds.sizes().x() * side.scale,
                    per.bounds.sizes().z() * side.scale);
    cairo_fill(cr);
  }
  Eigen::AlignedBox2d fp;
  for (const auto& q : outline) fp.extend(q);
  if (p.pad_mm > 0) {
    cairo_set_source_rgb(cr, 0.55, 0.45, 0.3);
    cairo_rectangle(cr, side.sx(fp.min().x()), side.sy(p.pad_mm), fp.sizes().x() * side.scale, p.pad_mm * side.scale);
    cairo_fill(cr);
  }
  cairo_set_source_rgba(cr, 0.3, 0.6, 0.3, 0.4);
  cairo_rectangle(cr, side.sx(fp.min().x()), side.sy(p.pad_mm + b.max().z()), fp.sizes().x() * side.scale,
                  b.max().z() * side.scale);
  cairo_fill(cr);
  cairo_set_source_rgba(cr, 0.1, 0.3, 0.1, 0.5);
  cairo_set_line_width(cr, 0.5);
  for (std::size_t i = 0; i < scene.tips_mm.size(); i += stride) {
    const Eigen::Vector3d t = Rz * scene.tips_mm[i] + off;
    cairo_rectangle(cr, side.sx(t.x()), side.sy(t.z()), 0.6, 0.6);
  }
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  draw_text(cr, W * 0.5 + 20, 28, fmt::format("side view (x, z): pad {:.1f} mm, workpiece top {:.1f} mm", p.pad_mm,
                                         p.pad_mm + b.max().z()));
}
}  // namespace

void write_placement_plot(const std::string& path, const Scene& scene, const PlacementResult& result) {
  const double W = 1400, H = 760;
  write_picture(path, "plot", W, H, [&](cairo_t* cr) { draw(cr, W, H, scene, result); });
}

}  // namespace machplan::placement
