// `machplan run` under faults a user can rehearse from the command line (--inject), a signal
// during a run, and a machine whose loop cannot hold the path: each ends with the torch off,
// the machine at rest, a report and exit 3.
#include <signal.h>

#include <chrono>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "models/backends/backend_factory.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

std::string part(const char* name) { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/" + name; }

using CliRun = test::CliResult;

CliRun machplan(const std::vector<std::string>& args) { return test::Cli().run(args); }

// The last line of a trace CSV, split.
std::vector<std::string> last_trace_row(const std::string& path, std::size_t& lines) {
  std::ifstream in(path);
  std::string line, last;
  lines = 0;
  while (std::getline(in, line)) last = line, ++lines;
  std::vector<std::string> cols;
  std::stringstream ss(last);
  for (std::string c; std::getline(ss, c, ',');) cols.push_back(c);
  return cols;
}

class Signals : public ::testing::TestWithParam<int> {};

TEST_P(Signals, StopTheMachineWriteTheReportAndTraceAndExitThree) {
  test::Cli cli;
  const std::string trace = (cli.dir() / "trace.csv").string();
  // The nested sheet paced to the wall clock, signalled once the streamed trace shows a second
  // of machine time (1000 periods): the machine is moving when the signal comes. The verdict
  // rests on that order and on the state at the end, not on how fast the run goes (the wait is
  // only a guard against a run that never starts).
  test::CliProcess p =
      cli.start({"run", part("nested_sheet.ngc"), "--machine", "thermal_gantry", "--realtime", "--trace", trace});
  std::size_t before = 0;
  for (int k = 0; k < 6000 && before <= 1000; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    last_trace_row(trace, before);
  }
  ASSERT_GT(before, 1000u) << "the run never got going";
  ASSERT_TRUE(p.signal(GetParam()));
  const CliRun r = p.wait();
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.out, HasSubstr("FAULT stop_requested"));
  EXPECT_THAT(r.out, HasSubstr("torch off at the end; machine stopped at rest"));
  EXPECT_THAT(r.err, HasSubstr("stop requested"));
  std::size_t lines = 0;
  const auto row = last_trace_row(trace, lines);
  EXPECT_GT(lines, before);  // the controlled stop was streamed after what was there at the signal
  // t_s,...,dac_y,enabled,torch_fire,arc_ok,...: the state after the last period
  ASSERT_EQ(row.size(), 16u);
  EXPECT_EQ(row[10], "0");  // drives disabled
  EXPECT_EQ(row[11], "0");  // torch off
}

INSTANTIATE_TEST_SUITE_P(IntTermHup, Signals, ::testing::Values(SIGINT, SIGTERM, SIGHUP),
                         [](const auto& info) {
                           return std::string(info.param == SIGINT ? "SIGINT" : (info.param == SIGTERM ? "SIGTERM" : "SIGHUP"));
                         });

struct JamCase {
  const char* mode;
  const char* expect;  // the fault that names the jam in this mode
};

class InjectedJam : public ::testing::TestWithParam<JamCase> {};

TEST_P(InjectedJam, EndsTorchOffAtRestReportedExitThree) {
  const JamCase c = GetParam();
  std::vector<std::string> args = {"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--json",
                                   "--mode", c.mode, "--inject", "jam@4:x"};
  if (std::string(c.mode) != "planned") args.insert(args.end(), {"--feed", "4"});
  const CliRun r = machplan(args);
  ASSERT_EQ(r.code, 3) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "faulted");
  ASSERT_EQ(j["faults"].size(), 1u);
  EXPECT_EQ(j["faults"][0]["kind"], c.expect);
  EXPECT_EQ(j["faults"][0]["axis"], "x");
  EXPECT_TRUE(j["torch_off_at_end"].get<bool>());
  EXPECT_TRUE(j["stopped_at_rest"].get<bool>());
  EXPECT_GE(j["faults"][0]["time_s"].get<double>(), 4.0);
  EXPECT_THAT(r.err, HasSubstr(std::string("machplan run: fault: ")));
}

INSTANTIATE_TEST_SUITE_P(EveryMode, InjectedJam,
                         ::testing::Values(JamCase{"planned", "following_error"}, JamCase{"paper-open", "axis_stalled"},
                                           JamCase{"paper-closed", "axis_stalled"}),
                         [](const auto& info) {
                           std::string n = info.param.mode;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

TEST(Inject, EveryKindEndsInItsFault) {
  const struct {
    const char* inject;
    const char* kind;
  } cases[] = {{"estop@3", "estop"},
               {"encoder-glitch@4:y", "encoder_glitch"},
               {"counter-misread@4", "counter_wrap_misread"},
               {"lost-backend@4", "lost_backend"},
               {"arc-loss@9", "arc_lost"},
               {"arc-start-failure@0", "arc_start_failed"},
               {"watchdog@4", "watchdog"}};
  for (const auto& c : cases) {
    const CliRun r = machplan({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--json", "--inject", c.inject});
    ASSERT_EQ(r.code, 3) << c.inject << "\n" << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["faults"][0]["kind"].get<std::string>(), c.kind) << c.inject;
    EXPECT_TRUE(j["torch_off_at_end"].get<bool>()) << c.inject;
  }
}

TEST(Inject, BadValuesExitTwoNamingTheFlag) {
  for (const char* bad : {"jam", "jam@", "jam@-1", "jam@x", "melt@3", "jam@3:z", "estop@nan"}) {
    const CliRun r = machplan({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--inject", bad});
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_THAT(r.err, HasSubstr("--inject")) << bad;
  }
  const CliRun r = machplan({"run", part("triangle_45.ngc"), "--machine", "thermal_gantry", "--backend", "linuxcnc"});
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr(fmt::format("--backend: unknown backend 'linuxcnc' (known: {})",
                                           fmt::join(backends::backend_names(), ", "))));
}

TEST(Supervision, ALoopThatCannotHoldThePathIsAFault) {
  // The gantry with a proportional gain far beyond stability (Kp T = 50 at its 1 ms period, within
  // the machine file's bound of 1e5): the drive output flips between its limits.
  test::TempDir dir;
  std::ifstream in(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  text = std::regex_replace(text, std::regex("kp_per_s: 90"), "kp_per_s: 5e4");
  text = std::regex_replace(text, std::regex("name: thermal_gantry"), "name: gantry_kp_5e4");
  const std::string machine = (dir.path() / "gantry_kp_5e4.yaml").string();
  std::ofstream(machine) << text;
  const CliRun r = machplan({"run", part("triangle_45.ngc"), "--machine", machine, "--json"});
  ASSERT_EQ(r.code, 3) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["faults"][0]["kind"], "drive_saturated");
  EXPECT_TRUE(j["torch_off_at_end"].get<bool>());
}

}  // namespace
}  // namespace machplan
