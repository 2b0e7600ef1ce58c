// `machplan run --record` and `machplan consumables show|reset`: a run of a bundled plasma job
// recorded with the figures of its own report, the counters since a consumable change, and
// bad input (a missing flag, a file that is not a store).
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan::test {
namespace {

TEST(ConsumablesCli, ARecordedRunCountsWhatItsReportSays) {
  const Cli cli;
  const std::string db = (cli.dir() / "shop.db").string();
  const CliResult run = cli.run({"run", "datasets/parts/nested_sheet.ngc", "--machine", "thermal_gantry", "--json",
                                 "--record", "--db", db});
  ASSERT_EQ(run.code, 0) << run.err;
  const auto r = nlohmann::json::parse(run.out);
  ASSERT_TRUE(r.contains("recorded")) << run.out;
  const std::string machine = r["machine"];

  const CliResult show = cli.run({"consumables", "show", "--machine", machine, "--db", db, "--json"});
  ASSERT_EQ(show.code, 0) << show.err;
  const auto s = nlohmann::json::parse(show.out);
  ASSERT_EQ(s["jobs"].size(), 1u);
  const auto& job = s["jobs"][0];
  EXPECT_EQ(job["id"], r["recorded"]["job_id"]);
  EXPECT_EQ(job["status"], "done");
  EXPECT_EQ(job["fault"], "");
  const auto& f = job["figures"];
  EXPECT_GT(f["pierces"].get<int>(), 1);
  EXPECT_EQ(f["pierces"].get<std::size_t>(), r["cuts"].size());
  EXPECT_EQ(f["probes"].get<std::size_t>(), r["probes"].size());
  EXPECT_DOUBLE_EQ(f["arc_on_s"].get<double>(), r["torch_on_s"].get<double>());
  EXPECT_DOUBLE_EQ(f["cycle_s"].get<double>(), r["cycle_time_s"].get<double>());
  EXPECT_DOUBLE_EQ(f["rapid_mm"].get<double>(), r["rapid_distance_mm"].get<double>());
  EXPECT_GT(f["cut_mm"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(f["cut_mm"].get<double>(), r["cut_distance_mm"].get<double>());
  EXPECT_EQ(s["lifetime"]["pierces"], f["pierces"]);
  EXPECT_EQ(s["since_change"]["pierces"], f["pierces"]);

  // The operator changes the consumables: the counters since then are zero, the lifetime stays.
  const CliResult reset = cli.run({"consumables", "reset", "--machine", machine, "--db", db, "--who", "ana"});
  ASSERT_EQ(reset.code, 0) << reset.err;
  const auto after = nlohmann::json::parse(cli.run({"consumables", "show", "--machine", machine, "--db", db, "--json"}).out);
  EXPECT_EQ(after["since_change"]["pierces"], 0);
  EXPECT_EQ(after["since_change"]["jobs"], 0);
  EXPECT_EQ(after["lifetime"]["pierces"], f["pierces"]);
  EXPECT_EQ(after["last_change"]["who"], "ana");
}

TEST(ConsumablesCli, BadInputNamesTheFlag) {
  const Cli cli;
  const CliResult no_machine = cli.run({"consumables", "show", "--db", (cli.dir() / "a.db").string()});
  EXPECT_EQ(no_machine.code, 2);
  EXPECT_NE(no_machine.err.find("--machine"), std::string::npos) << no_machine.err;

  const std::string junk = cli.write("junk.db", std::string(4096, 'j'));
  const CliResult foreign = cli.run({"consumables", "show", "--machine", "gantry", "--db", junk});
  EXPECT_EQ(foreign.code, 2);
  EXPECT_NE(foreign.err.find("--db"), std::string::npos) << foreign.err;

  // --record checks its store before the machine moves.
  const CliResult run = cli.run({"run", "datasets/parts/nested_sheet.ngc", "--machine", "thermal_gantry", "--record",
                                 "--db", junk});
  EXPECT_EQ(run.code, 2);
  EXPECT_NE(run.err.find("--db"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace machplan::test
