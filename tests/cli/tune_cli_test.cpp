// `machplan tune` end to end: a small tuning with --json and --plot, storing the gains, the
// ACC mode, and exit 2 naming the flag for bad input.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using Run = test::CliResult;

TEST(TuneCli, TunesPrintsJsonPlotsAndStores) {
  test::Cli cli;
  const std::string png = (cli.dir() / "tune.png").string(), db = (cli.dir() / "t.db").string();
  auto r = cli.run(fmt::format("tune --machine xy_table --controller p --contour circle:20:960 --evaluations 8 --json "
                                "--plot '{}'",
                                png));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "done");
  EXPECT_TRUE(j["gains"].is_object());
  EXPECT_FALSE(j["gains"].empty());
  for (const char* part : {"baseline", "tuned"})
    for (const char* k : {"max_contour_error_mm", "rms_contour_error_mm"}) EXPECT_TRUE(j[part][k].is_number()) << part << k;
  EXPECT_LE(j["tuned"]["max_contour_error_mm"].get<double>(), j["baseline"]["max_contour_error_mm"].get<double>());
  EXPECT_LE(j["optimizer"]["evaluations"].get<int>(), 8);
  EXPECT_EQ(j["tuned"]["contours"][0]["max_at"]["line"], 1);
  EXPECT_EQ(j["fresh"]["first_seed"], 4);  // after the three draws of seeds 1 .. 3
  EXPECT_TRUE(j["fresh"]["tuned"]["max_contour_error_mm"].is_number());
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
  // A fixed gain stays where it was put; one noise run instead of three.
  r = cli.run("tune --machine xy_table --controller p --contour square:10:960 --evaluations 4 --noise-runs 1 "
               "--fix kp_per_s=90 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto f = nlohmann::json::parse(r.out);
  EXPECT_EQ(f["gains"]["kp_per_s"], 90.0);
  EXPECT_EQ(f["fixed"][0], "kp_per_s");
  // The human form names the gains and both errors.
  r = cli.run("tune --machine xy_table --controller p --contour line:26.6:1200 --evaluations 3");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("baseline (axial P)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("tuned"), std::string::npos) << r.out;
}

TEST(TuneCli, StoredTuningIsUsedByRun) {
  test::Cli cli;
  const std::string db = (cli.dir() / "t.db").string();
  // The XY table carries no torch: the tuning test program is motion only.
  const std::string run =
      fmt::format("run datasets/programs/tune_corners.ngc --machine xy_table --controller tuned --db '{}' --json", db);
  auto r = cli.run(run);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--controller"), std::string::npos) << r.err;
  r = cli.run(fmt::format("tune --machine xy_table --controller p --contour line:30:1200 --evaluations 6 --store --db '{}' --json",
                           db));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto t = nlohmann::json::parse(r.out);
  EXPECT_EQ(t["stored"]["tuning_id"], 1);
  r = cli.run(run);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["controller"], "p");
}

TEST(TuneCli, AccRunsKorensTestAndPlots) {
  test::Cli cli;
  const std::string png = (cli.dir() / "acc.png").string();
  const auto r = cli.run(fmt::format("tune --acc --evaluations 40 --json --plot '{}'", png));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto& settled = j["koren_fixed_kc_0_5"]["settled"];
  ASSERT_EQ(settled.size(), 3u);
  EXPECT_NEAR(settled[0]["feed_mm_per_rev"].get<double>(), 0.25, 0.02);
  for (const auto& s : settled) EXPECT_NEAR(s["force_n"].get<double>(), 1500.0, 30.0);
  ASSERT_EQ(j["tunings"].size(), 2u);
  EXPECT_EQ(j["tunings"][0]["status"], "done");
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
}

// The README's command, as written: the test contour has a default, which --help names.
TEST(TuneCli, TheReadmesCommandTunesOnTheDefaultContour) {
  test::Cli cli;
  const auto r = cli.run("tune --machine xy_table --controller p --evaluations 3 --noise-runs 1 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["tuned"]["contours"][0]["contour"], "circle:20:960");
  const auto help = cli.run("tune --help");
  EXPECT_NE(help.out.find("(default circle:20:960)"), std::string::npos) << help.out;
}

// A deadline that ends the search with gains that meet every constraint leaves a usable
// answer: exit 0, and the status says the deadline ended it. The start point is evaluated
// first and the axial P's defaults meet the constraints, so a deadline of a few evaluations'
// work ends a feasible search.
TEST(TuneCli, ADeadlineWithUsableGainsIsNoFailure) {
  test::Cli cli;
  const auto r = cli.run("tune --machine xy_table --controller p --noise-runs 1 --time 0.05 --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out.substr(0, 400);
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "deadline");
  EXPECT_EQ(j["usable"], true);
  EXPECT_TRUE(j["optimizer"]["feasible"].get<bool>());
  EXPECT_NE(j["message"].get<std::string>().find("deadline"), std::string::npos) << j["message"];
  const auto text = cli.run("tune --machine xy_table --controller p --noise-runs 1 --time 0.05");
  EXPECT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("deadline (usable)"), std::string::npos) << text.out;
}

TEST(TuneCli, BadInputExitsTwoNamingTheFlag) {
  test::Cli cli;
  const std::pair<const char*, const char*> cases[] = {
      {"tune --machine xy_table --controller warp --contour circle:20:960", "--controller"},
      {"tune --machine xy_table --controller p --contour circle:20", "--contour"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --objective mean", "--objective"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --evaluations -3", "--evaluations"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --plot x.txt", "--plot"},
      {"tune --controller p --contour circle:20:960", "--machine"},
      {"tune --machine nowhere --controller p --contour circle:20:960", "nowhere"},
      {"tune --machine xy_table --controller p --contour program:missing.ngc", "missing.ngc"},
      {"tune --acc --acc-law sometimes", "--acc-law"},
      {"tune --acc --controller p", "--controller"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --noise-runs 0", "--noise-runs"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --fix kp_per_s", "--fix"},
      {"tune --machine xy_table --controller p --contour circle:20:960 --fix warp=1", "--fix"},
      {"tune --machine xy_table --controller p --contour square:0.1:960", "--contour"},
      {"tune --acc --noise-runs 2", "--noise-runs"},
      {"tune --acc --fix kp_per_s=1", "--fix"},
  };
  for (const auto& [args, flag] : cases) {
    const auto r = cli.run(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(flag), std::string::npos) << args << "\n" << r.err;
  }
}

}  // namespace
}  // namespace machplan
