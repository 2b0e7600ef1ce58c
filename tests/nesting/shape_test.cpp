// The shapes the searches test collisions on (solvers/nesting/internal/shape.h): meets() answers as
// Boost.Geometry's intersects on the moved polygons, touching included, and the poles lie
// inside the material.
#include <algorithm>
#include <cmath>
#include <random>

#include <boost/geometry/geometries/linestring.hpp>

#include <gtest/gtest.h>

#include "solvers/nesting/internal/shape.h"
#include "tests/nesting/shapes.h"

namespace machplan::nesting {
namespace {

// A 60 x 40 plate with a 30 x 20 window: parts can lie in the hole.
NestPart frame() {
  NestPart p = test::rect(60, 40, "frame");
  p.holes.push_back(Contour({{15, 10}, {15, 30}, {45, 30}, {45, 10}}, {0, 0, 0, 0}));
  p.area_mm2 -= 600;
  return p;
}

NestPart ell() {
  NestPart p;
  p.file = "ell";
  p.outer = Contour({{0, 0}, {30, 0}, {30, 8}, {8, 8}, {8, 30}, {0, 30}}, {0, 0, 0, 0, 0, 0});
  p.area_mm2 = 30 * 8 + 22 * 8;
  return p;
}

Poly moved(const Shape& s, double x, double y) {
  Poly m;
  bg::transform(s.poly, m, bg::strategy::transform::translate_transformer<double, 2, 2>(x, y));
  return m;
}

TEST(NestShape, MeetsAnswersAsBoostGeometryOnTheMovedPolygons) {
  std::vector<Shape> shapes;
  for (const NestPart& p : {frame(), ell(), test::disc(7), test::rect(12, 5)})
    for (const Shape& s : make_shapes(p, {0, 45, 90, 200}, true, 2.0, 0.05)) shapes.push_back(s);
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<std::size_t> any(0, shapes.size() - 1);
  std::uniform_real_distribution<double> at(-40, 40);
  int met = 0, apart = 0;
  for (int k = 0; k < 4000; ++k) {
    const Shape &a = shapes[any(rng)], &b = shapes[any(rng)];
    const Eigen::Vector2d pa(at(rng), at(rng)), pb(at(rng), at(rng));
    const bool boost = bg::intersects(moved(a, pa.x(), pa.y()), moved(b, pb.x(), pb.y()));
    ASSERT_EQ(meets(a, pa, b, pb), boost) << k;
    (boost ? met : apart) += 1;
  }
  EXPECT_GT(met, 400);
  EXPECT_GT(apart, 400);
  // A small part in the frame's window meets nothing; on the window's edge it meets the frame.
  const Shape f = make_shape(frame(), 0, false, 0, 0.05), r = make_shape(test::rect(12, 5), 0, false, 0, 0.05);
  EXPECT_FALSE(meets(f, {0, 0}, r, {20, 15}));
  EXPECT_TRUE(meets(f, {0, 0}, r, {20, 5.5}));
  // Two plates touching along an edge meet; a micrometre apart they do not.
  const Shape p = make_shape(test::rect(10, 10), 0, false, 0, 0.05);
  EXPECT_TRUE(meets(p, {0, 0}, p, {10 + 2e-5, 3}));
  EXPECT_FALSE(meets(p, {0, 0}, p, {10 + 2e-5 + 1e-3, 3}));
  // A small plate inside a large one, their bottom edges on one line: no edges cross, the small
  // one's first vertex lies on the large one's edge, and they still meet (in either order), as
  // in a bottom-left fill that slid a part down against another's edge.
  const Shape big = make_shapes(test::rect(700, 790), {0}, false, 0.0, 0.05)[0];
  const Shape small = make_shapes(test::rect(38.1, 38.1), {0}, false, 0.0, 0.05)[0];
  for (double dy : {0.0, 1e-13, -1e-13}) {
    EXPECT_TRUE(meets(small, {20, dy}, big, {0, 0})) << dy;
    EXPECT_TRUE(meets(big, {0, 0}, small, {20, dy})) << dy;
  }
}

TEST(NestShape, EveryPoleLiesInsideThePolygon) {
  for (const NestPart& part : {frame(), ell(), test::disc(7)})
    for (const Shape& s : make_shapes(part, {0, 90, 33}, false, 1.0, 0.05)) {
      ASSERT_GT(s.poles.size(), 0u);
      ASSERT_EQ(s.poles.padded() % Poles::kLanes, 0u);
      for (std::size_t k = 0; k < s.poles.size(); ++k) {
        const Pt c(s.poles.x[k], s.poles.y[k]);
        EXPECT_TRUE(bg::within(c, s.poly)) << part.file << " pole " << k;
        // Its circle stays inside too, within the tolerance the turned poles may stand out by.
        double room = bg::distance(c, bg::model::linestring<Pt>(s.poly.outer().begin(), s.poly.outer().end()));
        for (const auto& h : s.poly.inners()) room = std::min(room, bg::distance(c, bg::model::linestring<Pt>(h.begin(), h.end())));
        EXPECT_GE(room + 0.06, s.poles.radius[k]) << part.file << " pole " << k;
      }
    }
}

TEST(NestShape, ATurnedShapeIsTheShapeMadeAtThatAngle) {
  // Arcs, a hole and a mirror: turning the shape made at 0 degrees gives the rings, poles and
  // boxes of the shape made at the angle (its part box from the hull: holding the part, within
  // the tolerance), and meets() answers the same for both.
  NestPart p = frame();
  p.outer = Contour({{0, 0}, {60, 0}, {60, 40}, {0, 40}}, {0, 0.4, 0, 0});
  for (const bool mirrored : {false, true}) {
    const Shape base = make_shape(p, 0, mirrored, 2.0, 0.05);
    for (const double deg : {37.0, 200.5, -73.25}) {
      const Shape made = make_shape(p, deg, mirrored, 2.0, 0.05), turned = turned_shape(base, deg);
      EXPECT_NEAR(turned.rotation_deg, std::fmod(deg + 360.0, 360.0), 1e-12);
      ASSERT_EQ(turned.rings.size(), made.rings.size());
      for (std::size_t k = 0; k < made.rings.size(); ++k) {
        ASSERT_EQ(turned.rings[k].size(), made.rings[k].size());
        for (std::size_t i = 0; i < made.rings[k].size(); ++i) EXPECT_LT((turned.rings[k][i] - made.rings[k][i]).norm(), 1e-9);
      }
      EXPECT_TRUE(turned.part_box.contains(made.part_box));
      EXPECT_LT((turned.part_box.sizes() - made.part_box.sizes()).maxCoeff(), 2 * 0.05);
      EXPECT_NEAR(bg::area(made.poly), turned.area_mm2, 1e-6);
      const Shape other = make_shape(ell(), 0, false, 2.0, 0.05);
      std::mt19937 rng(7);
      std::uniform_real_distribution<double> u(-60, 60);
      for (int k = 0; k < 200; ++k) {
        const Eigen::Vector2d at(u(rng), u(rng));
        EXPECT_EQ(meets(turned, Eigen::Vector2d::Zero(), other, at), meets(made, Eigen::Vector2d::Zero(), other, at)) << at.transpose();
      }
    }
  }
  // A rectangle drawn 20 degrees askew is squared at -20 degrees and every quarter turn from it.
  Placement askew;
  askew.rotation_deg = 20;
  NestPart r = test::rect(100, 50);
  r.outer = place(r.outer, askew);
  std::vector<double> sq = squaring_rotations(r, 0.05);
  std::sort(sq.begin(), sq.end());
  ASSERT_EQ(sq.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(sq[k], 70.0 + 90.0 * static_cast<double>(k), 1e-6);
}

}  // namespace
}  // namespace machplan::nesting
