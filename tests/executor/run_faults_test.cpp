// `machplan run` under faults a user can rehearse from the command line (--inject), a signal
// during a run, and a machine whose loop cannot hold the path: each ends with the torch off,
// the machine at rest, a report and exit 3.
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
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

// While a run streams its trace, the rows go to a hidden temporary beside the trace's name
// (engine/common/output_file.h), renamed into place when the run ends: its path, or "" while
// there is none yet.
std::string streaming_trace_in(const std::filesystem::path& dir, const std::string& name) {
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.path().filename().string().rfind("." + name + ".tmp-", 0) == 0) return e.path().string();
  return {};
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
    const std::string streaming = streaming_trace_in(cli.dir(), "trace.csv");
    if (!streaming.empty()) last_trace_row(streaming, before);
  }
  ASSERT_GT(before, 1000u) << "the run never got going";
  EXPECT_FALSE(std::filesystem::exists(trace));  // the trace takes its name only when complete
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
  EXPECT_EQ(streaming_trace_in(cli.dir(), "trace.csv"), "");  // renamed, nothing left beside it
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

// A warped simulated sheet rises into the torch. A torch that touches the plate is a collision
// (QtPlasmaC's breakaway): the torch goes off in the period the breakaway switch opens, the
// machine stops under control, the run ends faulted with the fault named, exit 3. Before the
// breakaway input a run on a sheet warped 50 mm "completed" with the torch 63 mm below the
// plate's surface and the arc on. With a float switch fitted (the gantry's), the torch floats
// up as it meets the plate and its switch closing while the torch fires is the breakaway.
TEST(TorchCollision, ATorchThatTouchesTheWarpedPlateIsAFaultWithTheTorchOff) {
  test::Cli cli;
  const std::string trace = (cli.dir() / "collision.csv").string();
  // 4 mm over 40 mm: within the probe's reach (5 mm under the nominal surface), but too steep
  // for THC, and the plate meets the torch in the first cut.
  const CliRun r = cli.run({"run", part("nested_sheet.ngc"), "--machine", "thermal_gantry", "--sheet-warp", "4,40",
                            "--json", "--trace", trace});
  ASSERT_EQ(r.code, 3) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "faulted");
  ASSERT_EQ(j["faults"].size(), 1u);
  EXPECT_EQ(j["faults"][0]["kind"], "torch_breakaway");
  EXPECT_THAT(j["faults"][0]["message"].get<std::string>(), HasSubstr("the torch touched the plate"));
  EXPECT_TRUE(j["torch_off_at_end"].get<bool>());
  EXPECT_TRUE(j["stopped_at_rest"].get<bool>());
  EXPECT_THAT(r.err, HasSubstr("fault: "));
  // The trace: the torch fired with the arc on and below the plate (riding on its float, gap
  // under 0) in the period before the fault; from the fault on it is off (torch_fire, column
  // 11) and never fires again, and the run ends with the drives off. (The probes touch the
  // plate too, with the torch off.)
  const double fault_s = j["faults"][0]["time_s"].get<double>();
  std::ifstream in(trace);
  std::string line;
  std::getline(in, line);  // header
  bool cutting_before = false;
  std::size_t rows = 0, fired_after = 0;
  std::vector<std::string> cols;
  while (std::getline(in, line)) {
    cols.clear();
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cols.push_back(c);
    ASSERT_EQ(cols.size(), 16u) << line;
    ++rows;
    const double t = std::stod(cols[0]), gap = std::stod(cols[14]);
    if (std::abs(t - (fault_s - 0.001)) < 0.0005)
      cutting_before = cols[11] == "1" && cols[12] == "1" && gap < 0.0;  // torch firing, arc OK, on the plate
    if (t > fault_s + 0.0005 && cols[11] != "0") ++fired_after;
  }
  EXPECT_TRUE(cutting_before) << "the collision is expected mid-cut, with the arc on";
  EXPECT_GT(rows, 1000u);
  EXPECT_EQ(fired_after, 0u);
  EXPECT_EQ(cols[10], "0");  // drives disabled at the end

  // The report for people names the fault and the state the machine was left in.
  const CliRun text = cli.run({"run", part("nested_sheet.ngc"), "--machine", "thermal_gantry", "--sheet-warp", "4,40"});
  EXPECT_EQ(text.code, 3);
  EXPECT_THAT(text.out, HasSubstr("FAULT torch_breakaway: "));
  EXPECT_THAT(text.out, HasSubstr("torch off at the end; machine stopped at rest"));
}

// The text report of a completed run on a warped sheet carries the THC figures of the JSON.
TEST(TorchHeight, TheTextReportShowsTheThcFiguresOfTheJson) {
  const std::vector<std::string> args = {"run", part("nested_sheet.ngc"), "--machine", "thermal_gantry", "--sheet-warp",
                                         "3,1000"};
  std::vector<std::string> with_json = args;
  with_json.push_back("--json");
  const CliRun js = machplan(with_json);
  ASSERT_EQ(js.code, 0) << js.err;
  const auto j = nlohmann::json::parse(js.out);
  double max_mm = 0.0;
  int cuts = 0;
  for (const auto& c : j["cuts"])
    if (!c["thc"].is_null()) max_mm = std::max(max_mm, c["thc"]["max_height_error_mm"].get<double>()), ++cuts;
  ASSERT_GT(cuts, 0);
  const CliRun text = machplan(args);
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr(fmt::format("torch height     max {:.3f} mm", max_mm)));
  EXPECT_THAT(text.out, HasSubstr(fmt::format("over {} cuts while THC held it", cuts)));
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
