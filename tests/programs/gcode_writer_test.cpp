// The G-code writer's dialects (engine/programs/gcode_writer.h): GRBL's text reads back to the
// same moves in the grbl dialect, what GRBL cannot say is refused with the line, and the
// material feed is written as QtPlasmaC's parameter.
#include "engine/programs/gcode_writer.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"

// A named namespace: the unity build puts gcode_dialect_test.cpp's helpers beside these.
namespace machplan::gcode_writer_test {

using ::testing::HasSubstr;
using ::testing::Not;

const char* const kCut =
    "G21 G90 G17 G94\n"
    "G0 X10 Y10\nM3 S1\nG4 P0.5\n"
    "G1 X20 Y10 F1500\nG2 X20 Y10 I5 J0\nG3 X30 Y20 I10 J0 F900\nM5\n"
    "M8\nM9\nG0 X0 Y0\nM2\n";

GcodeOptions dialect(GcodeDialect d) {
  GcodeOptions o;
  o.dialect = d;
  return o;
}

TEST(GcodeWriter, TheGrblDialectReadsBackInGrblToTheSameMoves) {
  const Program p = read_gcode(kCut, "cut.ngc");
  const std::string text = write_gcode(p, "a header", GcodeDialect::grbl);
  EXPECT_THAT(text, Not(HasSubstr("G91.1")));
  EXPECT_THAT(text, Not(HasSubstr("G64")));
  const Program back = read_gcode(text, "back.nc", dialect(GcodeDialect::grbl));
  ASSERT_EQ(back.moves.size(), p.moves.size());
  for (std::size_t i = 0; i < p.moves.size(); ++i) {
    EXPECT_EQ(back.moves[i].kind, p.moves[i].kind) << i;
    EXPECT_LT((back.moves[i].end - p.moves[i].end).norm(), 1e-6) << i;
    EXPECT_LT((back.moves[i].center - p.moves[i].center).norm(), 1e-6) << i;
    EXPECT_EQ(back.moves[i].feed_mm_per_min, p.moves[i].feed_mm_per_min) << i;
  }
  EXPECT_EQ(back.events.size(), p.events.size()) << "M8, M9";
}

TEST(GcodeWriter, WhatGrblCannotSayIsRefusedWithItsLine) {
  for (const char* word : {"M190 P3\n", "M62 P2\n", "M67 E3 Q60\n", "T2 M6\n", "#<holes> = 2\n"}) {
    GcodeOptions o;
    o.reported_params = {"holes"};
    const Program p = read_gcode(std::string("G21 G90\n") + word + "G0 X1 Y1\nM3 S1\nG1 X2 F100\nM5\nM2\n", "w.ngc", o);
    try {
      (void)write_gcode(p, "", GcodeDialect::grbl);
      ADD_FAILURE() << word << " written for GRBL";
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr("w.ngc:2")) << word;
      EXPECT_THAT(e.what(), HasSubstr("GRBL has no")) << word;
    }
    EXPECT_NO_THROW((void)write_gcode(p)) << word << ": LinuxCNC has it";
  }
}

TEST(GcodeWriter, TheMaterialFeedIsWrittenAsQtPlasmaCsParameter) {
  Program p = read_gcode(kCut, "cut.ngc");
  for (Move& m : p.moves)
    if (m.kind == Move::Kind::line || m.kind == Move::Kind::arc) m.feed_mm_per_min = kMaterialCutFeed;
  const std::string text = write_gcode(p);
  EXPECT_THAT(text, HasSubstr("F#<_hal[plasmac.cut-feed-rate]>"));
  GcodeOptions o;
  o.params["_hal[plasmac.cut-feed-rate]"] = 1234.0;
  const Program back = read_gcode(text, "back.ngc", o);
  for (const Move& m : back.moves)
    if (m.kind == Move::Kind::line || m.kind == Move::Kind::arc) EXPECT_EQ(m.feed_mm_per_min, 1234.0);
  EXPECT_THROW((void)write_gcode(p, "", GcodeDialect::grbl), InputError);
}

}  // namespace machplan::gcode_writer_test
