// `machplan guard`: the JSON fields the issue names, the plot, and bad flags exiting 2 with the
// flag named, output paths checked before the run.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

using Outcome = test::CliResult;

Outcome machplan(const std::string& args) { return test::Cli().run(args); }

const std::string kTriangle = "datasets/profiles/paper_triangle.dxf";

TEST(GuardCli, JsonHasTheNamedFieldsAndThePlotIsWritten) {
  test::TempDir dir;
  const fs::path png = dir.path() / "guard.png";
  const Outcome o = machplan(fmt::format("guard {} --side outside --tool-radius 5 --tolerance 3 --operator random:6 --strategy paper "
                                         "--feed 18 --finish --json --plot '{}'",
                                         kTriangle, png.string()));
  ASSERT_EQ(o.code, 0) << o.err;
  const auto j = nlohmann::json::parse(o.out);
  for (const char* k : {"attempts", "successes", "max_invasion_mm", "mean_undercut_mm", "max_undercut_mm", "time_s", "per_attempt"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["attempts"].get<int>(), 6);
  EXPECT_EQ(j["per_attempt"].size(), 6u);
  EXPECT_EQ(j["strategy"], "paper");
  EXPECT_DOUBLE_EQ(j["latency_s"].get<double>(), 0.15);
  ASSERT_EQ(j["finish"].size(), 1u);
  EXPECT_TRUE(j["finish"][0]["completed"].get<bool>());
  EXPECT_GT(fs::file_size(png), 10000u);
}

TEST(GuardCli, TextReportPerAttemptAndTotals) {
  const Outcome o = machplan(fmt::format("guard {} --side outside --tool-radius 5 --tolerance 0.5 --operator random:3", kTriangle));
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_THAT(o.out, HasSubstr("attempts 3, successes 3 (100.00 %), invasions 0"));
  EXPECT_THAT(o.out, HasSubstr("under-cut over the successes: mean"));
}

TEST(GuardCli, BadFlagsExit2NamingTheFlag) {
  const std::string base = "guard " + kTriangle + " ";
  struct Case {
    std::string args, flag;
  };
  for (const Case& c : {
           Case{"--side middle --tool-radius 5 --tolerance 1 --operator random:3", "--side"},
           Case{"--side outside --tool-radius -1 --tolerance 1 --operator random:3", "--tool-radius"},
           Case{"--side outside --tool-radius 5 --tolerance nan --operator random:3", "--tolerance"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:0", "--operator"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --feed 0", "--feed"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --latency-ms 5000", "--latency-ms"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --strategy fast", "--strategy"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --seed -4", "--seed"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --plot out.txt", "--plot"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator random:3 --finish-allowance 0.2", "--finish-allowance"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator joystick:/dev/input/js-absent-machplan",
                "--operator: joystick: cannot open"},
           Case{"--side outside --tool-radius 5 --tolerance 1 --operator keys", "--operator: keys: "},
       }) {
    const Outcome o = machplan(base + c.args);
    EXPECT_EQ(o.code, 2) << c.args << "\n" << o.err;
    EXPECT_THAT(o.err, HasSubstr(c.flag)) << c.args;
  }
  // The plot's folder must exist before the run.
  test::TempDir dir;
  const std::string no_dir = (dir.path() / "missing" / "p.png").string();
  const Outcome nofolder = machplan(base + "--side outside --tool-radius 5 --tolerance 1 --operator random:3 --plot '" + no_dir + "'");
  EXPECT_EQ(nofolder.code, 2);
  EXPECT_THAT(nofolder.err, HasSubstr("--plot"));
  EXPECT_FALSE(fs::exists(no_dir));
  // The plot may not overwrite the profile.
  const Outcome same = machplan(base + "--side outside --tool-radius 5 --tolerance 1 --operator random:3 --plot " + kTriangle);
  EXPECT_EQ(same.code, 2);
  EXPECT_THAT(same.err, HasSubstr("--plot"));
  // A missing profile is named.
  const Outcome missing = machplan("guard /nonexistent/p.dxf --side outside --tool-radius 5 --tolerance 1 --operator random:3");
  EXPECT_EQ(missing.code, 2);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent/p.dxf"));
}

}  // namespace
}  // namespace machplan
