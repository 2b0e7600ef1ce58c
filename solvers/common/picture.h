// Writing a Cairo drawing to a file, PNG or SVG by the file's extension: the part every plot
// in solvers/ shares (placement, run, guard, tuning).
#pragma once

#include <functional>
#include <string>

// Cairo's own declaration (cairo.h), repeated so that callers need not see Cairo's headers.
typedef struct _cairo cairo_t;

namespace machplan {

// Creates a `width` x `height` surface (pixels for PNG, points for SVG), calls `draw` on it and
// writes `path`. Throws InputError::field(field, ...) when the extension is neither .png nor
// .svg (`field`: the caller's name for the option that gave the path, "plot"), and InputError
// naming the file when it cannot be created or written. Exceptions from `draw` propagate
// after the surface is released.
void write_picture(const std::string& path, const std::string& field, double width, double height,
                   const std::function<void(cairo_t*)>& draw);

// True when `path` ends in .png or .svg (what write_picture accepts).
bool is_picture_path(const std::string& path);

// A view of plan coordinates (mm, y up) on the picture (y down).
struct PlotView {
  double ox, oy, scale;  // picture = (ox + scale * x, oy - scale * y)
  double sx(double x) const { return ox + scale * x; }
  double sy(double y) const { return oy - scale * y; }
};

struct Segment;
class Contour;

// Traces a segment as a path (arcs as Cairo arcs; y is flipped, so the angles are negated),
// starting a new sub-path at its start when `move_first`.
void trace_segment(cairo_t* cr, const PlotView& v, const Segment& s, bool move_first);
// Traces a closed contour as one closed sub-path.
void trace_contour(cairo_t* cr, const PlotView& v, const Contour& c);

// Text with its baseline starting at (x, y), in picture units.
void draw_text(cairo_t* cr, double x, double y, const std::string& s, double size = 13);

// A round length for scale bars and axis ticks: the largest 1, 2 or 5 times a power of ten
// that is at most `want` (> 0).
double round_step(double want);

}  // namespace machplan
