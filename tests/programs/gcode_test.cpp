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
  expect_error("G21\nG18\nM2\n", 2, "G18 (XZ plane) is not supported");
  expect_error("G19\nM2\n", 1, "G19 (YZ plane) is not supported");
  expect_error("G0 X1\nG0 X2\nG0 X3\nG0 X4\nG0 X5\nG0 X6\nG0 X7\nG0 X8\nG0 X9\nG0 X10\nG0 X11\no100 sub\n", 12,
               "O-word subroutines are not supported");
  expect_error("#1=2\nM2\n", 1, "parameters (#) are not supported");
  expect_error("G0 X#1\nM2\n", 1, "parameters (#) are not supported");
  expect_error("G0 X[1+2]\nM2\n", 1, "expressions ([...]) are not supported");
  expect_error("G0 Xsin[1]\nM2\n", 1, "functions and expressions are not supported");
  expect_error("G41 G1 X1 F1\nM2\n", 1, "G41 (cutter radius compensation) is not supported");
  expect_error("G81 X1 Z-1 R1\nM2\n", 1, "G81 (canned cycle) is not supported");
  expect_error("G93\nM2\n", 1, "G93 (inverse time feed) is not supported");
  expect_error("G38.2 Z-1 F1\nM2\n", 1, "G38.2 (probing) is not supported");
  expect_error("M8\nM2\n", 1, "M8 (coolant) is not supported");
  expect_error("T1 M6\nM2\n", 1, "T words (tool selection) are not supported");
  expect_error("G0 A1\nM2\n", 1, "A axis words are not supported");
  expect_error("G81 ^60\nM2\n", 1, "polar coordinates");
  expect_error("M100\nM2\n", 1, "M100 (user-defined M code) is not supported");
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
  expect_error("G0 X1 $\nM2\n", 1, "bad character '$'");
  expect_error("G0 X1%\nM2\n", 1, "'%' is only allowed");
}

TEST(GcodeErrors, Numbers) {
  expect_error("G1 X1e400 F1\nM2\n", 1, "E words are not supported");
  expect_error("G0 X\nM2\n", 1, "X word without a value");
  expect_error("G0 X-\nM2\n", 1, "X word without a number");
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
  expect_error("F1\nG2 X2 R1 I1\nM2\n", 2, "mixed radius (R) and centre (I, J) format");
  expect_error("F1\nG2 X1\nM2\n", 2, "R, I and J words all missing for an arc");
  expect_error("F1\nG2 X0 I1 K1\nM2\n", 2, "K word given for an arc in the XY plane");
  expect_error("F1\nG2 X3 R1\nM2\n", 2, "too small to reach end point");
  expect_error("F1\nG2 X0 Y0 R1\nM2\n", 2, "current point same as end point of arc");
  expect_error("F1\nG2 X0 Y0 I0.00001\nM2\n", 2, "zero-radius arc");
  expect_error("F1\nG2 X0.001 R0\nM2\n", 2, "zero-radius arc: R0");  // rs274 prints a NaN centre
  expect_error("F1\nG2 X0 I1 P0\nM2\n", 2, "must be 1 or greater");
  expect_error("F1\nG2 X0 I1 P1.5\nM2\n", 2, "P word on G2/G3 is not an integer");
  expect_error("F1\nG2 X0 I1 P20000\nM2\n", 2, "more than 10000 turns");
  expect_error("F1\nG1 X1 I1\nM2\n", 2, "I word with no G2 or G3 to use it");
  expect_error("F1\nG1 X1 R1\nM2\n", 2, "R word with no G2 or G3 to use it");
  expect_error("F1\nG1 X1 P1\nM2\n", 2, "P word with no G2, G3 or G4 to use it");
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
