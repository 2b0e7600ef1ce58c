// The cross-coupled contour controller (engine/control/cross_coupled_controller.h): the
// contour error model on hand-computed lines and circles, and the direction of its correction.
#include <gtest/gtest.h>

#include "engine/control/cross_coupled_controller.h"

namespace machplan::control {
namespace {

ControllerInput at(Eigen::Vector2d r, Eigen::Vector2d y) {
  ControllerInput in;
  in.r_mm = {r.x(), r.y()};
  in.y_mm = {y.x(), y.y()};
  return in;
}

TEST(ContourEstimate, LineIsTheSignedDistanceAndTheGainsAreSinCos) {
  const double th = 26.6 * M_PI / 180;
  const Eigen::Vector2d dir(std::cos(th), std::sin(th)), right(std::sin(th), -std::cos(th));
  const Segment line = make_segment({10, 10}, Eigen::Vector2d(10, 10) + 100 * dir, 0.0);
  const Eigen::Vector2d r = Eigen::Vector2d(10, 10) + 40 * dir;
  ControllerInput in = at(r, r + 0.03 * right - 0.2 * dir);  // 0.03 mm to the right, lagging 0.2 mm
  in.path = &line;
  const ContourEstimate e = estimate_contour_error(in);
  ASSERT_TRUE(e.valid);
  EXPECT_NEAR(e.eps_mm, 0.03, 1e-12);  // the lag along the line is no contour error
  EXPECT_NEAR(e.cx, std::sin(th), 1e-12);
  EXPECT_NEAR(e.cy, std::cos(th), 1e-12);
  in = at(r, r - 0.05 * right);
  in.path = &line;
  EXPECT_NEAR(estimate_contour_error(in).eps_mm, -0.05, 1e-12);
}

TEST(ContourEstimate, CircleIsTheRadiusErrorAndTheGainsCarryTheCurvature) {
  const Segment ccw = make_segment({20, 0}, {-20, 0}, 1.0);  // centre (0, 0), R 20, turning left
  ASSERT_TRUE(ccw.is_arc());
  ASSERT_NEAR(ccw.radius, 20, 1e-12);
  const Eigen::Vector2d r(20, 0), y(20.1, -0.05);  // theta = 90 deg at r
  ControllerInput in = at(r, y);
  in.path = &ccw;
  ContourEstimate e = estimate_contour_error(in);
  const double ex = r.x() - y.x(), ey = r.y() - y.y();
  EXPECT_NEAR(e.eps_mm, y.norm() - 20, 1e-12);    // outside a left turn: to the right, positive
  EXPECT_NEAR(e.cx, 1.0 - ex / (2 * 20), 1e-12);  // sin(90) - Ex / (2 rho)
  EXPECT_NEAR(e.cy, 0.0 + ey / (2 * 20), 1e-12);  // cos(90) + Ey / (2 rho)
  // Koren's model eps = -Ex Cx + Ey Cy is (|y - c|^2 - rho^2) / (2 rho) exactly: the radius
  // error to first order in it.
  EXPECT_NEAR(-ex * e.cx + ey * e.cy, (y.squaredNorm() - 400) / 40, 1e-12);
  EXPECT_NEAR(-ex * e.cx + ey * e.cy, e.eps_mm, 3e-4);

  const Segment cw = make_segment({-20, 0}, {20, 0}, -1.0);  // the same circle turning right
  ASSERT_LT(cw.sweep, 0);
  in.path = &cw;
  e = estimate_contour_error(in);
  EXPECT_NEAR(e.eps_mm, 20 - y.norm(), 1e-12);  // outside a right turn is to the left: negative
  EXPECT_NEAR(e.cx, -1.0 + ex / (2 * 20), 1e-12);
}

TEST(ContourEstimate, WithoutAPathTheReferenceMotionGivesDirectionAndCurvature) {
  // At (20, 0) on a left turn of radius 20 at 10 mm/s: v = (0, 10), a = (-5, 0).
  const Eigen::Vector2d r(20, 0), y(20.1, -0.05);
  ControllerInput in = at(r, y);
  in.v_ff_mm_per_s = {0, 10};
  in.a_ff_mm_per_s2 = {-5, 0};
  const ContourEstimate e = estimate_contour_error(in);
  ASSERT_TRUE(e.valid);
  const double ex = -0.1, ey = 0.05;
  EXPECT_NEAR(e.cx, 1.0 - 0.05 * ex / 2, 1e-12);
  EXPECT_NEAR(e.cy, 0.05 * ey / 2, 1e-12);
  EXPECT_NEAR(e.eps_mm, (y.squaredNorm() - 400) / 40, 1e-12);  // the model, as above
  // At rest there is no contour and no estimate.
  EXPECT_FALSE(estimate_contour_error(at(r, y)).valid);
}

TEST(CrossCoupledController, CorrectionPushesTheToolBackOntoThePath) {
  PidGains none;
  none.kp_per_s = 0;  // axial loops off: only the contour loop acts
  ContourGains w;
  w.kp_per_s = 100;
  CrossCoupledController c;
  c.configure({none, none}, w, {500, 500}, 0.001);
  const Segment line = make_segment({0, 0}, {100, 0}, 0.0);  // along +X
  ControllerInput in = at({50, 0}, {49.9, -0.1});           // 0.1 right of the path, 0.1 behind
  in.path = &line;
  ControllerOutput out;
  c.update(in, out);
  EXPECT_NEAR(c.last_estimate().eps_mm, 0.1, 1e-12);
  EXPECT_NEAR(out.u_mm_per_s[0], 0.0, 1e-12);  // Cx = sin 0: the lag is left to the axial loop
  EXPECT_NEAR(out.u_mm_per_s[1], 10.0, 1e-12);  // Cy U = 1 * 100 * 0.1, towards the path

  // On a 45 degree line the correction is shared: (-Cx U, Cy U) = U (-sin, cos), the left normal.
  c.reset();
  const Segment diag = make_segment({0, 0}, {100, 100}, 0.0);
  const Eigen::Vector2d right(std::sqrt(0.5), -std::sqrt(0.5));
  in = at({50, 50}, Eigen::Vector2d(50, 50) + 0.2 * right);
  in.path = &diag;
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[0], -20 * std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(out.u_mm_per_s[1], 20 * std::sqrt(0.5), 1e-9);
}

TEST(CrossCoupledController, ContourIntegralAddsUpAndResets) {
  PidGains none;
  none.kp_per_s = 0;
  ContourGains w;
  w.kp_per_s = 0;
  w.ki_per_s2 = 1000;
  CrossCoupledController c;
  c.configure({none, none}, w, {500, 500}, 0.001);
  const Segment line = make_segment({0, 0}, {100, 0}, 0.0);
  ControllerInput in = at({50, 0}, {50, -0.1});
  in.path = &line;
  ControllerOutput out;
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[1], 0.0, 1e-12);  // S starts at 0
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[1], 1000 * 0.001 * 0.1, 1e-12);
  c.reset();
  c.update(in, out);
  EXPECT_NEAR(out.u_mm_per_s[1], 0.0, 1e-12);
}

}  // namespace
}  // namespace machplan::control
