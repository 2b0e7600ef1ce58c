// Pictures, PNG or SVG by the file's extension: the part every plot in solvers/ shares
// (placement, run, guard, tuning). Cairo draws them; it stays in picture.cpp, behind Canvas.
#pragma once

#include <functional>
#include <string>

namespace machplan {

// What a plot draws on: Cairo's drawing model under our own names. A path is traced
// (move_to, line_to, arc, rectangle, close_path) and then stroked or filled with the current
// source colour, line width and dash; save() and restore() bracket changes to that state and
// to the clip. Coordinates are picture units (pixels for PNG, points for SVG) with y down, so
// an arc from angle a0 to a1 > a0 turns clockwise on the picture. Only write_picture() makes
// one; it lives for the duration of the drawing callback.
class Canvas {
 public:
  enum class FillRule { winding, even_odd };
  enum class LineJoin { miter, round, bevel };

  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  // Drawing state.
  void set_source_rgb(double r, double g, double b);
  void set_source_rgba(double r, double g, double b, double a);
  void set_line_width(double width);
  // `count` lengths alternately on and off, starting `offset` into the pattern; count 0 (and
  // dashes null) draws solid lines again.
  void set_dash(const double* dashes, int count, double offset);
  void set_fill_rule(FillRule rule);  // default winding
  void set_line_join(LineJoin join);  // default miter
  void set_font_size(double size);
  void save();
  void restore();

  // The current path.
  void move_to(double x, double y);
  void line_to(double x, double y);
  void arc(double xc, double yc, double radius, double angle1, double angle2);           // increasing angle
  void arc_negative(double xc, double yc, double radius, double angle1, double angle2);  // decreasing angle
  void rectangle(double x, double y, double width, double height);
  void close_path();

  // Using the path (stroke, fill and clip clear it; fill_preserve keeps it) or the whole surface.
  void stroke();
  void fill();
  void fill_preserve();
  void clip();  // intersects the clip with the path, until the matching restore()
  void paint();

  // Text with its baseline starting at the current point, in the current font size.
  void show_text(const std::string& s);
  // How far show_text(s) would move the current point along x.
  double text_advance(const std::string& s);

 private:
  struct Context;  // Cairo's drawing context (picture.cpp)
  explicit Canvas(Context& context) : context_(context) {}
  friend void write_picture(const std::string&, const std::string&, double, double,
                            const std::function<void(Canvas&)>&);
  Context& context_;
};

// Creates a `width` x `height` surface (pixels for PNG, points for SVG), calls `draw` on it and
// writes `path`. Throws InputError::field(field, ...) when the extension is neither .png nor
// .svg (`field`: the caller's name for the option that gave the path, "plot"), and InputError
// naming the file when it cannot be created or written. Exceptions from `draw` propagate
// after the surface is released.
void write_picture(const std::string& path, const std::string& field, double width, double height,
                   const std::function<void(Canvas&)>& draw);

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

// Traces a segment as a path (y is flipped, so the arcs' angles are negated), starting a new
// sub-path at its start when `move_first`.
void trace_segment(Canvas& canvas, const PlotView& v, const Segment& s, bool move_first);
// Traces a closed contour as one closed sub-path.
void trace_contour(Canvas& canvas, const PlotView& v, const Contour& c);

// Text with its baseline starting at (x, y), in picture units.
void draw_text(Canvas& canvas, double x, double y, const std::string& s, double size = 13);

// A round length for scale bars and axis ticks: the largest 1, 2 or 5 times a power of ten
// that is at most `want` (> 0).
double round_step(double want);

// A scale bar of `length_mm` (take it from round_step) from (x, y) to the right, at `scale`
// picture units per mm, labelled above it ("50 mm").
void draw_scale_bar(Canvas& canvas, double x, double y, double scale, double length_mm);

}  // namespace machplan
