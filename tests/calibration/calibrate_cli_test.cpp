// `machplan calibrate ...` end to end: record, fit (--json), apply, history, show, and the
// exit codes and messages for bad input.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using Run = test::CliResult;

TEST(CalibrateCli, RecordFitApplyHistoryShow) {
  test::Cli cli;
  const std::string log = (cli.dir() / "s.csv").string();
  auto r = cli.run(fmt::format("calibrate record --machine thermal_gantry --seed 5 --speeds 0.2,0.5 --hold 0.6 --out '{}'", log));
  ASSERT_EQ(r.code, 0) << r.err;
  r = cli.run(fmt::format("calibrate fit '{}' --machine thermal_gantry --json", log));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "done");
  for (const char* axis : {"x", "y"}) {
    const auto& a = j["axes"][axis];
    // The nominal machine: gain 0.7 with 2 % viscous friction.
    EXPECT_NEAR(a["feed_factor"].get<double>(), 0.7 / 1.02, 0.002) << axis;
    for (const char* k : {"mm_per_count", "feed_factor", "backlash_mm", "lag_s", "latency_s"}) {
      EXPECT_TRUE(a[k].is_number()) << k;
      EXPECT_TRUE(a["sigma"][k].is_number()) << k;
    }
  }
  EXPECT_TRUE(j["rms_residual_mm"].is_number());
  r = cli.run(fmt::format("calibrate apply '{}' --machine thermal_gantry --who tester", log));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("stored as fit 1"), std::string::npos) << r.out;
  r = cli.run("calibrate history --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto h = nlohmann::json::parse(r.out);
  ASSERT_EQ(h.size(), 1u);
  EXPECT_EQ(h[0]["who"], "tester");
  EXPECT_TRUE(h[0]["active"].get<bool>());
  r = cli.run("calibrate show --machine thermal_gantry --feed 4");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("open-loop factor at 4 mm/s: 1.5"), std::string::npos) << r.out;
  // Planned mode takes the active calibration into the executor's setup.
  r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --calibration active --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["status"], "done");
}

TEST(CalibrateCli, BadInputIsNamedWithExitCode2) {
  test::Cli cli;
  const auto bad = cli.write("bad.csv", "# a log\nt_s,axis,dac,counter,dir,ref_mm\n0.0,x,0,1,0,\n0.001,x,9999,1,0,\n");
  auto r = cli.run(fmt::format("calibrate fit '{}' --machine thermal_gantry", bad));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(bad + ":4: dac 9999 is outside -2048 .. 2047"), std::string::npos) << r.err;
  r = cli.run("calibrate record --machine thermal_gantry --seed -3");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
  r = cli.run("calibrate record --machine thermal_gantry --backend nonesuch");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--backend"), std::string::npos) << r.err;
  r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --mode paper-open --calibration active");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--feed: a calibration in the paper modes needs the feed"), std::string::npos) << r.err;
  r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --calibration 1.5");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--calibration: 1.5: a factor applies to the paper modes only"), std::string::npos) << r.err;
  r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --calibration active");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("no active calibration for 'thermal_gantry'"), std::string::npos) << r.err;
}

TEST(CalibrateCli, ALogWithoutReferencesIsNotIdentifiableWithExitCode3) {
  test::Cli cli;
  const std::string log = (cli.dir() / "s.csv").string();
  ASSERT_EQ(cli.run(fmt::format("calibrate record --machine thermal_gantry --speeds 0.3,0.6 --hold 0.5 --out '{}'", log)).code, 0);
  // Drop every reference reading: cut each row after its last comma.
  std::ifstream in(log);
  std::ostringstream stripped;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && line.rfind("t_s", 0) != 0) line = line.substr(0, line.rfind(',') + 1);
    stripped << line << '\n';
  }
  const auto norefs = cli.write("norefs.csv", stripped.str());
  const auto r = cli.run(fmt::format("calibrate fit '{}' --machine thermal_gantry --json", norefs));
  EXPECT_EQ(r.code, 3) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "infeasible");
  EXPECT_NE(j["message"].get<std::string>().find("x.mm_per_count: the log has no reference readings"), std::string::npos);
  // And such a fit cannot become the active calibration.
  const auto a = cli.run(fmt::format("calibrate apply '{}' --machine thermal_gantry", norefs));
  EXPECT_EQ(a.code, 3) << a.err;
  EXPECT_NE(a.err.find("cannot become the active calibration"), std::string::npos) << a.err;
}

}  // namespace
}  // namespace machplan
