// Only the CLI knows flag names (cli/field_flags.h): a library's field error reaches the user
// under the flag that set the field, an old spelling of a name is read with a one-line
// warning, and a message quotes at most an excerpt of the user's text.
#include <algorithm>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "models/backends/backend_factory.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using test::TempDir;

const std::string kRun = "run datasets/parts/triangle_45.ngc --machine thermal_gantry";
const std::string kGuard = "guard datasets/profiles/paper_triangle.dxf --tool-radius 5 --tolerance 1 --operator random:3";

// Each of these is refused by a library's validate() naming a field (nested ones included:
// ExecutorOptions::blu_mm inside RunOptions is "executor.blu_mm"); the user reads the flag.
TEST(FieldFlags, AFieldErrorReadsAsTheFlagThatSetTheField) {
  TempDir dir;
  struct Case {
    std::string args, err;
  };
  for (const Case& c : {
           Case{kRun + " --mode paper-closed --blu 0", "--blu: 0 is out of range: must be in [0.01, 1000] mm\n"},
           Case{kRun + " --kerf 1e3", "--kerf: 1000 is out of range: must be >= 0 and <= 100 mm\n"},
           Case{kRun + " --backend fieldbus",
                fmt::format("--backend: unknown backend 'fieldbus' (known: {})\n", fmt::join(backends::backend_names(), ", "))},
           Case{kGuard + " --side outside --latency-ms 5000", "--latency-ms: 5000 ms must be in [0, 1000]\n"},
           Case{kGuard + " --side middle", "--side: unknown machining side 'middle' (known: outside, inside)\n"},
           Case{"profile datasets/profiles/paper_triangle.dxf --flatten-tolerance 9",
                "--flatten-tolerance: is 9, must be finite, >= 0 and <= 5 degrees\n"},
           Case{"tune --machine xy_table --controller p --contour bogus:1:2",
                "--contour: 'bogus:1:2': unknown contour kind 'bogus' (line:ANGLE_DEG:FEED_MM_MIN, "
                "circle:RADIUS_MM:FEED_MM_MIN, corner:TURN_DEG:FEED_MM_MIN, square:SIDE_MM:FEED_MM_MIN or "
                "program:FILE.ngc)\n"},
       }) {
    const test::CliResult r = test::Cli().run(c.args);
    EXPECT_EQ(r.code, 2) << c.args;
    EXPECT_EQ(r.err, c.err) << c.args;
  }
}

// The old spellings still work, with one line on stderr saying what to write instead; the
// run goes on (here into the paper mode, whose --blu check then refuses 0).
TEST(FieldFlags, AnOldSpellingIsAcceptedWithAOneLineWarning) {
  TempDir dir;
  const test::CliResult mode = test::Cli().run(kRun + " --mode paper_open --blu 0");
  EXPECT_EQ(mode.code, 2);
  EXPECT_EQ(mode.err,
            "machplan: warning: --mode: 'paper_open' is the old spelling of 'paper-open'\n"
            "--blu: 0 is out of range: must be in [0.01, 1000] mm\n");
  const test::CliResult kind = test::Cli().run("tune --machine xy_table --controller pid-ff --contour bogus:1:2");
  EXPECT_EQ(kind.code, 2);
  EXPECT_THAT(kind.err, ::testing::StartsWith("machplan: warning: --controller: 'pid-ff' is the old spelling of "
                                              "'pid_ff'\n--contour: "));
  // The canonical spellings give no warning.
  const test::CliResult canonical = test::Cli().run(kRun + " --mode paper-open --blu 0");
  EXPECT_EQ(canonical.err, "--blu: 0 is out of range: must be in [0.01, 1000] mm\n");
}

// A 10 MB one-line value in a machine file is quoted by its first characters only.
TEST(FieldFlags, AMessageQuotesAnExcerptOfTheUsersText) {
  TempDir dir;
  const std::string machine = (dir.path() / "huge.yaml").string();
  {
    std::ofstream f(machine);
    f << "name: huge\nservo_period_s: " << std::string(10u << 20, '7') << "x\n";
  }
  const test::CliResult r = test::Cli().run(kRun.substr(0, kRun.find(" --machine")) + " --machine '" + machine + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_LT(r.err.size(), 400u) << r.err.substr(0, 400);
  EXPECT_THAT(r.err, HasSubstr(machine + ":2: key 'servo_period_s' must be a number, got '" + std::string(60, '7') +
                               "...'"));
}

}  // namespace
}  // namespace machplan
