// solvers/motion/cut_order.h on programs written here: the order, the precedences, the pierce
// points and their lead-ins, what is kept, and the written program read back.
#include "solvers/motion/cut_order.h"

#include <cmath>
#include <map>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "engine/programs/gcode_writer.h"
#include "solvers/motion/rapids.h"

namespace machplan::motion {
namespace {

using ::testing::HasSubstr;
using Eigen::Vector2d;

// A plate 200 x 100 at (100, 100) cut first, pierced 6 mm left of its left edge; then two
// 20 mm holes and a 60 x 12 slot inside it, each pierced at its centre with a lead-in. A
// separate small disc (30 mm) far to the right, with no lead-in, cut last.
const char* const kOutlineFirst =
    "G21 G90 G17 G94\n"
    "G0 X94 Y150\n"                            // 2
    "M3 S1\nG4 P0.5\n"                         // 3, 4
    "G1 X100 Y150 F3000\n"                     // 5 lead-in
    "G1 X100 Y200\nG1 X300 Y200\nG1 X300 Y100\nG1 X100 Y100\nG1 X100 Y150\n"  // 6-10
    "M5\n"                                     // 11
    "G0 X140 Y170\nM3 S1\nG4 P0.5\n"           // 12-14
    "G1 X150 Y170 F1500\nG3 X150 Y170 I-10 J0\nM5\n"  // 15-17
    "M8\n"                                     // 18: coolant before the next cut
    "G0 X260 Y170\nM3 S1\nG4 P0.5\n"           // 19-21
    "G1 X270 Y170 F1500\nG3 X270 Y170 I-10 J0\nM5\n"  // 22-24
    "G0 X200 Y125\nM3 S1\nG4 P0.5\n"           // 25-27
    "G1 X200 Y119 F1500\nG1 X230 Y119\nG3 X230 Y131 I0 J6\nG1 X170 Y131\nG3 X170 Y119 I0 J-6\nG1 X200 Y119\nM5\n"
    "G0 X415 Y150\nM3 S1\n"                    // 35, 36
    "G2 X415 Y150 I15 J0 F3000\nM5\n"          // 37, 38: the disc, pierced on its edge
    "G0 X0 Y0\nM2\n";

Program read(const std::string& text) { return read_gcode(text, "p.ngc"); }

// The closed loops of a program's cuts, by the make_job geometry.
std::vector<Contour> loops_of(const Program& p) {
  std::vector<Contour> out;
  const Job job = make_job(p, {});
  for (const Stretch& s : job.stretches)
    if (s.cutting)
      if (auto c = closed_loop(s)) out.push_back(std::move(*c));
  return out;
}

// Two sets of loops hold the same contours (any order, any start): same areas, perimeters and
// boxes, each vertex of one on the other.
void expect_same_loops(const std::vector<Contour>& a, const std::vector<Contour>& b) {
  ASSERT_EQ(a.size(), b.size());
  std::vector<bool> used(b.size(), false);
  for (const Contour& c : a) {
    bool found = false;
    for (std::size_t k = 0; k < b.size() && !found; ++k) {
      if (used[k] || std::abs(signed_area(c) - signed_area(b[k])) > 1e-6 ||
          std::abs(perimeter(c) - perimeter(b[k])) > 1e-6 || !bounding_box(c).isApprox(bounding_box(b[k]), 1e-9))
        continue;
      bool on = true;
      for (const Vector2d& v : b[k].vertices()) on = on && distance(c, v) < 1e-6;
      if (on) used[k] = found = true;
    }
    EXPECT_TRUE(found) << "a loop of area " << signed_area(c) << " is missing";
  }
}

TEST(CutOrder, ProgramOrderIsKeptAndAnOuterContourCutFirstIsWarnedOnce) {
  CutOrderOptions o;
  o.order = CutOrder::program;
  const Program p = read(kOutlineFirst);
  const OrderedProgram r = order_cuts(p, o);
  EXPECT_FALSE(r.report.reordered);
  EXPECT_EQ(r.program.moves.size(), p.moves.size());
  ASSERT_TRUE(r.report.outer_first.has_value());
  EXPECT_EQ(*r.report.outer_first, std::make_pair(5, 15));
  ASSERT_EQ(r.report.warnings.size(), 1u);
  EXPECT_THAT(r.report.warnings[0], HasSubstr("p.ngc:5: the contour cut at line 5 encloses the cut at line 15"));
  // Below the command line no flag is named: the order is, as every caller sets it.
  EXPECT_THAT(r.report.warnings[0], HasSubstr("(the cut order 'optimise' cuts inner contours first)"));
  EXPECT_THAT(r.report.warnings[0], ::testing::Not(HasSubstr("--")));
  EXPECT_EQ(r.report.summary.status, Status::done);
}

TEST(CutOrder, OptimiseCutsInnerContoursFirstAndKeepsEveryCut) {
  const Program p = read(kOutlineFirst);
  const OrderedProgram r = order_cuts(p, {});
  ASSERT_TRUE(r.report.reordered) << r.report.summary.full_report();
  EXPECT_TRUE(r.report.warnings.empty());
  EXPECT_EQ(r.report.cuts, 5u);
  EXPECT_EQ(r.report.closed_cuts, 5u);
  EXPECT_EQ(r.report.with_lead_in, 4u);  // the disc has none
  // The plate (line 5) after its holes and slot (lines 15, 22, 28).
  std::map<int, std::size_t> at;
  for (std::size_t k = 0; k < r.report.sequence.size(); ++k) at[r.report.cut_lines[static_cast<std::size_t>(r.report.sequence[k])]] = k;
  for (int inner : {15, 22, 28}) EXPECT_LT(at[inner], at[5]) << inner;
  // The same cuts: every loop as before, the same number of torch words and dwells.
  expect_same_loops(loops_of(p), loops_of(r.program));
  std::map<Move::Kind, int> before, after;
  for (const Move& m : p.moves) ++before[m.kind];
  for (const Move& m : r.program.moves) ++after[m.kind];
  for (Move::Kind k : {Move::Kind::torch_on, Move::Kind::torch_off, Move::Kind::dwell}) EXPECT_EQ(before[k], after[k]);
  // The travel: no longer than as programmed or by nearest neighbour, and not below the bound.
  EXPECT_LE(r.report.travel_mm, r.report.programmed_travel_mm + 1e-9);
  EXPECT_LE(r.report.travel_mm, r.report.nearest_travel_mm + 1e-9);
  EXPECT_GE(r.report.travel_mm, r.report.lower_bound_mm - 1e-9);
  // The coolant word stays with the cut it came before (the hole at line 22).
  ASSERT_EQ(r.program.events.size(), 1u);
  const Move& next = r.program.moves[r.program.events[0].before_move];
  EXPECT_EQ(next.kind, Move::Kind::rapid);
  EXPECT_LT((next.end.head<2>() - Vector2d(260, 170)).norm(), 1e-9);  // a hole pierced at its centre stays there
  // The disc, pierced on its own edge, keeps its pierce point.
  bool disc = false;
  for (std::size_t i = 0; i + 1 < r.program.moves.size(); ++i)
    if (r.program.moves[i + 1].kind == Move::Kind::torch_on && (r.program.moves[i].end.head<2>() - Vector2d(415, 150)).norm() < 1e-12)
      disc = true;
  EXPECT_TRUE(disc);
}

TEST(CutOrder, AMovedLeadInIsTheSamePieceOffTheEdge) {
  // The plate alone, with its lead-in, after a start far to its right: the pierce moves to
  // the right side, the lead-in 6 mm long and square to the edge as programmed.
  const Program p = read("G21 G90\nG0 X94 Y150\nM3 S1\nG1 X100 Y150 F3000\nG1 X100 Y200\nG1 X300 Y200\n"
                         "G1 X300 Y100\nG1 X100 Y100\nG1 X100 Y150\nM5\nG0 X600 Y150\nM2\n");
  const OrderedProgram r = order_cuts(p, {});
  ASSERT_TRUE(r.report.reordered);
  EXPECT_EQ(r.report.moved_pierces, 1u);
  EXPECT_LT(r.report.travel_mm, r.report.programmed_travel_mm - 1.0);
  const Program& q = r.program;
  std::size_t on = 0;
  while (q.moves[on].kind != Move::Kind::torch_on) ++on;
  const Vector2d pierce = q.moves[on - 1].end.head<2>();
  const Vector2d entry = q.moves[on + 1].end.head<2>();
  EXPECT_NEAR((entry - pierce).norm(), 6.0, 1e-9);
  const std::vector<Contour> loops = loops_of(q);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_NEAR(distance(loops[0], entry), 0.0, 1e-9);
  EXPECT_NEAR(distance(loops[0], pierce), 6.0, 1e-9);  // square to the edge, off it
  EXPECT_FALSE(contains(loops[0], pierce));            // on the waste side, as programmed
  expect_same_loops(loops_of(p), loops);
}

TEST(CutOrder, NearestKeepsPiercePointsAndPrecedences) {
  CutOrderOptions o;
  o.order = CutOrder::nearest;
  const OrderedProgram r = order_cuts(read(kOutlineFirst), o);
  ASSERT_TRUE(r.report.reordered);
  EXPECT_EQ(r.report.moved_pierces, 0u);
  EXPECT_NEAR(r.report.travel_mm, r.report.nearest_travel_mm, 1e-9);
  std::map<int, std::size_t> at;
  for (std::size_t k = 0; k < r.report.sequence.size(); ++k) at[r.report.cut_lines[static_cast<std::size_t>(r.report.sequence[k])]] = k;
  for (int inner : {15, 22, 28}) EXPECT_LT(at[inner], at[5]) << inner;  // the plate after its three
}

TEST(CutOrder, APauseAfterTheTorchOffGoesWithItsCut) {
  // A post that pauses after each M5 (to let the arc die): the pause stays right after its cut.
  const Program p = read("G0 X200 Y0\nM3 S1\nG1 X210 F600\nG1 X210 Y10\nM5\nG4 P0.6\n"
                         "G0 X10 Y0\nM3 S1\nG1 X20 F600\nG1 X20 Y10\nM5\nG4 P0.7\nM2\n");
  const OrderedProgram r = order_cuts(p, {});
  ASSERT_TRUE(r.report.reordered) << r.report.summary.full_report();
  EXPECT_EQ(r.report.cut_lines[static_cast<std::size_t>(r.report.sequence[0])], 9);  // the nearer cut first
  const auto& m = r.program.moves;
  for (std::size_t i = 0; i + 1 < m.size(); ++i)
    if (m[i].kind == Move::Kind::torch_off) EXPECT_EQ(m[i + 1].kind, Move::Kind::dwell) << i;
  EXPECT_NEAR(m[5].seconds, 0.7, 1e-12);  // the second cut's pause, now after the first cut made
}

TEST(CutOrder, WhatCannotBeReorderedIsLeftAsWritten) {
  const Program z = read("G0 X1 Y1\nM3 S1\nG1 X5 F100\nM5\nG0 Z5\nG0 X10\nM3 S1\nG1 X20 F100\nM5\nM2\n");
  const OrderedProgram r = order_cuts(z, {});
  EXPECT_FALSE(r.report.reordered);
  EXPECT_EQ(r.program.moves.size(), z.moves.size());
  ASSERT_EQ(r.report.warnings.size(), 1u);
  EXPECT_THAT(r.report.warnings[0], HasSubstr("p.ngc:5: Z moves"));
  EXPECT_EQ(r.report.summary.status, Status::infeasible);
  const OrderedProgram g = order_cuts(read("G0 X1\nM3 S1\nG1 X5 F100\nG0 X9\nG1 X12\nM5\nM2\n"), {});
  EXPECT_FALSE(g.report.reordered);
  EXPECT_THAT(g.report.warnings.at(0), HasSubstr("p.ngc:4: a rapid with the torch on"));
  CutOrderOptions bad;
  bad.entry_candidates = 65;
  EXPECT_THROW(order_cuts(z, bad), InputError);
}

TEST(CutOrder, TheWrittenProgramReadsBackToTheSameMoves) {
  const OrderedProgram r = order_cuts(read(kOutlineFirst), {});
  const Program back = read_gcode(write_gcode(r.program, "a header (with brackets)\nsecond line"), "back.ngc");
  ASSERT_EQ(back.moves.size(), r.program.moves.size());
  for (std::size_t i = 0; i < back.moves.size(); ++i) {
    const Move &a = r.program.moves[i], &b = back.moves[i];
    EXPECT_EQ(a.kind, b.kind) << i;
    EXPECT_LT((a.end - b.end).norm(), 1e-5) << i;
    if (a.kind == Move::Kind::arc) {
      EXPECT_LT((a.center - b.center).norm(), 1e-5) << i;
      EXPECT_EQ(a.clockwise, b.clockwise) << i;
    }
    if (a.kind == Move::Kind::line || a.kind == Move::Kind::arc) EXPECT_DOUBLE_EQ(a.feed_mm_per_min, b.feed_mm_per_min);
    if (a.kind == Move::Kind::dwell) EXPECT_DOUBLE_EQ(a.seconds, b.seconds);
  }
  ASSERT_EQ(back.events.size(), 1u);
  EXPECT_EQ(back.events[0].kind, ProgramEvent::Kind::coolant);
  EXPECT_EQ(back.events[0].before_move, r.program.events[0].before_move);
}

}  // namespace
}  // namespace machplan::motion
