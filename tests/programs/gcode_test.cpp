// Unit tests of the G-code reader: each accepted feature and each error message.
#include "engine/programs/gcode.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "engine/common/error.h"

namespace machplan {
namespace {

Program read(const std::string& text, const GcodeOptions& options = {}) {
  return read_gcode(text, "prog.ngc", options);
}

// Expects read(text) to throw InputError at `line` with a message containing `fragment`.
void expect_error(const std::string& text, int line, const std::string& fragment, const GcodeOptions& options = {}) {
  try {
    read(text, options);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.line(), line) << what;
    EXPECT_EQ(what.rfind("prog.ngc:" + std::to_string(line) + ": ", 0), 0u) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << "message: " << what << "\nexpected to contain: " << fragment;
  }
}

void expect_point(const Eigen::Vector3d& p, double x, double y, double z) {
  EXPECT_NEAR(p.x(), x, 1e-9);
  EXPECT_NEAR(p.y(), y, 1e-9);
  EXPECT_NEAR(p.z(), z, 1e-9);
}

TEST(Gcode, RapidLineAndModalMotion) {
  const Program p = read("G0 X1 Y2 Z3\nG1 X4 F100\nY5\nM2\n");
  ASSERT_EQ(p.moves.size(), 3u);
  EXPECT_EQ(p.moves[0].kind, Move::Kind::rapid);
  expect_point(p.moves[0].end, 1, 2, 3);
  EXPECT_EQ(p.moves[0].line, 1);
  EXPECT_EQ(p.moves[1].kind, Move::Kind::line);
  EXPECT_DOUBLE_EQ(p.moves[1].feed_mm_per_min, 100);
  expect_point(p.moves[2].end, 4, 5, 3);
  EXPECT_EQ(p.moves[2].line, 3);
  EXPECT_TRUE(p.ends_with_program_end);
  EXPECT_EQ(p.source, "prog.ngc");
}

TEST(Gcode, StartsAtOriginInMillimetresAbsolute) {
  const Program p = read("G0\nM2\n");
  ASSERT_EQ(p.moves.size(), 1u);  // G0 without axis words: a move to where the tool is
  expect_point(p.start, 0, 0, 0);
  expect_point(p.moves[0].end, 0, 0, 0);
}

TEST(Gcode, InchesAreConvertedAndFeedTakesUnitsWhenRead) {
  const Program p = read("G20 G0 X1\nG1 X2 F10\nG21 G1 X60\nM2\n");
  ASSERT_EQ(p.moves.size(), 3u);
  expect_point(p.moves[0].end, 25.4, 0, 0);
  EXPECT_DOUBLE_EQ(p.moves[1].feed_mm_per_min, 254.0);
  expect_point(p.moves[2].end, 60, 0, 0);
  EXPECT_DOUBLE_EQ(p.moves[2].feed_mm_per_min, 254.0);
  // F on the G20 line is read before the units change, as LinuxCNC orders a line.
  const Program q = read("G20 G1 X1 F10\nM2\n");
  EXPECT_DOUBLE_EQ(q.moves[0].feed_mm_per_min, 10.0);
}

TEST(Gcode, IncrementalDistances) {
  const Program p = read("G91 G0 X1 Y1\nX1\nG90 X0\nM2\n");
  expect_point(p.moves[1].end, 2, 1, 0);
  expect_point(p.moves[2].end, 0, 1, 0);
}

TEST(Gcode, ArcCentreFormatIncrementalAndAbsolute) {
  const Program p = read("F100\nG0 X10\nG3 X0 Y10 I-10\nG90.1 G3 X-10 Y0 I0 J0\nM2\n");
  ASSERT_EQ(p.moves.size(), 3u);
  const Move& a = p.moves[1];
  EXPECT_EQ(a.kind, Move::Kind::arc);
  EXPECT_FALSE(a.clockwise);
  EXPECT_NEAR(a.center.x(), 0, 1e-12);
  EXPECT_NEAR(a.center.y(), 0, 1e-12);
  EXPECT_EQ(a.turns, 0);
  EXPECT_NEAR(p.moves[2].center.norm(), 0, 1e-12);
}

TEST(Gcode, ArcRadiusFormatPicksShortOrLongArc) {
  const Program p = read("F100\nG2 X2 R1\nG0 X0 Y0\nG2 X2 Y0 R1.5\nG0 X0 Y0\nG2 X2 Y0 R-1.5\nM2\n");
  // Semicircle: centre at the midpoint.
  EXPECT_NEAR(p.moves[0].center.x(), 1, 1e-9);
  EXPECT_NEAR(p.moves[0].center.y(), 0, 1e-9);
  EXPECT_TRUE(p.moves[0].clockwise);
  // Positive R, clockwise from (0,0) to (2,0): the short arc bulges up, centre below.
  const double h = std::sqrt(1.5 * 1.5 - 1.0);
  EXPECT_NEAR(p.moves[2].center.y(), -h, 1e-9);
  EXPECT_NEAR(p.moves[4].center.y(), h, 1e-9);
}

TEST(Gcode, FullCircleHelixAndTurns) {
  const Program p = read("F100\nG0 X5\nG2 X5 Y0 Z-3 I-5 P3\nG3 I-5\nM2\n");
  const Move& a = p.moves[1];
  EXPECT_TRUE(a.clockwise);
  EXPECT_EQ(a.turns, 2);  // P3: three turns, two beyond the first
  expect_point(a.end, 5, 0, -3);
  EXPECT_EQ(p.moves[2].turns, 0);
  // Summary: 3 turns of a radius-5 helix dropping 3 mm, then a full circle.
  const ProgramSummary s = summarize(p, 6000);
  const double helix = std::hypot(3 * 2 * M_PI * 5, 3.0);
  EXPECT_NEAR(s.feed_length_mm, helix + 2 * M_PI * 5, 1e-9);
  EXPECT_EQ(s.arc_count, 2u);
  EXPECT_NEAR(s.min.x(), -5, 1e-9);
  EXPECT_NEAR(s.max.y(), 5, 1e-9);
}

TEST(Gcode, DwellTorchAndSpindleSpeed) {
  const Program p = read("S3000 M3\nG4 P0.5\nM5\nM4\nM2\n");
  ASSERT_EQ(p.moves.size(), 4u);
  EXPECT_EQ(p.moves[0].kind, Move::Kind::torch_on);
  EXPECT_DOUBLE_EQ(p.moves[0].spindle_speed, 3000);
  EXPECT_EQ(p.moves[1].kind, Move::Kind::dwell);
  EXPECT_DOUBLE_EQ(p.moves[1].seconds, 0.5);
  EXPECT_EQ(p.moves[2].kind, Move::Kind::torch_off);
  EXPECT_EQ(p.moves[3].kind, Move::Kind::torch_on);
  EXPECT_STREQ(to_string(p.moves[3].kind), "torch_on");
}

TEST(Gcode, OrderOnOneLineFollowsLinuxCnc) {
  // M3, then G4, then the motion; M2 last.
  const Program p = read("G0 X1 G4 P1 M3 M2\nG0 X5\n");
  ASSERT_EQ(p.moves.size(), 3u);
  EXPECT_EQ(p.moves[0].kind, Move::Kind::torch_on);
  EXPECT_EQ(p.moves[1].kind, Move::Kind::dwell);
  EXPECT_EQ(p.moves[2].kind, Move::Kind::rapid);
}

TEST(Gcode, LexicalForms) {
  const Program p = read("%\nn10 g0x.5y-.5z+1 (c) ; rest\n/G 0 X 1 2 . 5\nG00 X1.\n%\nG0 X99 ignored\n");
  ASSERT_EQ(p.moves.size(), 3u);
  expect_point(p.moves[0].end, 0.5, -0.5, 1);
  expect_point(p.moves[1].end, 12.5, -0.5, 1);
  expect_point(p.moves[2].end, 1, -0.5, 1);
  EXPECT_FALSE(p.ends_with_program_end);
}

TEST(Gcode, NothingAfterProgramEndIsRead) {
  const Program p = read("G0 X1\nM30\n#1=2 ((( G18\n");
  EXPECT_EQ(p.moves.size(), 1u);
}

TEST(Gcode, PreambleCodesAreAccepted) {
  EXPECT_NO_THROW(read("G17 G21 G40 G49 G54 G80 G90 G94 G91.1\nM0\nM1\nM2\n"));
}

TEST(Gcode, Summary) {
  Program p = read("G0 X30 Y40\nG1 X30 Y0 F600\nG4 P2\nM2\n");
  const ProgramSummary s = summarize(p, 3000);
  EXPECT_EQ(s.rapid_count, 1u);
  EXPECT_EQ(s.line_count, 1u);
  EXPECT_EQ(s.dwell_count, 1u);
  EXPECT_NEAR(s.rapid_length_mm, 50, 1e-12);
  EXPECT_NEAR(s.feed_length_mm, 40, 1e-12);
  EXPECT_NEAR(s.estimated_seconds, 50.0 / 3000 * 60 + 40.0 / 600 * 60 + 2, 1e-12);
  expect_point(s.max, 30, 40, 0);
}

// --- Refused features -------------------------------------------------------------------

TEST(GcodeRefused, FeaturesAreNamedWithTheirLine) {
  expect_error("G41 G1 X1 F1\nM2\n", 1, "G41 (cutter radius compensation) is not supported");
  expect_error("G86 X1 Z-1 R1 F1\nM2\n", 1, "G86 (boring cycle with spindle stop) is not supported");
  expect_error("G93\nM2\n", 1, "G93 (inverse time feed) is not supported");
  expect_error("G38.2 Z-1 F1\nM2\n", 1, "G38.2 (probing) is not supported");
  expect_error("G0 A1\nM2\n", 1, "A axis words are not supported");
  expect_error("G81 ^60\nM2\n", 1, "polar coordinates");
  expect_error("G10 L2 P1 R30\nM2\n", 1, "rotation of a coordinate system) is not supported");
  expect_error("G10 L1 P1 Z1\nM2\n", 1, "G10 L1 (setting tool table data) is not supported");
  expect_error("o<other> call\nM2\n", 1, "subroutine o<other> is not defined in this file");
}

// --- Words with no geometry, parameters, O-words, offsets, cycles --------------------------

TEST(GcodeFeatures, WordsWithoutGeometryBecomeEvents) {
  const Program p = read("G21 F100 G64 P0.2\nT2 M6\nG43 H2\nM8\nM52 P1\nM62 P3\nM67 E1 Q40\nM66 P1 L3 Q2\nM190 P2\n"
                         "G1 X1\nG61\nG1 X2\nM9\nM2\n");
  using K = ProgramEvent::Kind;
  ASSERT_EQ(p.events.size(), 10u);
  EXPECT_EQ(p.events[0].kind, K::tool_select);
  EXPECT_EQ(p.events[0].number, 2);
  EXPECT_EQ(p.events[1].kind, K::tool_change);
  EXPECT_EQ(p.events[2].kind, K::tool_length_offset);
  EXPECT_EQ(p.events[3].kind, K::coolant);
  EXPECT_EQ(p.events[4].kind, K::feed_override);
  EXPECT_EQ(p.events[5].kind, K::digital_output);
  EXPECT_TRUE(p.events[5].synchronized);
  EXPECT_EQ(p.events[6].kind, K::analog_output);
  EXPECT_DOUBLE_EQ(p.events[6].value, 40);
  EXPECT_EQ(p.events[7].kind, K::wait_input);
  EXPECT_EQ(p.events[7].mode, 3);
  EXPECT_EQ(p.events[8].kind, K::user_m_code);
  EXPECT_EQ(p.events[8].number, 190);
  EXPECT_EQ(p.events[8].before_move, 1u);  // after the torch_off of M6, before the first line
  EXPECT_EQ(p.events[9].line, 13);
  ASSERT_EQ(p.moves.size(), 3u);  // M6 stops the spindle, as LinuxCNC does
  EXPECT_EQ(p.moves[0].kind, Move::Kind::torch_off);
  EXPECT_EQ(p.moves[1].path_mode, Move::PathMode::blend);
  EXPECT_NEAR(p.moves[1].path_tolerance_mm, 0.2, 1e-12);
  EXPECT_EQ(p.moves[2].path_mode, Move::PathMode::exact_path);
}

TEST(GcodeFeatures, SpindleSelectorG80AndG94) {
  GcodeOptions three;
  three.spindle_count = 3;
  const Program p = read("G21 F100\nM3 $1 S1\nG0 X1 G80\nM5 $-1\nM2\n", three);
  ASSERT_EQ(p.moves.size(), 3u);
  EXPECT_EQ(p.moves[0].spindle, 1);
  EXPECT_EQ(p.moves[1].kind, Move::Kind::rapid);
  EXPECT_EQ(p.moves[2].spindle, -1);
  expect_error("M3 $1 S1\nM2\n", 1, "invalid spindle ($) number $1");
  expect_error("G21 F100\nG94\nG1 X1\nM2\n", 3, "zero feed rate");
}

TEST(GcodeFeatures, ParametersAndExpressions) {
  const Program p = read("#1=2 #<w>=[3*4] #<_g>=-1\nG0 X#1 Y#<w> Z#<_g>\n#1=5 #2=#1\nG0 X#2 Y[2**3 MOD 5] Z[-#1+ABS[-1]]\n"
                         "G0 X[ATAN[1]/[1]] Y[ROUND[-2.5]] Z[1 LT 2 AND 3 GE 3]\nM2\n");
  ASSERT_EQ(p.moves.size(), 3u);
  expect_point(p.moves[0].end, 2, 12, -1);
  expect_point(p.moves[1].end, 2, 3, -4);  // #2 took #1's value before the line set it
  expect_point(p.moves[2].end, 45, -3, 1);
  GcodeOptions given;
  given.params["_hal[plasmac.cut-feed-rate]"] = 2500;
  const Program q = read("F#<_HAL[plasmac.cut-feed-rate]>\nG1 X1\nM2\n", given);
  EXPECT_DOUBLE_EQ(q.moves[0].feed_mm_per_min, 2500);
  expect_error("F#<_hal[plasmac.cut-feed-rate]>\nM2\n", 1, "#<_hal[plasmac.cut-feed-rate]> has no value");
  expect_error("G0 X[1/0]\nM2\n", 1, "divide by zero");
  expect_error("G0 X[SQRT[-1]]\nM2\n", 1, "negative argument to SQRT");
  expect_error("G0 X[ACOS[2]]\nM2\n", 1, "argument to ACOS out of range");
  expect_error("G0 X[1+2\nM2\n", 1, "unclosed expression");
  expect_error("G0 X[FOO[1]]\nM2\n", 1, "unknown function 'foo'");
  expect_error("G0 X#<nope>\nM2\n", 1, "named parameter #<nope> not defined");
  expect_error("G0 X#6000\nM2\n", 1, "out of range");
  GcodeOptions wide;
  wide.max_line_chars = 5000;
  expect_error("G0 X" + std::string(1000, '[') + "1" + std::string(1000, ']') + "\nM2\n", 1, "nested more than 200 deep",
               wide);
  const Program deep = read("G0 X" + std::string(100, '[') + "1" + std::string(100, ']') + "\nM2\n", wide);
  expect_point(deep.moves[0].end, 1, 0, 0);
}

TEST(GcodeFeatures, OWords) {
  const Program p = read("F1\n#1=9\no1 call [2]\nG1 X#1 Y#<_value>\no2 repeat [2]\nG91 G1 X1\nG90\no2 endrepeat\n"
                         "#3=0\no3 while [#3 LT 3]\n#3=[#3+1]\no4 if [#3 EQ 2]\no3 continue\no4 elseif [#3 EQ 3]\nG1 Y30\n"
                         "o4 else\nG1 Y10\no4 endif\no3 endwhile\nM2\no1 sub\nG1 X#1\no1 return [#1*4]\no1 endsub\n");
  ASSERT_EQ(p.moves.size(), 6u);
  expect_point(p.moves[0].end, 2, 0, 0);
  expect_point(p.moves[1].end, 9, 8, 0);  // #1 restored after the call; the return value
  expect_point(p.moves[3].end, 11, 8, 0);
  expect_point(p.moves[4].end, 11, 10, 0);
  expect_point(p.moves[5].end, 11, 30, 0);
  GcodeOptions small;
  small.max_executed_lines = 1000;
  expect_error("o1 while [1]\no1 endwhile\nM2\n", 1, "more than 1000 lines executed", small);
  expect_error("o1 while [0]\nM2\n", 1, "never closed");
  expect_error("o1 endwhile\nM2\n", 1, "with no matching opening line");
  expect_error("o1 sub\no1 call\no1 endsub\no1 call\nM2\n", 2, "nested deeper than 50");
}

TEST(GcodeFeatures, WorkOffsetsInMachineCoordinates) {
  const Program p = read("G10 L2 P2 X100 Y50\nG55 G0 X1 Y1\nG92 X0 Y0\nG0 X2\nG53 G0 X5 Y5\nG92.1\nG10 L20 P0 X0\nG0 X0\n"
                         "G54 G0 X0 Y0\nG20 G10 L2 P3 X1\nG56 G0 X0\nM2\n");
  ASSERT_EQ(p.moves.size(), 6u);
  expect_point(p.moves[0].end, 101, 51, 0);
  expect_point(p.moves[1].end, 103, 51, 0);  // G92 made (101, 51) the zero
  expect_point(p.moves[2].end, 5, 5, 0);     // G53: machine coordinates
  expect_point(p.moves[3].end, 5, 5, 0);     // G10 L20 P0 X0: here is X0
  expect_point(p.moves[4].end, 0, 0, 0);
  expect_point(p.moves[5].end, 25.4, 0, 0);
}

TEST(GcodeFeatures, ArcsInOtherPlanesAndDrillingCycles) {
  const Program p = read("G21 F100\nG18 G2 X10 Z0 I5 K0\nG17 G0 Z5\nG81 X1 Y1 Z-2 R1\nG80\nM2\n");
  ASSERT_EQ(p.moves.size(), 6u);
  EXPECT_EQ(p.moves[0].plane, Move::Plane::xz);
  EXPECT_NEAR(p.moves[0].center.x(), 0, 1e-12);   // (z, x) order, as LinuxCNC's ARC_FEED
  EXPECT_NEAR(p.moves[0].center.y(), 5, 1e-12);
  expect_point(p.moves[2].end, 1, 1, 5);  // rapid over the hole, down to R, feed, back to R
  expect_point(p.moves[3].end, 1, 1, 1);
  EXPECT_EQ(p.moves[4].kind, Move::Kind::line);
  expect_point(p.moves[4].end, 1, 1, -2);
  expect_point(p.moves[5].end, 1, 1, 1);
}

TEST(GcodeFeatures, LenientEndWarns) {
  GcodeOptions lenient;
  lenient.require_program_end = false;
  const Program p = read("G0 X1\n", lenient);
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_NE(p.warnings[0].find("no end"), std::string::npos);
}

// --- LinuxCNC's errors ------------------------------------------------------------------

TEST(GcodeErrors, WordsAndCodes) {
  expect_error("G1 X1 X2 F1\nM2\n", 1, "multiple X words on one line");
  expect_error("G1 X1 F1 F2\nM2\n", 1, "multiple F words on one line");
  expect_error("G0 G1 X1\nM2\n", 1, "two G codes from the same modal group on one line: G0 and G1");
  expect_error("G20 G21\nM2\n", 1, "two G codes from the same modal group on one line: G20 and G21");
  expect_error("M3 M5\nM2\n", 1, "two M codes from the same modal group on one line: M3 and M5");
  expect_error("G1.5\nM2\n", 1, "unknown G code G1.5");
  expect_error("G6\nM2\n", 1, "unknown G code G6");
  expect_error("M47\nM2\n", 1, "unknown M code M47");
  expect_error("M3.5\nM2\n", 1, "M code M3.5 is not an integer");
  expect_error("G0 N10 X1\nM2\n", 1, "N word (line number) is only allowed at the start of a line");
  expect_error("G0 X1 @\nM2\n", 1, "polar coordinates");
  expect_error("G0 X1 $\nM2\n", 1, "a value is missing");
  expect_error("G0 X1%\nM2\n", 1, "'%' is only allowed");
}

TEST(GcodeErrors, Numbers) {
  expect_error("G1 X1e400 F1\nM2\n", 1, "E word with no M66, M67 or M68");
  expect_error("G0 X\nM2\n", 1, "X word without a value");
  expect_error("G0 X-\nM2\n", 1, "a value is missing");
  expect_error("G0 X1.2.3\nM2\n", 1, "more than one decimal point");
  expect_error("G0 X--1\nM2\n", 1, "repeated sign");
  expect_error("G0 X1" + std::string(20, '0') + "\nM2\n", 1, "larger than 1e+09");
}

TEST(GcodeErrors, Comments) {
  expect_error("G0 X1\n(open\nM2\n", 2, "unclosed comment");
  expect_error("(a (b) c)\nM2\n", 1, "nested comment");
}

TEST(GcodeErrors, FeedAndSpeed) {
  expect_error("G0 X1\nG1 X2\nM2\n", 2, "cannot do G1 with zero feed rate");
  expect_error("G1\nM2\n", 1, "cannot do G1 with zero feed rate");
  expect_error("G2 X2 I1\nM2\n", 1, "cannot make an arc (G2) with zero feed rate");
  expect_error("G3 X2 R1 F0\nM2\n", 1, "cannot make an arc (G3) with zero feed rate");
  expect_error("G1 X1 F-1\nM2\n", 1, "negative F word");
  expect_error("M3 S-1\nM2\n", 1, "negative S word");
}

TEST(GcodeErrors, Arcs) {
  expect_error("F1\nG2 X2 R1 I1\nM2\n", 2, "mixed radius (R) and centre (I, J, K) format");
  expect_error("F1\nG2 X1\nM2\n", 2, "R, I, J and K words all missing for an arc");
  expect_error("F1\nG2 X0 I1 K1\nM2\n", 2, "K word given for an arc in the XY plane");
  expect_error("F1\nG2 X3 R1\nM2\n", 2, "too small to reach end point");
  expect_error("F1\nG2 X0 Y0 R1\nM2\n", 2, "current point same as end point of arc");
  expect_error("F1\nG2 X0 Y0 I0.00001\nM2\n", 2, "zero-radius arc");
  expect_error("F1\nG2 X0.001 R0\nM2\n", 2, "zero-radius arc: R0");  // rs274 prints a NaN centre
  expect_error("F1\nG2 X0 I1 P0\nM2\n", 2, "must be 1 or greater");
  expect_error("F1\nG2 X0 I1 P1.5\nM2\n", 2, "P word on G2/G3 is not an integer");
  expect_error("F1\nG2 X0 I1 P20000\nM2\n", 2, "more than 10000 turns");
  expect_error("F1\nG1 X1 I1\nM2\n", 2, "I word with no G2 or G3 to use it");
  expect_error("F1\nG1 X1 R1\nM2\n", 2, "R word with no G2, G3, G10 or canned cycle to use it");
  expect_error("F1\nG1 X1 P1\nM2\n", 2, "P word with no code that uses it");
}

TEST(GcodeErrors, ArcEndRadiusTolerance) {
  // LinuxCNC (mm): refused when |r2 - r1| > 0.02 sqrt(2) mm and > 0.1 % of the larger
  // radius, or when it exceeds 100 times that absolute tolerance.
  const double abs_tol = 0.02 * std::sqrt(2.0);
  EXPECT_NO_THROW(read(fmt::format("F1\nG0 X10\nG3 X{} I-10\nM2\n", -10 - 0.9 * abs_tol)));
  expect_error(fmt::format("F1\nG0 X10\nG3 X{} I-10\nM2\n", -10 - 1.1 * abs_tol), 3,
               "radius to end of arc differs from radius to start");
  // A large arc: 0.1 % of 5000 mm is 5 mm, but 100 x 0.028 = 2.83 mm caps the difference:
  // 2 mm passes, 3 mm fails.
  EXPECT_NO_THROW(read("F1\nG0 X5000\nG3 X-5002 I-5000\nM2\n"));
  expect_error("F1\nG0 X5000\nG3 X-5003 I-5000\nM2\n", 3, "radius to end of arc differs");
  // Inches: the tolerance is 0.002 sqrt(2) inch.
  expect_error("G20 F1\nG0 X1\nG3 X-1.004 I-1\nM2\n", 3, "radius to end of arc differs");
  EXPECT_NO_THROW(read("G20 F1\nG0 X1\nG3 X-1.002 I-1\nM2\n"));
}

TEST(GcodeErrors, DwellAndAxes) {
  expect_error("G4\nM2\n", 1, "dwell time missing with G4");
  expect_error("G4 P-1\nM2\n", 1, "dwell time missing with G4");
  expect_error("G80 X1\nM2\n", 1, "axis words (X, Y, Z) with G80");
  expect_error("G80\nX1\nM2\n", 2, "without a motion code");
}

TEST(GcodeErrors, ProgramEndIsRequiredUnlessDisabled) {
  expect_error("G0 X1\nG0 X2\n", 2, "file ended with no percent sign or program end");
  GcodeOptions options;
  options.require_program_end = false;
  const Program p = read("G0 X1\n", options);
  EXPECT_FALSE(p.ends_with_program_end);
  EXPECT_EQ(p.moves.size(), 1u);
}

TEST(GcodeLimits, LinesMovesAndOptions) {
  expect_error("G0 X1 (" + std::string(250, 'a') + ")\nM2\n", 1, "line is longer than 252 characters");
  EXPECT_NO_THROW(read("G0 X1 (" + std::string(244, 'a') + ")\nM2\n"));
  GcodeOptions options;
  options.max_moves = 3;
  expect_error("G0 X1\nG0 X2\nG0 X3\nG0 X4\nM2\n", 4, "more than 3 moves", options);
  options = {};
  options.max_moves = 0;
  EXPECT_THROW(read("M2\n", options), InputError);
  // Binary junk is refused, not crashed on.
  expect_error(std::string("G0 X1\n\x01\x02\n", 9) + "M2\n", 2, "bad character");
}

TEST(GcodeLimits, BinaryFileIsNotAText) {
  // A binary file (here the start of a PNG image, then a long run of bytes with no newline)
  // is named for what it is, at the line of its first NUL byte, before its bytes are read as
  // words or its long "lines" meet the length limit.
  std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
  png += std::string(600, '\x7f');
  expect_error(png, 3, "not a text file (a NUL byte on this line)");
  // Anywhere in the file, even after lines that read well, and in the GRBL dialect too.
  GcodeOptions grbl;
  grbl.dialect = GcodeDialect::grbl;
  expect_error(std::string("G0 X1\nG1 X2 F100\n") + std::string(300, 'a') + std::string(1, '\0') + "\n", 3,
               "not a text file", grbl);
}

TEST(GcodeFile, MissingFileAndDemo) {
  EXPECT_THROW(read_gcode_file("/nonexistent/prog.ngc"), InputError);
  const Program p = read_gcode_file(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/programs/demo_plate.ngc");
  const ProgramSummary s = summarize(p);
  EXPECT_EQ(s.torch_on_count, 3u);
  EXPECT_EQ(s.dwell_count, 3u);
  EXPECT_GE(s.arc_count, 3u);
  EXPECT_TRUE(p.ends_with_program_end);
  // The plate is 200 x 100 mm; the kerf-offset path lies 0.75 mm outside it.
  EXPECT_NEAR(s.max.x(), 200.75, 1e-9);
  EXPECT_NEAR(s.max.y(), 100.75, 1e-9);
}

}  // namespace
}  // namespace machplan
