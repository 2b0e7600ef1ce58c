// `machplan order`: the reordered program is G-code LinuxCNC's rs274 reads, to the cuts
// machplan reads from it; bad flags and programs that cannot be reordered are refused.
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"
#include "tests/support/rs274.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

// A plate cut before its two holes (each pierced at its centre, lead-in to the edge).
const char* const kPlateProgram =
    "G21 G90 G17 G94\n"
    "G0 X94 Y150\nM3 S1\nG4 P0.5\nG1 X100 Y150 F3000\nG1 X100 Y200\nG1 X300 Y200\nG1 X300 Y100\n"
    "G1 X100 Y100\nG1 X100 Y150\nM5\n"
    "G0 X140 Y170\nM3 S1\nG4 P0.5\nG1 X150 Y170 F1500\nG3 X150 Y170 I-10 J0\nM5\n"
    "G0 X260 Y130\nM3 S1\nG4 P0.5\nG1 X270 Y130 F1500\nG3 X270 Y130 I-10 J0\nM5\n"
    "G0 X0 Y0\nM2\n";

TEST(OrderCli, WritesAProgramRs274ReadsToTheSameCuts) {
  test::TempDir dir;
  const std::string in = dir.write("plate.ngc", kPlateProgram);
  const std::string out = (dir.path() / "ordered.ngc").string();
  const test::CliResult r = test::Cli().run("order '" + in + "' --output '" + out + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("3 cuts in optimise order"));
  // machplan's reading of the written program.
  const test::FeedEnds feeds = test::machplan_feeds(out);
  ASSERT_GE(feeds.size(), 4u);
  EXPECT_TRUE(feeds[0].first > 140 && feeds[0].first < 290 && feeds[0].second > 110) << feeds[0].first;
  // LinuxCNC's reading: accepted, with the same feed moves.
  test::expect_same_feeds(test::rs274_feeds(out), feeds);
}

TEST(OrderCli, ReportAsJsonAndBadInput) {
  test::TempDir dir;
  const std::string in = dir.write("plate.ngc", kPlateProgram);
  const std::string out = (dir.path() / "o.ngc").string();
  const test::CliResult j = test::Cli().run("order '" + in + "' -o '" + out + "' --json");
  ASSERT_EQ(j.code, 0) << j.err;
  const nlohmann::json report = nlohmann::json::parse(j.out);
  EXPECT_EQ(report["order"], "optimise");
  EXPECT_EQ(report["cuts"], 3);
  EXPECT_EQ(report["sequence_lines"].back(), 5);  // the plate last
  EXPECT_EQ(report["outer_first"]["outer_line"], 5);
  EXPECT_LE(report["travel_mm"].get<double>(), report["programmed_travel_mm"].get<double>());
  // stdout: the program; the report on stderr.
  const test::CliResult plain = test::Cli().run("order '" + in + "'");
  ASSERT_EQ(plain.code, 0);
  EXPECT_THAT(plain.out, HasSubstr("G21 G90 G91.1 G94"));
  EXPECT_THAT(plain.err, HasSubstr("cut order of"));
  // Bad input.
  EXPECT_EQ(test::Cli().run("order '" + in + "' --json").code, 2);
  const test::CliResult bad = test::Cli().run("order '" + in + "' --order sideways");
  EXPECT_EQ(bad.code, 2);
  EXPECT_THAT(bad.err, HasSubstr("--order: 'sideways' is not an order"));
  EXPECT_EQ(test::Cli().run("order '" + in + "' -o '" + in + "'").code, 2);  // over its own input
  // A program that cannot be reordered: exit 3, the reason, nothing written.
  const std::string z = dir.write("z.ngc", "G0 X1\nM3 S1\nG1 X5 F100\nM5\nG0 Z5\nM2\n");
  const std::string zo = (dir.path() / "z_out.ngc").string();
  const test::CliResult zr = test::Cli().run("order '" + z + "' -o '" + zo + "'");
  EXPECT_EQ(zr.code, 3);
  EXPECT_THAT(zr.out, HasSubstr("z.ngc:5: Z moves"));
  EXPECT_FALSE(std::filesystem::exists(zo));
}

}  // namespace
}  // namespace machplan
