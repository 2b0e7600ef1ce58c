// engine/geometry/chaining.h: runs of spans joined end to end into closed and open chains, in
// any order and direction, with the joins across wide gaps listed.
#include "engine/geometry/chaining.h"

#include <cmath>

#include <gtest/gtest.h>

#include "engine/geometry/contour.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

SpanRun run(std::size_t id, Vector2d a, Vector2d b, double bulge = 0.0) {
  SpanRun r;
  r.vertices = {a, b};
  r.bulges = {bulge};
  r.parts = {id};
  return r;
}

TEST(Chaining, ShuffledReversedPiecesCloseIntoOneContour) {
  // A 10 x 10 square with a half-circle on its top side, drawn out of order, one side reversed.
  const std::vector<SpanRun> runs = {
      run(0, {0, 0}, {10, 0}),
      run(1, {0, 10}, {0, 0}),
      run(2, {10, 10}, {10, 0}),          // reversed
      run(3, {10, 10}, {0, 10}, 1.0),     // a half circle bulging up
  };
  const Chaining c = chain_runs(runs, 0.01);
  ASSERT_EQ(c.closed.size(), 1u);
  EXPECT_TRUE(c.open.empty());
  EXPECT_TRUE(c.joins.empty());
  const SpanRun& s = c.closed[0];
  EXPECT_TRUE(s.closed);
  EXPECT_EQ(s.parts, (std::vector<std::size_t>{0, 2, 3, 1}));
  // The first run keeps its direction; the reversed one is turned round.
  EXPECT_EQ(s.vertices.front(), Vector2d(0, 0));
  const Contour contour(s.vertices, s.bulges);
  EXPECT_NEAR(signed_area(contour), 100 + M_PI * 25 / 2, 1e-9);
  EXPECT_NEAR(s.length(), 30 + M_PI * 5, 1e-9);
}

TEST(Chaining, GapsBeyondTheToleranceStayOpenAndJoinsAreListed) {
  // A triangle with one corner 0.2 mm apart.
  const std::vector<SpanRun> runs = {run(0, {0, 0}, {10, 0}), run(1, {10, 0}, {5, 8}), run(2, {5, 8}, {0.2, 0})};
  const Chaining tight = chain_runs(runs, 0.01);
  EXPECT_TRUE(tight.closed.empty());
  ASSERT_EQ(tight.open.size(), 1u);
  EXPECT_EQ(tight.open[0].parts, (std::vector<std::size_t>{0, 1, 2}));
  // Chained again with a wider tolerance, the gap closes and is listed (above 0.01 mm).
  const Chaining healed = chain_runs(tight.open, 0.5, 0.01);
  ASSERT_EQ(healed.closed.size(), 1u);
  ASSERT_EQ(healed.joins.size(), 1u);
  EXPECT_NEAR(healed.joins[0].gap_mm, 0.2, 1e-12);
  EXPECT_EQ(healed.joins[0].from, 2u);
  EXPECT_EQ(healed.joins[0].to, 0u);  // the chain closed on its own start
}

TEST(Chaining, ClosedRunsPassThroughAndOneSpanCannotClose) {
  SpanRun circle;
  circle.vertices = {{1, 0}, {-1, 0}};
  circle.bulges = {1, 1};
  circle.closed = true;
  circle.parts = {7};
  // A single line whose ends are within the tolerance is not a contour.
  const Chaining c = chain_runs({circle, run(8, {0, 0}, {0.001, 0})}, 0.01);
  ASSERT_EQ(c.closed.size(), 1u);
  EXPECT_EQ(c.closed[0].parts, std::vector<std::size_t>{7});
  ASSERT_EQ(c.open.size(), 1u);
  // Reversing twice gives the run back.
  SpanRun r = run(9, {0, 0}, {3, 4}, 0.5);
  r.reverse();
  EXPECT_EQ(r.vertices.front(), Vector2d(3, 4));
  EXPECT_EQ(r.bulges[0], -0.5);
}

}  // namespace
}  // namespace machplan
