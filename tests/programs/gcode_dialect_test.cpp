// The G-code reader's dialects (engine/programs/gcode.h, "Dialects"): GRBL programs as GRBL
// runs them, and the automatic choice between GRBL and LinuxCNC. The programs are our own,
// written the way GRBL senders and laser plug-ins write theirs.
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

GcodeOptions dialect(GcodeDialect d) {
  GcodeOptions o;
  o.dialect = d;
  return o;
}

std::string error_of(const std::string& text, const GcodeOptions& o) {
  try {
    (void)read_gcode(text, "p.nc", o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A laser job as a GRBL plug-in writes it: homing and unlock first, a '%' line in the middle,
// a jog at the end, and no program end.
const char* const kLaserJob =
    "$H\n"                      // 1
    "$X\n"                      // 2
    "G21 G90\n"                 // 3
    "M4 S0\n"                   // 4
    "G0 X10 Y10\n"              // 5
    "G1 X40 Y10 S800 F1500\n"   // 6
    "%\n"                       // 7
    "G2 X40 Y30 I0 J10\n"       // 8
    "M5\n"                      // 9
    "$J=G91 X5 F500\n";         // 10

TEST(GcodeDialect, GrblReadsSystemCommandsAsEventsAndNeedsNoEnd) {
  const Program p = read_gcode(kLaserJob, "laser.nc", dialect(GcodeDialect::grbl));
  EXPECT_EQ(p.dialect, GcodeDialect::grbl);
  EXPECT_FALSE(p.ends_with_program_end);
  // The moves are those the G-code lines make; the '$' and '%' lines make none.
  ASSERT_EQ(p.moves.size(), 5u);
  EXPECT_EQ(p.moves[0].kind, Move::Kind::torch_on);
  EXPECT_EQ(p.moves[1].kind, Move::Kind::rapid);
  EXPECT_EQ(p.moves[2].kind, Move::Kind::line);
  EXPECT_EQ(p.moves[3].kind, Move::Kind::arc);
  EXPECT_EQ(p.moves[3].line, 8);
  EXPECT_EQ(p.moves[4].kind, Move::Kind::torch_off);
  // Three controller commands, kept with their text and place.
  std::vector<std::string> texts;
  for (const ProgramEvent& e : p.events)
    if (e.kind == ProgramEvent::Kind::controller_command) texts.push_back(e.text);
  EXPECT_EQ(texts, (std::vector<std::string>{"$H", "$X", "$J=G91 X5 F500"}));
  EXPECT_EQ(p.events.front().line, 1);
  EXPECT_EQ(p.events.front().before_move, 0u);
  EXPECT_EQ(p.events.back().before_move, 5u);
  // One warning for all of them; none for the missing end.
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_THAT(p.warnings[0], HasSubstr("laser.nc:1: 3 GRBL system command lines"));
  // GRBL's one path mode.
  EXPECT_EQ(p.moves[2].path_mode, Move::PathMode::exact_path);
}

TEST(GcodeDialect, LinuxcncRefusesWhatGrblAccepts) {
  EXPECT_THAT(error_of(kLaserJob, {}), HasSubstr("p.nc:1:"));
  // Without the '$' and '%' lines, LinuxCNC still wants a program end.
  EXPECT_EQ(error_of("G0 X1\nG1 X2 F100\n", {}), "p.nc:2: file ended with no percent sign or program end (M2 or M30)");
  // A '%' line inside the program is an error for LinuxCNC, nothing for GRBL.
  EXPECT_THAT(error_of("G0 X1\n%\nM2\n", {}), HasSubstr("p.nc:2:"));
  EXPECT_EQ(error_of("G0 X1\n%\nM2\n", dialect(GcodeDialect::grbl)), "");
}

TEST(GcodeDialect, GrblReadsEverythingElseAsLinuxcnc) {
  // The same G-code lines give the same moves in both dialects (the path mode apart).
  const std::string text = "G21 G90\nG0 X5 Y5\nM3 S1\nG4 P0.5\nG1 X20 F600\nG3 X30 Y15 R10\nG91 G1 Y-10\nM5\nM2\n";
  const Program a = read_gcode(text, "a.nc");
  const Program b = read_gcode(text, "b.nc", dialect(GcodeDialect::grbl));
  ASSERT_EQ(a.moves.size(), b.moves.size());
  for (std::size_t i = 0; i < a.moves.size(); ++i) {
    EXPECT_EQ(a.moves[i].kind, b.moves[i].kind) << i;
    EXPECT_TRUE(a.moves[i].end.isApprox(b.moves[i].end)) << i;
    EXPECT_EQ(a.moves[i].feed_mm_per_min, b.moves[i].feed_mm_per_min) << i;
  }
  EXPECT_TRUE(b.ends_with_program_end);
  EXPECT_EQ(a.moves[0].path_mode, Move::PathMode::blend);
  EXPECT_EQ(b.moves[0].path_mode, Move::PathMode::exact_path);
  // An explicit G64 still sets blending under GRBL's reading (as everything else).
  EXPECT_EQ(read_gcode("G64 P0.1\nG0 X1\nM2\n", "c.nc", dialect(GcodeDialect::grbl)).moves[0].path_mode,
            Move::PathMode::blend);
  // Errors stay errors, with the file and line.
  EXPECT_EQ(error_of("G0 X1\nG6 X2\n", dialect(GcodeDialect::grbl)), "p.nc:2: unknown G code G6");
}

TEST(GcodeDialect, AutomaticPicksGrblOnItsSignsWithANote) {
  const GcodeOptions automatic = dialect(GcodeDialect::automatic);
  // A '$' system command.
  const Program laser = read_gcode(kLaserJob, "laser.nc", automatic);
  EXPECT_EQ(laser.dialect, GcodeDialect::grbl);
  ASSERT_GE(laser.warnings.size(), 1u);
  EXPECT_EQ(laser.warnings[0],
            "laser.nc:1: read as a GRBL program (auto-detected: a GRBL system command line; the linuxcnc dialect reads "
            "it as LinuxCNC does)");
  // A setting line ($ digits =) is GRBL's; a spindle word ($1 M3) is LinuxCNC's.
  EXPECT_EQ(read_gcode("$100=250\nG0 X1\n", "s.nc", automatic).dialect, GcodeDialect::grbl);
  GcodeOptions two_spindles = automatic;
  two_spindles.spindle_count = 2;
  const Program spindle = read_gcode("$1 M3 S100\nG1 X1 F100\n$1 M5\nM2\n", "t.nc", two_spindles);
  EXPECT_EQ(spindle.dialect, GcodeDialect::linuxcnc);
  EXPECT_TRUE(spindle.warnings.empty());
  // No program end.
  const Program noend = read_gcode("G0 X1\nG1 X2 F100\n", "n.nc", automatic);
  EXPECT_EQ(noend.dialect, GcodeDialect::grbl);
  ASSERT_EQ(noend.warnings.size(), 1u);
  EXPECT_THAT(noend.warnings[0], HasSubstr("n.nc: read as a GRBL program (auto-detected: no program end"));
  // A '%' line inside the program.
  EXPECT_EQ(read_gcode("G0 X1\n%\nG0 X2\n", "q.nc", automatic).dialect, GcodeDialect::grbl);
  // A LinuxCNC program stays LinuxCNC's, '%' around it included.
  const Program lcnc = read_gcode("%\nG0 X1\nG1 X2 F100\n%\n", "l.nc", automatic);
  EXPECT_EQ(lcnc.dialect, GcodeDialect::linuxcnc);
  EXPECT_TRUE(lcnc.warnings.empty());
  // --lenient (require_program_end false) keeps LinuxCNC's reading of a program with no end.
  GcodeOptions lenient = automatic;
  lenient.require_program_end = false;
  const Program l2 = read_gcode("G0 X1\n", "m.nc", lenient);
  EXPECT_EQ(l2.dialect, GcodeDialect::linuxcnc);
  ASSERT_EQ(l2.warnings.size(), 1u);
  EXPECT_THAT(l2.warnings[0], HasSubstr("the program has no end"));
}

// A program as GRBL senders' users share them: real-time commands ('?' status, '~' cycle
// start, '!' feed hold) on lines of their own, which the sender sends at once, not as lines.
const char* const kRealtimeJob =
    "?\n"                 // 1
    "G21 G90\n"           // 2
    "G0 X10 Y10\n"        // 3
    "~\n"                 // 4
    "G1 X20 F600\n"       // 5
    " ! \r\n"             // 6
    "M2\n";               // 7

TEST(GcodeDialect, GrblSkipsRealTimeCommandLinesWithANote) {
  const Program p = read_gcode(kRealtimeJob, "rt.nc", dialect(GcodeDialect::grbl));
  // The moves of the program without those lines.
  const Program q = read_gcode("G21 G90\nG0 X10 Y10\nG1 X20 F600\nM2\n", "q.nc", dialect(GcodeDialect::grbl));
  ASSERT_EQ(p.moves.size(), q.moves.size());
  for (std::size_t i = 0; i < p.moves.size(); ++i) {
    EXPECT_EQ(p.moves[i].kind, q.moves[i].kind) << i;
    EXPECT_TRUE(p.moves[i].end.isApprox(q.moves[i].end)) << i;
  }
  EXPECT_EQ(p.moves[1].line, 5);
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_EQ(p.warnings[0], "rt.nc:1: 3 GRBL real-time command lines (?, ~, !) skipped, as a GRBL sender skips them");
  // A '?' inside a G-code line is not a real-time line: an error as before.
  EXPECT_THAT(error_of("G0 X1 ?\n", dialect(GcodeDialect::grbl)), HasSubstr("p.nc:1: bad character '?'"));
}

TEST(GcodeDialect, LinuxcncRefusesRealTimeLinesNamingTheGrblDialect) {
  EXPECT_EQ(error_of(kRealtimeJob, {}),
            "p.nc:1: '?' is a GRBL real-time command, which a GRBL sender strips before streaming; LinuxCNC has no "
            "such line: read the program in the grbl dialect");
  EXPECT_THAT(error_of("G0 X1\n!\nM2\n", {}), HasSubstr("p.nc:2: '!' is a GRBL real-time command"));
  // The automatic dialect takes such a line as a sign of a GRBL program.
  const Program p = read_gcode(kRealtimeJob, "rt.nc", dialect(GcodeDialect::automatic));
  EXPECT_EQ(p.dialect, GcodeDialect::grbl);
  ASSERT_EQ(p.warnings.size(), 2u);
  EXPECT_THAT(p.warnings[0], HasSubstr("rt.nc:1: read as a GRBL program (auto-detected: a GRBL real-time command line"));
}

TEST(GcodeDialect, NamesParseBothWays) {
  for (GcodeDialect d : {GcodeDialect::linuxcnc, GcodeDialect::grbl, GcodeDialect::automatic})
    EXPECT_EQ(gcode_dialect_from(to_string(d)), d);
  EXPECT_FALSE(gcode_dialect_from("fanuc").has_value());
}

}  // namespace
}  // namespace machplan
