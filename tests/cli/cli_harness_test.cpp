// The CLI harness every command-line test uses (tests/support/cli_run.h): the command reads
// and writes the sandbox's folders, not the user's; the shell and the argument-list forms pass
// the same words; a started command can be signalled once it handles the signal.
#include <csignal>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(CliHarness, TheUsersFoldersAreTheSandboxes) {
  test::Cli cli;
  const test::CliResult r = cli.run({"machines"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr((cli.config_home() / "machplan" / "machines").string()));
  // The calibration store's default place is the sandbox's data folder.
  EXPECT_FALSE(fs::exists(cli.data_home() / "machplan" / "calibration.db"));
  const test::CliResult h = cli.run({"calibrate", "history"});
  ASSERT_EQ(h.code, 0) << h.err;
  EXPECT_THAT(h.out, HasSubstr("no calibrations stored"));
  EXPECT_TRUE(fs::exists(cli.data_home() / "machplan" / "calibration.db"));
}

TEST(CliHarness, ShellWordsAndArgumentListsAgree) {
  test::Cli cli;
  const std::string with_space = cli.write("a part.ngc", "G0 X10 Y5\nG1 X20 F600\nM2\n");
  const test::CliResult a = cli.run("program '" + with_space + "' --json");
  const test::CliResult b = cli.run({"program", with_space, "--json"});
  ASSERT_EQ(a.code, 0) << a.err;
  EXPECT_EQ(a.out, b.out);
  EXPECT_THAT(a.out, HasSubstr("\"moves\""));
  // Bundled data by relative path: the current folder is the source tree.
  EXPECT_EQ(cli.run({"program", "datasets/programs/demo_plate.ngc"}).code, 0);
}

TEST(CliHarness, AStartedCommandIsSignalledOnceItHandlesTheSignal) {
  test::Cli cli;
  // A run paced to the wall clock lasts minutes; SIGTERM once handled ends it in order, in
  // whichever phase it comes (planning the rapids, or running).
  test::CliProcess p =
      cli.start({"run", "datasets/parts/nested_sheet.ngc", "--machine", "thermal_gantry", "--realtime"});
  ASSERT_TRUE(p.wait_until_catching(SIGTERM));
  ASSERT_TRUE(p.signal(SIGTERM));
  const test::CliResult r = p.wait();
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, ::testing::AnyOf(HasSubstr("stop requested"), HasSubstr("stopped on request")));
}

}  // namespace
}  // namespace machplan
