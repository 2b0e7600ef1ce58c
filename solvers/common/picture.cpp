#include "solvers/common/picture.h"

#include <cmath>

#include <cairo-svg.h>
#include <cairo.h>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/contour.h"

namespace machplan {
namespace {

bool ends_with(const std::string& s, const char* tail) {
  const std::string t(tail);
  return s.size() > t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

}  // namespace

bool is_picture_path(const std::string& path) { return ends_with(path, ".png") || ends_with(path, ".svg"); }

void write_picture(const std::string& path, const std::string& field, double width, double height,
                   const std::function<void(cairo_t*)>& draw) {
  const bool svg = ends_with(path, ".svg");
  const bool png = ends_with(path, ".png");
  if (!svg && !png) throw InputError::field(field, fmt::format("'{}' must end in .png or .svg", excerpt(path)));
  cairo_surface_t* surface = svg ? cairo_svg_surface_create(path.c_str(), width, height)
                                 : cairo_image_surface_create(CAIRO_FORMAT_ARGB32, static_cast<int>(width),
                                                              static_cast<int>(height));
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(surface);
    throw InputError(path, 0, "cannot create the picture");
  }
  cairo_t* cr = cairo_create(surface);
  try {
    draw(cr);
  } catch (...) {
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    throw;
  }
  cairo_destroy(cr);
  cairo_status_t st = CAIRO_STATUS_SUCCESS;
  if (png) st = cairo_surface_write_to_png(surface, path.c_str());
  cairo_surface_finish(surface);
  if (st == CAIRO_STATUS_SUCCESS) st = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (st != CAIRO_STATUS_SUCCESS)
    throw InputError(path, 0, std::string("cannot write the picture: ") + cairo_status_to_string(st));
}

void draw_text(cairo_t* cr, double x, double y, const std::string& s, double size) {
  cairo_set_font_size(cr, size);
  cairo_move_to(cr, x, y);
  cairo_show_text(cr, s.c_str());
}

void trace_segment(cairo_t* cr, const PlotView& v, const Segment& s, bool move_first) {
  if (move_first) cairo_move_to(cr, v.sx(s.start.x()), v.sy(s.start.y()));
  if (!s.is_arc()) {
    cairo_line_to(cr, v.sx(s.end.x()), v.sy(s.end.y()));
    return;
  }
  const double a0 = -s.start_angle, a1 = -s.end_angle();
  if (s.sweep > 0) cairo_arc_negative(cr, v.sx(s.center.x()), v.sy(s.center.y()), s.radius * v.scale, a0, a1);
  else cairo_arc(cr, v.sx(s.center.x()), v.sy(s.center.y()), s.radius * v.scale, a0, a1);
}

void trace_contour(cairo_t* cr, const PlotView& v, const Contour& c) {
  for (std::size_t i = 0; i < c.size(); ++i) trace_segment(cr, v, c.span(i), i == 0);
  cairo_close_path(cr);
}

double round_step(double want) {
  const double p10 = std::pow(10.0, std::floor(std::log10(want)));
  return want >= 5 * p10 ? 5 * p10 : (want >= 2 * p10 ? 2 * p10 : p10);
}

}  // namespace machplan
