#include "solvers/placement/report/plot.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>

#include "engine/common/error.h"
#include "solvers/common/picture.h"
#include "solvers/placement/report/internal/report.h"

namespace machplan::placement {

namespace {

using View = PlotView;

// A polyline's first point starts a sub-path, the others extend it.
void vertex(Canvas& cr, bool first, double x, double y) {
  if (first) cr.move_to(x, y);
  else cr.line_to(x, y);
}

void polygon(Canvas& cr, const View& v, const std::vector<Eigen::Vector2d>& pts) {
  for (std::size_t i = 0; i < pts.size(); ++i) vertex(cr, i == 0, v.sx(pts[i].x()), v.sy(pts[i].y()));
  cr.close_path();
}

void draw(Canvas& cr, double W, double H, const Scene& scene, const PlacementResult& r) {
  cr.set_source_rgb(1, 1, 1);
  cr.paint();
  const Placement& p = r.placement;
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(p.rotation_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d off = p.offset();
  const Eigen::Vector2d half = scene.machine.table_size_mm / 2;
  const double extent = std::max(half.x(), half.y()) * 1.25;

  // ---- top view (left) ----
  const double panel = std::min(W / 2, H) - 60;
  View top{W * 0.25, H / 2 + 10, panel / (2 * extent)};
  cr.set_line_width(1.5);
  cr.set_source_rgb(0.9, 0.9, 0.9);
  cr.rectangle(top.sx(-half.x()), top.sy(half.y()), 2 * half.x() * top.scale, 2 * half.y() * top.scale);
  cr.fill_preserve();
  cr.set_source_rgb(0.4, 0.4, 0.4);
  cr.stroke();
  // axes through the table centre
  cr.set_source_rgb(0.6, 0.6, 0.6);
  cr.move_to(top.sx(-half.x()), top.sy(0));
  cr.line_to(top.sx(half.x()), top.sy(0));
  cr.move_to(top.sx(0), top.sy(-half.y()));
  cr.line_to(top.sx(0), top.sy(half.y()));
  cr.stroke();
  for (const auto& per : scene.peripherals) {
    cr.set_source_rgba(0.85, 0.3, 0.2, 0.35);
    polygon(cr, top, per.outline);
    cr.fill_preserve();
    cr.set_source_rgb(0.7, 0.2, 0.1);
    cr.stroke();
    draw_text(cr, top.sx(per.bounds.center().x()) - 30, top.sy(per.bounds.center().y()), per.name, 11);
  }
  // searched region (positions of the workpiece origin)
  const double dash[] = {6.0, 4.0};
  cr.set_dash(dash, 2, 0);
  cr.set_source_rgb(0.2, 0.4, 0.8);
  cr.rectangle(top.sx(r.region.min().x()), top.sy(r.region.max().y()), r.region.sizes().x() * top.scale,
                  r.region.sizes().y() * top.scale);
  cr.stroke();
  cr.set_dash(nullptr, 0, 0);
  // workpiece outline at the answer
  const auto& b = scene.workpiece_bounds;
  std::vector<Eigen::Vector2d> outline;
  for (int k : {0, 1, 3, 2})
    outline.push_back((Rz * Eigen::Vector3d(k & 1 ? b.max().x() : b.min().x(), k & 2 ? b.max().y() : b.min().y(), 0) + off).head<2>());
  cr.set_source_rgba(0.3, 0.6, 0.3, 0.25);
  polygon(cr, top, outline);
  cr.fill_preserve();
  cr.set_source_rgb(0.1, 0.45, 0.1);
  cr.stroke();
  // tool path (every 50th row-wise pose is plenty to show its shape)
  cr.set_source_rgba(0.1, 0.3, 0.1, 0.6);
  cr.set_line_width(0.5);
  const std::size_t stride = std::max<std::size_t>(1, scene.tips_mm.size() / 20000);
  for (std::size_t i = 0; i < scene.tips_mm.size(); i += stride) {
    const Eigen::Vector3d t = Rz * scene.tips_mm[i] + off;
    vertex(cr, i == 0, top.sx(t.x()), top.sy(t.y()));
  }
  cr.stroke();
  // paper trail
  if (!r.trail.empty()) {
    cr.set_source_rgb(0.8, 0.5, 0.0);
    cr.set_line_width(1.5);
    for (std::size_t i = 0; i < r.trail.size(); ++i)
      vertex(cr, i == 0, top.sx(r.trail[i].x_mm), top.sy(r.trail[i].y_mm));
    cr.stroke();
  }
  // answer
  cr.set_source_rgb(0.8, 0.0, 0.0);
  cr.arc(top.sx(p.x_mm), top.sy(p.y_mm), 5, 0, 2 * M_PI);
  cr.fill();
  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, 20, 28, fmt::format("top view: {}  x {:.2f}  y {:.2f}  {} {:.1f} mm  rotation {:.0f} deg", to_string(r.summary.status),
                               p.x_mm, p.y_mm, height_name(scene), p.pad_mm, p.rotation_deg));
  draw_scale_bar(cr, top.sx(-extent), top.sy(-extent) + 20, top.scale, round_step(0.4 * extent));
  draw_text(cr, 20, H - 14, "grey: table   red: peripherals   green: workpiece and tool path   dashed blue: searched region   "
                       "orange: paper search trail   red dot: answer", 11);

  // ---- side view (right): x along the table diagonal through the answer, z up ----
  View side{W * 0.75, H * 0.8, panel / (2 * extent)};
  cr.set_line_width(1.5);
  cr.set_source_rgb(0.4, 0.4, 0.4);
  cr.move_to(side.sx(-half.x()), side.sy(0));
  cr.line_to(side.sx(half.x()), side.sy(0));
  cr.stroke();
  for (const auto& per : scene.peripherals) {
    cr.set_source_rgba(0.85, 0.3, 0.2, 0.35);
    cr.rectangle(side.sx(per.bounds.min().x()), side.sy(per.bounds.max().z()), per.bounds.sizes().x() * side.scale,
                    per.bounds.sizes().z() * side.scale);
    cr.fill();
  }
  Eigen::AlignedBox2d fp;
  for (const auto& q : outline) fp.extend(q);
  if (p.pad_mm > 0) {
    cr.set_source_rgb(0.55, 0.45, 0.3);
    cr.rectangle(side.sx(fp.min().x()), side.sy(p.pad_mm), fp.sizes().x() * side.scale, p.pad_mm * side.scale);
    cr.fill();
  }
  cr.set_source_rgba(0.3, 0.6, 0.3, 0.4);
  cr.rectangle(side.sx(fp.min().x()), side.sy(p.pad_mm + b.max().z()), fp.sizes().x() * side.scale,
                  b.max().z() * side.scale);
  cr.fill();
  cr.set_source_rgba(0.1, 0.3, 0.1, 0.5);
  cr.set_line_width(0.5);
  for (std::size_t i = 0; i < scene.tips_mm.size(); i += stride) {
    const Eigen::Vector3d t = Rz * scene.tips_mm[i] + off;
    cr.rectangle(side.sx(t.x()), side.sy(t.z()), 0.6, 0.6);
  }
  cr.fill();
  cr.set_source_rgb(0, 0, 0);
  draw_text(cr, W * 0.5 + 20, 28, fmt::format("side view (x, z): {} {:.1f} mm, workpiece top {:.1f} mm", height_name(scene),
                                         p.pad_mm, p.pad_mm + b.max().z()));
  draw_scale_bar(cr, side.sx(-extent), side.sy(0) + 40, side.scale, round_step(0.4 * extent));
}
}  // namespace

void write_placement_plot(const std::string& path, const Scene& scene, const PlacementResult& result) {
  const double W = 1400, H = 760;
  write_picture(path, "plot", W, H, [&](Canvas& cr) { draw(cr, W, H, scene, result); });
}

}  // namespace machplan::placement
