// Closed 2-D contours made of straight and circular spans: the vocabulary of profiles, kerf
// offsetting and the hybrid-machining guard.
//
// A Contour is a closed polyline of n >= 1 vertices P0 .. P(n-1) with one bulge per vertex.
// Span i runs from P(i) to P((i+1) mod n); bulge b(i) describes its shape exactly as in a DXF
// LWPOLYLINE:
//
//     b = tan(sweep / 4),   sweep in (-2 pi, 2 pi), positive = counter-clockwise arc,
//     b = 0: straight line,   |b| = 1: half circle.
//
// With chord c = |P(i+1) - P(i)| the arc's radius and centre are
//
//     r = c (1 + b^2) / (4 |b|) = (c / 4) (|b| + 1/|b|)
//     centre = midpoint + n_left * (c / 2) * (1/b - b) / 2
//
// where n_left is the unit chord direction turned by +90 degrees. A full circle therefore
// takes two spans (for example two half circles with b = 1).
//
// Degenerate input is allowed but defined: a span whose end points coincide (c == 0) is a
// zero-length straight span whatever its bulge, since a single DXF span cannot express a full
// circle. Functions below never divide by such a chord.
//
// Non-finite input is rejected when a Contour is built: coordinates must be finite with
// |x|, |y| <= kMaxCoordinateMm and bulges finite with |b| <= kMaxBulge, so every figure
// computed below is finite. Constructing a Contour is the only validation point; all other
// functions take a valid Contour or valid Segments and never throw on geometry.
//
// Units are millimetres and radians. Nothing here allocates except the functions that return
// vectors. All functions are pure and thread-safe.
//
// Example:
//
//     // A 20 x 10 slot: two lines and two half circles of radius 5, counter-clockwise.
//     Contour slot({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {0, 1, 0, 1});
//     signed_area(slot);   // 10 * 10 + pi * 25 = 178.54 mm^2, positive: ccw
//     perimeter(slot);     // 2 * 10 + 2 * pi * 5
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan {

// Largest coordinate accepted, mm (1000 km): far beyond any machine, small enough that
// squares and products of coordinates stay far from overflow.
inline constexpr double kMaxCoordinateMm = 1e9;
// Largest |bulge| accepted: a sweep within 4e-8 rad of a full turn.
inline constexpr double kMaxBulge = 1e8;

// One span turned into its geometric kind.
//
// For a line, `center`, `radius`, `start_angle` and `sweep` are zero. For an arc, the points
// are center + radius (cos t, sin t) for t from start_angle to start_angle + sweep;
// sweep > 0 is counter-clockwise, |sweep| < 2 pi. `start` and `end` are the span's end points
// exactly as given (not recomputed from the angles).
struct Segment {
  enum class Kind { line, arc };
  Kind kind = Kind::line;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
  double start_angle = 0.0;  // rad, atan2 of (start - center)
  double sweep = 0.0;        // rad, signed

  double end_angle() const { return start_angle + sweep; }
  bool is_arc() const { return kind == Kind::arc; }
};

// The span from `a` to `b` with bulge `bulge` (see the file comment). Preconditions: finite
// inputs within the limits above (not checked here; Contour checks them). Coincident `a` and
// `b`, or bulge 0, give a line.
Segment make_segment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double bulge);

// Length of a segment, mm: |b - a| for a line, radius * |sweep| for an arc.
double length(const Segment& s);

// The point at parameter t in [0, 1] (clamped), uniform in arc length.
Eigen::Vector2d point_at(const Segment& s, double t);

// The point of `s` nearest to `p`. For an arc seen from its own centre every point is
// equally near; the start is returned.
Eigen::Vector2d closest_point(const Segment& s, const Eigen::Vector2d& p);

// The point of the straight segment a -> b nearest to `p` (a when a == b), and its distance.
// These are the one place the plane's point-to-segment distance is written.
Eigen::Vector2d closest_point_on_segment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p);
double point_segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b);

// Parameter t in [0, 1] (uniform in length, as point_at) of the point of `s` at or nearest
// to `p`, for a `p` that lies on the segment up to rounding. On an arc, a p whose angle falls
// outside the arc's range gives the end (0 or 1) nearer in angle. A zero-length line gives 0.
double parameter_at(const Segment& s, const Eigen::Vector2d& p);

// Unit direction of travel at the start / end of a segment of positive length (for an arc,
// computed from its angles, so exact to rounding).
Eigen::Vector2d start_tangent(const Segment& s);
Eigen::Vector2d end_tangent(const Segment& s);
// Unit direction of travel at a point q of the segment (an arc: perpendicular to q - centre,
// turned with the sweep). Degenerate cases (zero-length line, q at the centre) give +x.
Eigen::Vector2d tangent_at(const Segment& s, const Eigen::Vector2d& q);

// z component of the cross product of two plane vectors: a.x b.y - a.y b.x.
inline double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// An angle wrapped into [0, 2 pi), rad.
double wrap_angle_positive(double angle_rad);

// Smallest axis-aligned box holding the segment (arcs: end points plus the extreme points at
// 0, 90, 180, 270 degrees that the arc passes).
Eigen::AlignedBox2d bounding_box(const Segment& s);

// Where two segments meet.
//
// `points` holds the isolated crossing or touching points (at most two). When the segments
// share a piece of curve (collinear overlapping lines, or arcs on the same circle with
// overlapping angular ranges) `overlap` is true and `points` holds the two ends of the shared
// piece. `tolerance_mm` widens every test: points within it of both segments count; segments
// that pass within it of each other without crossing count as touching at the nearest point
// only for the line-line and tangent cases. It must be >= 0.
struct Intersection {
  std::vector<Eigen::Vector2d> points;
  bool overlap = false;
  bool empty() const { return points.empty() && !overlap; }
};
Intersection intersect(const Segment& a, const Segment& b, double tolerance_mm = 1e-9);

// A closed contour; see the file comment for the meaning of vertices and bulges.
class Contour {
 public:
  Contour() = default;
  // Throws InputError::field naming the offending index when the sizes differ, the
  // contour is empty, or a coordinate or bulge is non-finite or beyond the limits above.
  Contour(std::vector<Eigen::Vector2d> vertices, std::vector<double> bulges);

  // A circle of radius r > 0 as two half circles, counter-clockwise (ccw = true) or
  // clockwise, starting at center + (r, 0). Throws InputError like the constructor
  // and when r is not positive.
  static Contour circle(const Eigen::Vector2d& center, double r, bool ccw = true);

  const std::vector<Eigen::Vector2d>& vertices() const { return vertices_; }
  const std::vector<double>& bulges() const { return bulges_; }
  std::size_t size() const { return vertices_.size(); }
  bool empty() const { return vertices_.empty(); }

  // Span i (0 <= i < size()) as a Segment; span size()-1 closes the contour.
  Segment span(std::size_t i) const;
  std::vector<Segment> segments() const;

  // The same contour traversed the other way (vertex order reversed, bulges negated and
  // shifted so that each stays with its span). Area changes sign; everything else is equal.
  Contour reversed() const;

 private:
  std::vector<Eigen::Vector2d> vertices_;
  std::vector<double> bulges_;
};

enum class Orientation { ccw, cw, degenerate };
const char* to_string(Orientation o);

// Signed enclosed area, mm^2, exact for arcs: the shoelace sum of the chords plus, for each
// arc, the signed circular-segment area (r^2 / 2)(theta - sin theta), theta = sweep.
// Positive for counter-clockwise contours. For a self-intersecting contour this is the
// sum of the lobes weighted by their winding numbers.
double signed_area(const Contour& c);

// ccw when signed_area > tolerance_mm2, cw when < -tolerance_mm2, else degenerate.
Orientation orientation(const Contour& c, double tolerance_mm2 = 1e-12);

// Total length of all spans, mm.
double perimeter(const Contour& c);

// Bounding box of all spans, arcs included exactly. Empty box for an empty contour.
Eigen::AlignedBox2d bounding_box(const Contour& c);

// The point at arc length s from vertex 0 along the contour; s is taken modulo the perimeter
// (negative s walks backwards). Returns vertex 0 for a contour of zero length.
Eigen::Vector2d point_at_length(const Contour& c, double s);

struct ContourPoint {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  std::size_t span = 0;   // index of the span holding `point`
  double distance = 0.0;  // |point - query|, mm
};
// The point of the contour nearest to `p` (ties: the lowest span index). Precondition: the
// contour is not empty.
ContourPoint closest_point(const Contour& c, const Eigen::Vector2d& p);

// Unsigned distance from `p` to the contour, mm.
double distance(const Contour& c, const Eigen::Vector2d& p);

// Winding number of the contour about `p`: the number of counter-clockwise turns the contour
// makes around it (negative for clockwise). Computed exactly per span: a line contributes the
// angle its chord subtends at p; an arc contributes the same plus +-2 pi when p lies in the
// circular segment between its chord and the arc. Points on (or within rounding of) the
// contour give an unspecified but finite answer; test distance() first when that matters.
int winding_number(const Contour& c, const Eigen::Vector2d& p);

// Non-zero winding rule: true when p is inside the contour (either orientation).
bool contains(const Contour& c, const Eigen::Vector2d& p);

// Places where the contour crosses or touches itself, other than at the shared vertex of two
// consecutive spans. Spans shorter than tolerance_mm are ignored (they cannot be told apart
// from a vertex). Sorted by span pair; each point reported once per pair of spans.
struct SelfIntersection {
  std::size_t span_a = 0, span_b = 0;  // span_a < span_b
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
};
std::vector<SelfIntersection> self_intersections(const Contour& c, double tolerance_mm = 1e-6);

// Points where two contours cross, touch or share a piece of boundary (tolerance as in
// intersect()). Empty when they are disjoint or one lies strictly inside the other.
std::vector<Eigen::Vector2d> contour_intersections(const Contour& a, const Contour& b,
                                                   double tolerance_mm = 1e-6);

// Calls f(i, j) once for every pair i != j of boxes that intersect (touching counts), by
// sweep and prune: boxes sorted by their low edge along the axis on which they are thinner
// relative to the spread, each compared only with the boxes still open at its low edge.
// O(n log n + k) for k pairs when few boxes overlap along that axis; memory O(n). Empty boxes
// take part in no pair. The order of calls is deterministic (it depends only on the boxes).
void for_each_intersecting_pair(const std::vector<Eigen::AlignedBox2d>& boxes,
                                const std::function<void(std::size_t, std::size_t)>& f);

}  // namespace machplan
