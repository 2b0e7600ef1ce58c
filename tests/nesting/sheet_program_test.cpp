// The cut program of a nested sheet (solvers/nesting/sheet_program.h): direction, leads on the
// waste side with room from the neighbours, overcut, kerf, round holes from their centre, and
// QtPlasmaC's words.
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "solvers/nesting/sheet_program.h"
#include "tests/nesting/shapes.h"

// A named namespace: the unity build puts the other nesting tests' helpers beside these.
namespace machplan::nesting::sheet_program_test {

using Eigen::Vector2d;

// One cut of a program: where it pierced, its path, its length.
struct Cut {
  Vector2d pierce = Vector2d::Zero();
  std::vector<Segment> path;
  double length = 0.0;
};

std::vector<Cut> cuts_of(const Program& p) {
  std::vector<Cut> out;
  Vector2d at = p.start.head<2>();
  bool on = false;
  for (const Move& m : p.moves) {
    if (m.kind == Move::Kind::torch_on) {
      out.push_back({at, {}, 0.0});
      on = true;
    } else if (m.kind == Move::Kind::torch_off) {
      on = false;
    } else if (m.kind == Move::Kind::line || m.kind == Move::Kind::arc || m.kind == Move::Kind::rapid) {
      if (on)
        for (const Segment& s : motion::move_segments(m, at)) {
          out.back().path.push_back(s);
          out.back().length += length(s);
        }
      at = m.end.head<2>();
    }
  }
  return out;
}

// Signed area swept by a cut's path (its loop dominates): > 0 counter-clockwise.
double swept_area(const Cut& c) {
  double a = 0.0;
  for (const Segment& s : c.path)
    for (int k = 0; k < 16; ++k) {
      const Vector2d p = point_at(s, k / 16.0), q = point_at(s, (k + 1) / 16.0);
      a += 0.5 * cross(p, q);
    }
  return a;
}

// A 100 x 60 plate with a round hole of radius 15 at (30, 30) and a 20 x 20 square hole at
// (70, 30).
NestPart plate() {
  NestPart p = test::rect(100, 60, "plate");
  p.holes.push_back(Contour::circle({30, 30}, 15).reversed());
  p.holes.push_back(Contour({{60, 20}, {60, 40}, {80, 40}, {80, 20}}, {0, 0, 0, 0}));
  p.area_mm2 = 6000 - std::numbers::pi * 225 - 400;
  return p;
}

Placement at(std::size_t part, double x, double y) {
  Placement p;
  p.part = part;
  p.translate_mm = {x, y};
  return p;
}

const Sheet kSheet{1000, 500, 10};

TEST(SheetProgram, HolesComeFirstOutlinesRunClockwiseHolesCounterClockwiseAndEveryPierceIsInTheWaste) {
  const std::vector<NestPart> parts{plate()};
  const SheetProgram sp = sheet_program(parts, {at(0, 100, 100)}, 0, kSheet);
  const std::vector<Cut> cuts = cuts_of(sp.program);
  ASSERT_EQ(cuts.size(), 3u);
  EXPECT_EQ(sp.cuts, 3);
  EXPECT_EQ(sp.cramped, 0);
  const Contour outer = place(parts[0].outer, at(0, 100, 100));
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_GT(swept_area(cuts[i]), 0.0) << "hole " << i << " counter-clockwise";
    EXPECT_TRUE(contains(outer, cuts[i].pierce));
  }
  EXPECT_LT(swept_area(cuts[2]), 0.0) << "the outline clockwise: the part on the right";
  EXPECT_FALSE(contains(outer, cuts[2].pierce)) << "the outline pierced outside the part";
  EXPECT_NEAR(distance(outer, cuts[2].pierce), 5.0, 1e-6) << "the arc lead-in's radius";
  // Part on the left: both turn round.
  SheetProgramOptions left;
  left.part_on_right = false;
  const std::vector<Cut> l = cuts_of(sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, left).program);
  EXPECT_LT(swept_area(l[0]), 0.0);
  EXPECT_GT(swept_area(l[2]), 0.0);
}

TEST(SheetProgram, ACutIsItsLeadInTheLoopTheOvercutAndTheLeadOut) {
  const std::vector<NestPart> parts{test::rect(200, 100, "plate")};
  SheetProgramOptions o;
  o.lead_in = {LeadShape::line, 6.0};
  o.lead_out = {LeadShape::arc, 3.0};
  o.overcut_mm = 4.0;
  const std::vector<Cut> cuts = cuts_of(sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, o).program);
  ASSERT_EQ(cuts.size(), 1u);
  EXPECT_NEAR(cuts[0].length, 6.0 + 600.0 + 4.0 + 3.0 * std::numbers::pi / 2, 1e-6);
  // Entered at the middle of a long side, square to it.
  const Vector2d entry = cuts[0].path[0].end;
  EXPECT_NEAR(entry.x(), 200.0, 1e-6);
  EXPECT_TRUE(std::abs(entry.y() - 100.0) < 1e-6 || std::abs(entry.y() - 200.0) < 1e-6);
  EXPECT_NEAR((cuts[0].pierce - entry).norm(), 6.0, 1e-9);
}

TEST(SheetProgram, KerfCompensationGrowsOutlinesAndShrinksHolesByHalfTheKerf) {
  const std::vector<NestPart> parts{plate()};
  SheetProgramOptions o;
  o.kerf_mm = 2.0;
  o.lead_in.length_mm = 0.0;  // the cuts are their loops alone
  const std::vector<Cut> cuts = cuts_of(sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, o).program);
  ASSERT_EQ(cuts.size(), 3u);
  const Contour outer = place(parts[0].outer, at(0, 100, 100));
  const Contour round = place(parts[0].holes[0], at(0, 100, 100));
  const Contour square = place(parts[0].holes[1], at(0, 100, 100));
  for (const Cut& c : cuts)
    for (const Segment& s : c.path)
      for (double t : {0.0, 0.3, 0.7}) {
        const Vector2d q = point_at(s, t);
        const double d = std::min({distance(outer, q), distance(round, q), distance(square, q)});
        EXPECT_NEAR(d, 1.0, 1e-6) << "the centre line half the kerf off the drawing";
        EXPECT_EQ(contains(outer, q) && !contains(round, q) && !contains(square, q), false) << "in the waste";
      }
  // Uncompensated: on the drawing.
  o.compensate_kerf = false;
  for (const Cut& c : cuts_of(sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, o).program))
    EXPECT_LT(std::min({distance(outer, c.pierce), distance(round, c.pierce), distance(square, c.pierce)}), 1e-6);
}

TEST(SheetProgram, LeadsKeepClearOfTheNeighboursAndAreShortenedWhereThereIsNoRoom) {
  // A small square 4 mm from every side of a square hole: no 5 mm lead fits between them.
  NestPart frame = test::rect(100, 100, "frame");
  frame.holes.push_back(Contour({{20, 20}, {20, 80}, {80, 80}, {80, 20}}, {0, 0, 0, 0}));
  const std::vector<NestPart> parts{frame, test::rect(52, 52, "inner")};
  SheetProgramOptions o;
  o.clearance_mm = 1.5;
  const SheetProgram sp = sheet_program(parts, {at(0, 100, 100), at(1, 124, 124)}, 0, kSheet, o);
  const std::vector<Cut> cuts = cuts_of(sp.program);
  ASSERT_EQ(cuts.size(), 3u);
  EXPECT_EQ(sp.cramped, 0);
  EXPECT_GE(sp.shortened, 2) << "the inner square's and the hole's lead-ins";
  const Contour hole = place(frame.holes[0], at(0, 100, 100));
  const Contour inner = place(parts[1].outer, at(1, 124, 124));
  for (const Cut& c : cuts) {
    const double to_hole = distance(hole, c.pierce), to_inner = distance(inner, c.pierce);
    EXPECT_GE(std::max(to_hole, to_inner), 0.5 * 0.3 * 5.0 - 1e-9);
    if (to_hole < 4 && to_inner < 4) EXPECT_GE(std::min(to_hole, to_inner), 1.5 - 1e-9) << "clearance from the other cut";
  }
  // With room to spare (the square alone), the full lead.
  EXPECT_EQ(sheet_program(parts, {at(1, 124, 124)}, 0, kSheet, o).shortened, 0);
}

TEST(SheetProgram, ASmallRoundHoleIsPiercedAtItsCentreAndCutAsOneFullCircle) {
  NestPart p = test::rect(60, 60, "plate");
  p.holes.push_back(Contour::circle({30, 30}, 4).reversed());
  const std::vector<NestPart> parts{p};
  const Program prog = sheet_program(parts, {at(0, 100, 100)}, 0, kSheet).program;
  const std::vector<Cut> cuts = cuts_of(prog);
  ASSERT_EQ(cuts.size(), 2u);
  EXPECT_NEAR((cuts[0].pierce - Vector2d(130, 130)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(cuts[0].length, std::numbers::pi * 2 + 2 * std::numbers::pi * 4, 1e-6) << "a half circle of radius 2, then the hole";
  int full_circles = 0;
  Vector2d from = prog.start.head<2>();
  for (const Move& m : prog.moves) {
    if (m.kind == Move::Kind::arc && (m.end.head<2>() - from).norm() < 1e-9) ++full_circles;
    if (m.kind != Move::Kind::torch_on && m.kind != Move::Kind::torch_off) from = m.end.head<2>();
  }
  EXPECT_EQ(full_circles, 1) << "QtPlasmaC sees a hole only in one full-circle arc";
}

TEST(SheetProgram, ASlotTooNarrowForTheLeadIsPiercedInItsMiddle) {
  NestPart p = test::rect(60, 60, "plate");
  p.holes.push_back(Contour({{24, 29}, {24, 31}, {36, 31}, {36, 29}}, {0, 0, 0, 0}));  // 12 x 2
  const std::vector<NestPart> parts{p};
  const SheetProgram sp = sheet_program(parts, {at(0, 100, 100)}, 0, kSheet);
  EXPECT_EQ(sp.cramped, 0);
  const std::vector<Cut> cuts = cuts_of(sp.program);
  ASSERT_EQ(cuts.size(), 2u);
  // On the slot's middle line, 1 mm from both long sides (the cut order may move it along).
  EXPECT_NEAR(cuts[0].pierce.y(), 130.0, 1e-6);
  EXPECT_GT(cuts[0].pierce.x(), 124.0 + 1.0);
  EXPECT_LT(cuts[0].pierce.x(), 136.0 - 1.0);
  EXPECT_NEAR(cuts[0].length, 1.0 + 28.0, 1e-6) << "a line to a long side, then the slot";
}

TEST(SheetProgram, QtPlasmaCWordsComeFirstAndBadOptionsNameTheirField) {
  const std::vector<NestPart> parts{plate()};
  SheetProgramOptions o;
  o.material = 7;
  o.hole_mode = 2;
  o.feed_mm_per_min = kMaterialCutFeed;
  const Program p = sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, o).program;
  ASSERT_GE(p.events.size(), 6u);
  EXPECT_EQ(p.events[0].kind, ProgramEvent::Kind::user_m_code);
  EXPECT_EQ(p.events[0].number, 190);
  EXPECT_EQ(p.events[0].value, 7.0);
  EXPECT_EQ(p.events[1].kind, ProgramEvent::Kind::wait_input);
  EXPECT_EQ(p.events[2].text, "holes");
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(p.events[i].before_move, 0u) << i;
  // THC held off for the round hole of 30 mm (at most h_diameter), not for the square one.
  ASSERT_EQ(p.events.size(), 8u);
  EXPECT_EQ(p.events[6].kind, ProgramEvent::Kind::digital_output);
  EXPECT_EQ(p.events[6].number, 2);
  EXPECT_EQ(p.events[6].value, 1.0);
  EXPECT_EQ(p.moves[p.events[6].before_move].kind, Move::Kind::torch_on);
  EXPECT_EQ(p.events[7].value, 0.0);
  EXPECT_EQ(p.moves[p.events[7].before_move - 1].kind, Move::Kind::torch_off);
  for (const Move& m : p.moves)
    if (m.kind == Move::Kind::line || m.kind == Move::Kind::arc) EXPECT_EQ(m.feed_mm_per_min, kMaterialCutFeed);
  o.hole_mode = 5;
  try {
    (void)sheet_program(parts, {at(0, 100, 100)}, 0, kSheet, o);
    FAIL() << "hole mode 5 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("hole_mode"), std::string::npos) << e.what();
  }
}

}  // namespace machplan::nesting::sheet_program_test
