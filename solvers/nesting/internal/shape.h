// A part turned one way, as the searches see it: its polygon grown by half the spacing and
// approximated from outside (outline.h), with its holes shrunk by as much as holes of the
// polygon, about the part's reference point. Two parts whose polygons do not meet keep the
// spacing on their true lines and arcs (the certificate checks it on those).
//
// The poles: circles inside the polygon's material, the largest first, each the largest that
// fits beside the ones before (found on a grid), at most 8 (more made the search slower for no
// better nests: the exact test decides what they miss), none smaller than a tenth of the first. Two
// parts whose poles overlap surely collide, and how deep the poles of two colliding parts go
// into each other measures their collision smoothly (strip_search.h), as in the sparrow nester
// of Gardeyn and Wauters ("An open-source heuristic to reboot 2D nesting research", 2025).
#pragma once

#include <cstdint>
#include <vector>

#include <boost/geometry.hpp>
#include <boost/geometry/geometries/box.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/common/termination.h"
#include "solvers/nesting/bottom_left.h"
#include "solvers/nesting/part.h"
#include "solvers/nesting/strip_search.h"

namespace machplan::nesting {

namespace bg = boost::geometry;
using Pt = bg::model::d2::point_xy<double>;
using Poly = bg::model::polygon<Pt>;  // clockwise, closed (Boost's default)
using Box = bg::model::box<Pt>;

// Circles inside a shape, as arrays of their centres' x and y and their radii (about the part's
// reference point), so that the overlap of two sets vectorises: `count` poles, at most kLanes,
// the arrays padded to kLanes with circles of radius 0 far away (which add nothing to an overlap).
struct Poles {
  static constexpr std::size_t kLanes = 8;
  std::size_t count = 0;
  std::vector<float> x, y, radius;
  std::size_t size() const { return count; }
  std::size_t padded() const { return radius.size(); }
};

struct Shape {
  double rotation_deg = 0.0;
  bool mirrored = false;
  Poly poly;
  Box box;                       // the polygon's
  Eigen::AlignedBox2d part_box;  // the true part's (what must lie in the sheet's usable area)
  std::vector<Eigen::Vector2d> part_hull;  // the convex hull of the true part's outside polygon (turned_shape's part_box)
  Poles poles;
  std::vector<std::vector<Eigen::Vector2d>> rings;  // the polygon's: the outer first, then the holes (not closed)
  std::int64_t vertices = 0;     // of all its rings
  double area_mm2 = 0.0;         // the polygon's
  double hull_area_mm2 = 0.0;    // its convex hull's
  double diameter_mm = 0.0;      // its box's diagonal
};

// The part turned by `deg` (mirrored first when asked), grown by spacing / 2.
Shape make_shape(const NestPart& part, double deg, bool mirrored, double spacing_mm, double tolerance_mm);

// `base` turned about the part's reference point to `deg` (mirrored as it is), for a part that
// turns freely: its rings, poles and boxes turned (the true part's box from its hull, so it
// holds the part); its Boost polygon is left empty (the strip search does not read it).
Shape turned_shape(const Shape& base, double deg);

// The angles in [0, 360) that square the part's smallest box (a hull edge along x), four of
// them 90 degrees apart: what a part drawn askew is best tried at.
std::vector<double> squaring_rotations(const NestPart& part, double tolerance_mm);

// Every way a part may be turned: `rotations` (each mirrored too when `mirror`).
std::vector<Shape> make_shapes(const NestPart& part, const std::vector<double>& rotations, bool mirror, double spacing_mm,
                               double tolerance_mm);

// What a remnant sheet holds fixed, as shapes at (0, 0): a frame round it whose hole is the
// outline, and each cut-out; grown so that a part's shape that does not meet them keeps the
// sheet's margin from their true edges (at least half the spacing). None for a whole sheet.
std::vector<Shape> sheet_obstacles(const Sheet& sheet, double spacing_mm, double tolerance_mm);

// Whether the polygons of `a` at `at_a` and of `b` at `at_b` meet, touching included (what
// bg::intersects says of the moved polygons, without moving them): a pair of edges that meet,
// or a vertex of one inside the other's material. Thread-safe.
bool meets(const Shape& a, const Eigen::Vector2d& at_a, const Shape& b, const Eigen::Vector2d& at_b);

// The steps meets() took on this thread since it started: edges scanned, pairs of edges tested
// and vertices of the point-in-polygon tests. What its work is charged by (strip_search.cpp).
std::int64_t& meets_steps();

// The box moved by (x, y).
Box moved(const Box& b, double x, double y);

// The searches on shapes made once for a request (bottom_left.cpp, strip_search.cpp).

// Every way each part may be turned, per part; checks the request as bottom_left_nest does.
using ShapeSet = std::vector<std::vector<Shape>>;
ShapeSet shapes_of(const NestRequest& request);

struct NestProgress;

// bottom_left_nest with restarts (bottom_left.h) on those shapes.
// `first`, when given, is the first fill already made (restarts go on from it, as from their
// own).
NestResult bottom_left_nest(const NestRequest& request, const ShapeSet& shapes, Termination& t, std::uint64_t seed,
                            const NestResult* first = nullptr);

// Shortens the used length of `nest`'s last used sheet in place until `t` ends (a deadline of
// nominal work, or a stop request: the best so far is kept). `nest` must be feasible, as the
// bottom-left fill makes it; the other sheets are left as they are (strip_search.h). Reports to
// `progress` when it is not null.
StripSearchStats shorten_last_sheet(const NestRequest& request, const ShapeSet& shapes, NestResult& nest, Termination& t,
                                    std::uint64_t seed, int workers, NestProgress* progress = nullptr);

}  // namespace machplan::nesting
