#include "solvers/common/picture.h"

#include <cmath>
#include <string_view>

#include <cairo-svg.h>
#include <cairo.h>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/geometry/contour.h"

namespace machplan {
namespace {

bool ends_with(const std::string& s, const char* tail) {
  const std::string t(tail);
  return s.size() > t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

// Cairo writes the picture through this callback into the AtomicOutput's temporary; a write
// that fails stops Cairo with a write error, and AtomicOutput::write has kept the reason.
cairo_status_t write_picture_bytes(void* closure, const unsigned char* data, unsigned int length) {
  auto* out = static_cast<AtomicOutput*>(closure);
  try {
    out->write(std::string_view(reinterpret_cast<const char*>(data), length));
  } catch (const OutputError& e) {
    out->fail(e.reason());
    return CAIRO_STATUS_WRITE_ERROR;
  }
  return CAIRO_STATUS_SUCCESS;
}

}  // namespace

struct Canvas::Context {
  cairo_t* cr;
};

void Canvas::set_source_rgb(double r, double g, double b) { cairo_set_source_rgb(context_.cr, r, g, b); }
void Canvas::set_source_rgba(double r, double g, double b, double a) { cairo_set_source_rgba(context_.cr, r, g, b, a); }
void Canvas::set_line_width(double width) { cairo_set_line_width(context_.cr, width); }
void Canvas::set_dash(const double* dashes, int count, double offset) {
  cairo_set_dash(context_.cr, dashes, count, offset);
}
void Canvas::set_fill_rule(FillRule rule) {
  cairo_set_fill_rule(context_.cr, rule == FillRule::even_odd ? CAIRO_FILL_RULE_EVEN_ODD : CAIRO_FILL_RULE_WINDING);
}
void Canvas::set_line_join(LineJoin join) {
  cairo_set_line_join(context_.cr, join == LineJoin::round   ? CAIRO_LINE_JOIN_ROUND
                                   : join == LineJoin::bevel ? CAIRO_LINE_JOIN_BEVEL
                                                             : CAIRO_LINE_JOIN_MITER);
}
void Canvas::set_font_size(double size) { cairo_set_font_size(context_.cr, size); }
void Canvas::save() { cairo_save(context_.cr); }
void Canvas::restore() { cairo_restore(context_.cr); }
void Canvas::move_to(double x, double y) { cairo_move_to(context_.cr, x, y); }
void Canvas::line_to(double x, double y) { cairo_line_to(context_.cr, x, y); }
void Canvas::arc(double xc, double yc, double radius, double angle1, double angle2) {
  cairo_arc(context_.cr, xc, yc, radius, angle1, angle2);
}
void Canvas::arc_negative(double xc, double yc, double radius, double angle1, double angle2) {
  cairo_arc_negative(context_.cr, xc, yc, radius, angle1, angle2);
}
void Canvas::rectangle(double x, double y, double width, double height) {
  cairo_rectangle(context_.cr, x, y, width, height);
}
void Canvas::close_path() { cairo_close_path(context_.cr); }
void Canvas::stroke() { cairo_stroke(context_.cr); }
void Canvas::fill() { cairo_fill(context_.cr); }
void Canvas::fill_preserve() { cairo_fill_preserve(context_.cr); }
void Canvas::clip() { cairo_clip(context_.cr); }
void Canvas::paint() { cairo_paint(context_.cr); }
void Canvas::show_text(const std::string& s) { cairo_show_text(context_.cr, s.c_str()); }
double Canvas::text_advance(const std::string& s) {
  cairo_text_extents_t extents;
  cairo_text_extents(context_.cr, s.c_str(), &extents);
  return extents.x_advance;
}

bool is_picture_path(const std::string& path) { return ends_with(path, ".png") || ends_with(path, ".svg"); }

void write_picture(const std::string& path, const std::string& field, double width, double height,
                   const std::function<void(Canvas&)>& draw) {
  const bool svg = ends_with(path, ".svg");
  const bool png = ends_with(path, ".png");
  if (!svg && !png) throw InputError::field(field, fmt::format("'{}' must end in .png or .svg", excerpt(path)));
  // Whole or not at all: into a temporary beside `path`, renamed by commit().
  AtomicOutput out(path);
  cairo_surface_t* surface = svg ? cairo_svg_surface_create_for_stream(write_picture_bytes, &out, width, height)
                                 : cairo_image_surface_create(CAIRO_FORMAT_ARGB32, static_cast<int>(width),
                                                              static_cast<int>(height));
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(surface);
    throw InputError(path, 0, "cannot create the picture");
  }
  cairo_t* cr = cairo_create(surface);
  try {
    Canvas::Context context{cr};
    Canvas canvas(context);
    draw(canvas);
  } catch (...) {
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    throw;
  }
  cairo_destroy(cr);
  cairo_status_t st = CAIRO_STATUS_SUCCESS;
  if (png) st = cairo_surface_write_to_png_stream(surface, write_picture_bytes, &out);
  cairo_surface_finish(surface);
  if (st == CAIRO_STATUS_SUCCESS) st = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  // A failed write has its reason in `out` already; another Cairo failure is named here.
  if (st != CAIRO_STATUS_SUCCESS) out.fail(std::string("cannot draw the picture: ") + cairo_status_to_string(st));
  out.commit();
}

void draw_text(Canvas& canvas, double x, double y, const std::string& s, double size) {
  canvas.set_font_size(size);
  canvas.move_to(x, y);
  canvas.show_text(s);
}

void trace_segment(Canvas& canvas, const PlotView& v, const Segment& s, bool move_first) {
  if (move_first) canvas.move_to(v.sx(s.start.x()), v.sy(s.start.y()));
  if (!s.is_arc()) {
    canvas.line_to(v.sx(s.end.x()), v.sy(s.end.y()));
    return;
  }
  const double a0 = -s.start_angle, a1 = -s.end_angle();
  if (s.sweep > 0) canvas.arc_negative(v.sx(s.center.x()), v.sy(s.center.y()), s.radius * v.scale, a0, a1);
  else canvas.arc(v.sx(s.center.x()), v.sy(s.center.y()), s.radius * v.scale, a0, a1);
}

void trace_contour(Canvas& canvas, const PlotView& v, const Contour& c) {
  for (std::size_t i = 0; i < c.size(); ++i) trace_segment(canvas, v, c.span(i), i == 0);
  canvas.close_path();
}

double round_step(double want) {
  const double p10 = std::pow(10.0, std::floor(std::log10(want)));
  return want >= 5 * p10 ? 5 * p10 : (want >= 2 * p10 ? 2 * p10 : p10);
}

void draw_scale_bar(Canvas& canvas, double x, double y, double scale, double length_mm) {
  canvas.set_source_rgb(0, 0, 0);
  canvas.set_line_width(2.0);
  canvas.move_to(x, y);
  canvas.line_to(x + length_mm * scale, y);
  canvas.stroke();
  draw_text(canvas, x, y - 6, fmt::format("{:g} mm", length_mm), 11);
}

}  // namespace machplan
