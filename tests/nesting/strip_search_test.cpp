// The strip search (solvers/nesting/strip_search.h): it shortens the bottom-left nest's last
// sheet, every nest it returns passes the certificate, the same seed and work give the same
// nest, a stop returns the best so far, and the sheets before the last are left alone.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "engine/common/stop.h"
#include "solvers/nesting/internal/shape.h"
#include "solvers/nesting/strip_search.h"
#include "tests/nesting/shapes.h"

namespace machplan::nesting {
namespace {

using test::disc;
using test::rect;

// An L of legs `a` long and `b` wide: bottom-left fill packs it badly, interlocking it well.
NestPart ell(double a, double b) {
  NestPart p;
  p.file = "ell";
  p.outer = Contour({{0, 0}, {a, 0}, {a, b}, {b, b}, {b, a}, {0, a}}, {0, 0, 0, 0, 0, 0});
  p.area_mm2 = a * b + (a - b) * b;
  return p;
}

NestRequest ells_and_discs() {
  NestRequest r;
  r.parts = {ell(60, 15), disc(12), rect(50, 20)};
  r.quantity = {10, 6, 4};
  r.rotations_deg = {0, 90, 180, 270};
  r.sheets = {Sheet{3000, 130, 5}};
  r.spacing_mm = 3;
  return r;
}

NestResult searched(const NestRequest& r, double work_s, std::uint64_t seed, StripSearchStats* stats = nullptr) {
  Termination t;
  t.set_deadline(work_s, "nominal search time");
  return nest(r, t, seed, 2, stats);
}

TEST(StripSearch, ShortensTheBottomLeftNestAndEveryNestItReturnsIsCertified) {
  const NestRequest r = ells_and_discs();
  const NestResult first = bottom_left_nest(r);
  StripSearchStats stats;
  const NestResult n = searched(r, 0.3, 3, &stats);
  ASSERT_EQ(n.placements.size(), first.placements.size());
  EXPECT_TRUE(n.unplaced.empty());
  std::printf("bottom-left %.1f mm, searched %.1f mm (%d of %d shrinks kept, %lld moves)\n", first.last_length_mm(),
              n.last_length_mm(), stats.shrinks_kept, stats.shrinks_tried, static_cast<long long>(stats.moves));
  EXPECT_GT(stats.shrinks_kept, 0);
  EXPECT_LT(n.last_length_mm(), 0.97 * first.last_length_mm()) << "at least 3 % shorter than the bottom-left fill";
  const Certificate c = certify(r.parts, n.placements, r.sheets, r.spacing_mm);
  EXPECT_TRUE(c.certified) << (c.violations.empty() ? "" : c.violations[0]);
  // What it said while it ran ends where the answer is: every share spent, the same length.
  NestProgress progress;
  Termination t;
  t.set_deadline(0.3, "nominal search time");
  const NestResult watched = nest(r, t, 3, 2, nullptr, &progress);
  EXPECT_EQ(progress.share.share(), 1.0);
  EXPECT_EQ(progress.sheets.load(), 1);
  EXPECT_DOUBLE_EQ(progress.last_length_mm.load(), watched.last_length_mm());
  EXPECT_DOUBLE_EQ(watched.last_length_mm(), n.last_length_mm()) << "watching changes nothing";
  // The used length it reports is the parts' right edge.
  double right = 0.0;
  for (const Placement& p : n.placements) right = std::max(right, bounding_box(place(r.parts[p.part].outer, p)).max().x());
  EXPECT_NEAR(n.last_length_mm(), right, 1e-6);
}

TEST(StripSearch, TheSameSeedAndWorkGiveTheSameNestOnTwoWorkers) {
  const NestRequest r = ells_and_discs();
  const NestResult a = searched(r, 0.1, 11), b = searched(r, 0.1, 11);
  ASSERT_EQ(a.placements.size(), b.placements.size());
  EXPECT_EQ(a.last_length_mm(), b.last_length_mm());
  for (std::size_t i = 0; i < a.placements.size(); ++i) {
    EXPECT_EQ(a.placements[i].translate_mm, b.placements[i].translate_mm) << i;
    EXPECT_EQ(a.placements[i].rotation_deg, b.placements[i].rotation_deg) << i;
  }
}

TEST(StripSearch, AStopReturnsTheBestNestSoFar) {
  const NestRequest r = ells_and_discs();
  StopSource stop;
  stop.request_stop();
  Termination t(stop.token());
  t.set_deadline(100, "nominal search time");
  const NestResult n = nest(r, t, 1);
  EXPECT_EQ(t.reason(), Termination::Reason::stop_requested);
  ASSERT_EQ(n.placements.size(), 20u);
  EXPECT_TRUE(certify(r.parts, n.placements, r.sheets, r.spacing_mm).certified);
}

TEST(StripSearch, OnlyTheLastSheetIsShortenedAndTheOthersStayAsFilled) {
  NestRequest r = ells_and_discs();
  r.sheets = {Sheet{300, 130, 5}, Sheet{300, 130, 5}, Sheet{300, 130, 5}};
  const NestResult first = bottom_left_nest(r);
  ASSERT_EQ(first.sheets_used, 2);
  NestResult n = first;
  Termination t;
  t.set_deadline(0.2, "nominal search time");
  shorten_last_sheet(r, shapes_of(r), n, t, 5, 2);
  ASSERT_EQ(n.placements.size(), first.placements.size());
  for (std::size_t i = 0; i < n.placements.size(); ++i)
    if (first.placements[i].sheet == 0) {
      EXPECT_EQ(n.placements[i].translate_mm, first.placements[i].translate_mm);
      EXPECT_EQ(n.placements[i].sheet, 0);
    }
  EXPECT_EQ(n.used_length_mm[0], first.used_length_mm[0]);
  EXPECT_LT(n.used_length_mm[1], first.used_length_mm[1]);
  EXPECT_TRUE(certify(r.parts, n.placements, r.sheets, r.spacing_mm).certified);
}

// A part drawn askew: `p` turned by `deg` about the origin.
NestPart askew(NestPart p, double deg) {
  Placement turn;
  turn.rotation_deg = deg;
  p.outer = place(p.outer, turn);
  return p;
}

NestRequest askew_rectangles() {
  NestRequest r;
  r.parts = {askew(rect(100, 50), 20)};
  r.quantity = {8};
  r.rotations_deg = {0, 45, 90, 135, 180, 225, 270, 315};
  r.sheets = {Sheet{2000, 110, 0}};
  return r;
}

TEST(StripSearch, APartThatTurnsFreelySquaresWithTheStripAndTurnsByAnyAngle) {
  // Eight 100 x 50 rectangles drawn 20 degrees askew in a strip 110 high: squared, two rows of
  // four, 400 mm; every 45 degrees, never squared.
  NestRequest r = askew_rectangles();
  const NestResult steps = searched(r, 0.3, 3);
  r.any_rotation = true;
  const NestResult any = searched(r, 0.3, 3);
  std::printf("every 45 deg %.1f mm, any angle %.1f mm\n", steps.last_length_mm(), any.last_length_mm());
  EXPECT_LT(any.last_length_mm(), 410.0);
  EXPECT_GT(steps.last_length_mm(), 1.25 * any.last_length_mm());
  for (const NestResult* n : {&steps, &any}) {
    const Certificate c = certify(r.parts, n->placements, r.sheets, r.spacing_mm);
    EXPECT_TRUE(c.certified) << (c.violations.empty() ? "" : c.violations[0]);
  }
  // Ells drawn askew beside them, with spacing: the search turns parts to angles the fill never
  // tries (neither a multiple of 45 degrees nor a squaring one), and the nest is still certified
  // on the true lines and the same for the same seed.
  r.parts.push_back(askew(ell(60, 15), 31));
  r.quantity.push_back(6);
  r.spacing_mm = 2;
  const NestResult a = searched(r, 0.3, 5), b = searched(r, 0.3, 5);
  const Certificate c = certify(r.parts, a.placements, r.sheets, r.spacing_mm);
  EXPECT_TRUE(c.certified) << (c.violations.empty() ? "" : c.violations[0]);
  int off_grid = 0;
  for (const Placement& p : a.placements) {
    bool tried = std::abs(std::remainder(p.rotation_deg, 45.0)) < 1e-6;
    for (const double sq : squaring_rotations(r.parts[p.part], r.tolerance_mm)) tried |= std::abs(std::remainder(p.rotation_deg - sq, 360.0)) < 1e-6;
    off_grid += tried ? 0 : 1;
  }
  EXPECT_GT(off_grid, 0);
  ASSERT_EQ(a.placements.size(), b.placements.size());
  for (std::size_t i = 0; i < a.placements.size(); ++i) {
    EXPECT_EQ(a.placements[i].translate_mm, b.placements[i].translate_mm) << i;
    EXPECT_EQ(a.placements[i].rotation_deg, b.placements[i].rotation_deg) << i;
  }
}

}  // namespace
}  // namespace machplan::nesting
