// machplan on the HAL-simulated machine (scripts/hal-sim), end to end through the command line:
// parts cut within a tenth of a millimetre from pos-fb, the HAL-side watchdog when machplan is
// killed mid-cut, the E-stop chain opened mid-cut, and a calibration session recorded on the
// velocity-mode simulation. Each test starts HAL and stops it again (HalSim), and runs in
// machine time: the servo thread paces every run.
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"
#include "tests/support/hal_sim.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

// Sampler columns (datasets/hal/sim_common.hal).
enum Col { kPeriod, kMissed, kTorch, kEnable, kWatchdogOk, kEstopOk, kCmdX, kCmdY, kFbX, kFbY };

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::string halcmd_getp(const std::string& pin) {
  std::string out;
  if (FILE* p = popen(("timeout 10 halcmd getp " + pin + " 2>&1").c_str(), "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

// HAL runs lock their memory and run SCHED_FIFO: not from a user namespace.
const test::CliIo kNoNamespace{.isolate = false};

// On a flat plate, or on one warped along X (`amplitude` mm over `wavelength` mm, the HAL
// simulation's plate model: scripts/hal-sim sheet --warp), whose surface each probe must find.
void expect_cut_within_a_tenth(const std::string& program, double amplitude = 0.0, double wavelength = 1.0) {
  test::HalSim sim;
  if (amplitude != 0.0) test::hal_sim(fmt::format("sheet --warp {},{}", amplitude, wavelength));
  const test::Cli cli;
  const test::CliResult r =
      cli.run(fmt::format("run datasets/parts/{} --machine thermal_gantry --backend hal --json", program), kNoNamespace);
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_EQ(j["status"], "done") << r.out.substr(0, 2000);
  EXPECT_EQ(j["backend"], "hal");
  EXPECT_FALSE(j["cuts"].empty());
  const double err = j["max_contour_error_mm"].get<double>();
  EXPECT_GT(err, 0.0);  // measured, from pos-fb
  EXPECT_LE(err, 0.1) << program;
  // The machine has no truth to tell: no true figure, not a number standing in for one.
  EXPECT_EQ(j["truth_available"], false);
  EXPECT_TRUE(j["max_true_contour_error_mm"].is_null());
  EXPECT_TRUE(j["rms_true_contour_error_mm"].is_null());
  EXPECT_TRUE(j["cuts"][0]["max_true_contour_error_mm"].is_null());
  // The torch probes for the simulated plate at each pierce, through the float switch and
  // ohmic pins, so the run takes at least the lower bound, which counts those probes.
  EXPECT_GE(j["cycle_ratio"].get<double>(), 1.0) << program;
  std::printf("%s: cycle ratio %.4f\n", program.c_str(), j["cycle_ratio"].get<double>());
  // Every pierce probed through the HAL pins; the surface found where the plate model puts it.
  ASSERT_FALSE(j["probes"].empty());
  double worst = 0.0;
  for (const json& p : j["probes"]) {
    EXPECT_EQ(p["sensor"], "ohmic");
    EXPECT_FALSE(p["skipped"].get<bool>()) << "the pierces lie more than 5 mm apart";
    EXPECT_TRUE(p["pierce_height_error_mm"].is_null()) << "no truth through HAL";
    const double x = p["position_mm"][0].get<double>();
    const double plate = amplitude * std::sin(2 * M_PI * x / wavelength);
    worst = std::max(worst, std::abs(p["surface_mm"].get<double>() - plate));
  }
  EXPECT_LT(worst, 0.1) << program;
  std::printf("%s: %zu probes through HAL, surface within %.3f mm of the plate model's (warp %g mm over %g mm)\n",
              program.c_str(), j["probes"].size(), worst, amplitude, wavelength);
  ASSERT_FALSE(j["backend_notes"].empty());
  EXPECT_NE(j["backend_notes"][0].get<std::string>().find("HAL exchange"), std::string::npos);
  std::printf("%s: max contour error %.4f mm; %s\n", program.c_str(), err, j["backend_notes"][0].get<std::string>().c_str());
}

TEST(HalRun, TriangleIsCutWithinATenthOfAMillimetreFromPosFb) { expect_cut_within_a_tenth("triangle_45.ngc"); }

TEST(HalRun, TheReportSaysTheTrueErrorIsUnavailable) {
  test::HalSim sim;
  const test::Cli cli;
  const test::CliResult r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --backend hal", kNoNamespace);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("true error       unavailable: the hal backend reports only what the machine measures"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
}

// Several parts of lines, fillets and full-circle holes at two feeds. (The nested sheet
// takes six minutes of machine time; the simulator backend's suites cut it whole.)
// On a plate warped 1.5 mm over 1000 mm along X: each of its five pierces probes a different
// height (gentle enough for a cut without THC: the HAL simulation has no arc voltage).
TEST(HalRun, BracketWithHolesIsCutWithinATenthOfAMillimetreFromPosFb) { expect_cut_within_a_tenth("bracket_l.ngc", 1.5, 1000.0); }

// The gantry with an offset probe 80 mm left of the torch (and 30 mm behind it) instead of its
// ohmic contact, on the bracket over a plate warped along X: every pierce probed through
// machplan.offset-probe and the float-switch pin beside the torch, the surface found where the
// plate model puts it under the pierce (not under the torch as it probed), the cut within a tenth.
TEST(HalRun, TheOffsetProbeFindsThePlateUnderEachPierceThroughHal) {
  constexpr double kOffsetX = -80.0, kA = 1.5, kL = 1000.0;
  test::HalSim sim;
  test::hal_sim(fmt::format("sheet --warp {},{}", kA, kL));
  test::HalPins pins;
  pins.set_pin("probe-shift.in1", kOffsetX);
  test::TempDir dir;
  std::string yaml = slurp("datasets/machines/thermal_gantry.yaml");
  const std::string sensors = "    ohmic: true ";
  ASSERT_NE(yaml.find(sensors), std::string::npos);
  yaml.replace(yaml.find(sensors), sensors.size(),
               fmt::format("    offset_x_mm: {}\n    offset_y_mm: 30\n    offset_delay_s: 0.2\n    ohmic: false", kOffsetX));
  const std::string machine = (dir.path() / "thermal_gantry.yaml").string();
  std::ofstream(machine) << yaml;
  const test::Cli cli;
  const test::CliResult r =
      cli.run(fmt::format("run datasets/parts/bracket_l.ngc --machine '{}' --backend hal --json", machine), kNoNamespace);
  pins.set_pin("probe-shift.in1", 0.0);
  ASSERT_EQ(r.code, 0) << r.err << r.out.substr(0, 2000);
  const json j = json::parse(r.out);
  EXPECT_EQ(j["status"], "done");
  EXPECT_LE(j["max_contour_error_mm"].get<double>(), 0.1);
  ASSERT_FALSE(j["probes"].empty());
  double worst = 0.0, worst_torch = 0.0;
  for (const json& p : j["probes"]) {
    EXPECT_EQ(p["sensor"], "offset_probe");
    const double x = p["position_mm"][0].get<double>();
    const double surface = p["surface_mm"].get<double>();
    worst = std::max(worst, std::abs(surface - kA * std::sin(2 * M_PI * x / kL)));
    worst_torch = std::max(worst_torch, std::abs(surface - kA * std::sin(2 * M_PI * (x - kOffsetX) / kL)));
  }
  std::printf("offset probe through HAL: %zu probes, surface within %.3f mm of the plate under the pierce (%.3f mm off the "
              "plate under the torch as it probed); max contour error %.4f mm\n",
              j["probes"].size(), worst, worst_torch, j["max_contour_error_mm"].get<double>());
  EXPECT_LT(worst, 0.1);
  EXPECT_GT(worst_torch, 0.2) << "the probe, not the torch, met the plate";
}

// The program side stalled again and again (SIGSTOP for 60 ms every 300 ms, as a loaded machine
// or a page fault would stall it): the component plays the positions the program planned ahead
// (machplan.comp), so the cut stays on its path and no following error trips, where coasting
// at the last speed overshot the ends of moves by a millimetre or more.
TEST(HalRun, StalledProgramTheComponentPlaysThePlannedPositionsAndTheCutStaysOnThePath) {
  test::HalSim sim;
  test::TempDir dir;
  const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
  test::Child run(
      fmt::format("'{}' run datasets/parts/triangle_45.ngc --machine thermal_gantry --backend hal --json", MACHPLAN_CLI),
      out, err);
  int stalls = 0;
  for (auto end = std::chrono::steady_clock::now() + 120s; !run.exited() && std::chrono::steady_clock::now() < end;) {
    std::this_thread::sleep_for(240ms);
    if (::kill(run.pid(), SIGSTOP) != 0) break;
    std::this_thread::sleep_for(60ms);
    ::kill(run.pid(), SIGCONT);
    ++stalls;
  }
  ASSERT_EQ(run.wait(60s), 0) << slurp(err);
  const json j = json::parse(slurp(out));
  EXPECT_EQ(j["status"], "done");
  const double e = j["max_contour_error_mm"].get<double>();
  EXPECT_LE(e, 0.1);
  ASSERT_FALSE(j["backend_notes"].empty());
  const std::string note = j["backend_notes"][0].get<std::string>();
  // The note counts the periods the component played from the plan: the stalls made some.
  const std::size_t at = note.find("planned ahead in ");
  ASSERT_NE(at, std::string::npos) << note;
  EXPECT_GT(std::stol(note.substr(at + 17)), 100) << note;
  EXPECT_GT(stalls, 20);
  std::printf("triangle_45.ngc stalled %d times: max contour error %.4f mm; %s\n", stalls, e, note.c_str());
}

// machplan cutting, with the torch lit; returns when the arc has burned a while.
void start_cutting(test::HalPins& pins, test::Child& run, const std::string& err_path) {
  ASSERT_TRUE(pins.wait_bit("machplan.arc-ok", true, 60000ms)) << "no arc within 60 s: " << slurp(err_path);
  std::this_thread::sleep_for(300ms);
  ASSERT_TRUE(pins.bit("machplan.torch-on")) << slurp(err_path);
  (void)run;
}

TEST(HalRun, KilledMidCutTheComponentStopsTheMachineWithinTheWatchdog) {
  test::HalSim sim;
  test::HalPins pins;
  test::TempDir dir;
  const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
  test::Child run(fmt::format("'{}' run datasets/parts/nested_sheet.ngc --machine thermal_gantry --backend hal", MACHPLAN_CLI),
                  out, err);
  start_cutting(pins, run, err);
  if (HasFatalFailure()) return;
  test::SamplerRecording rec(pins, 1500, (dir.path() / "samples").string());
  std::this_thread::sleep_for(200ms);
  run.kill_now();
  const auto rows = rec.rows(30s);
  ASSERT_EQ(rows.size(), 1500u);
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_EQ(rows[i][kPeriod], rows[i - 1][kPeriod] + 1) << "row " << i;
  const int watchdog = static_cast<int>(pins.number("machplan.watchdog-periods"));

  // The last period machplan's command arrived in time, mid-cut.
  std::size_t last = rows.size();
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (rows[i][kMissed] == 0) last = i;
  ASSERT_LT(last, rows.size()) << "no command arrived in time while recording";
  EXPECT_EQ(rows[last][kTorch], 1.0);
  EXPECT_EQ(rows[last][kEnable], 1.0);
  // The first period torch-on and enable are off: within watchdog_periods() + 1 of it.
  std::size_t off = rows.size();
  for (std::size_t i = last; i < rows.size() && off == rows.size(); ++i)
    if (rows[i][kTorch] == 0 && rows[i][kEnable] == 0) off = i;
  ASSERT_LT(off, rows.size()) << "torch-on and enable stayed on";
  const double periods = rows[off][kPeriod] - rows[last][kPeriod];
  std::printf("killed: torch-on and enable FALSE %.0f periods after the last command (watchdog %d periods)\n", periods,
              watchdog);
  EXPECT_LE(periods, watchdog + 1);
  EXPECT_GE(periods, watchdog);  // not before the watchdog's time either
  for (std::size_t i = off; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i][kTorch], 0.0) << "row " << i;
    ASSERT_EQ(rows[i][kEnable], 0.0) << "row " << i;
    ASSERT_EQ(rows[i][kWatchdogOk], 0.0) << "row " << i;
  }
  // The positions stop changing: the commands ramp to rest at stop-decel (at most 0.2 s from
  // the gantry's top speed), the disabled drives stand.
  ASSERT_GT(rows.size(), off + 400);
  for (std::size_t i = off + 250; i < rows.size(); ++i)
    for (int c : {kCmdX, kCmdY, kFbX, kFbY}) ASSERT_EQ(rows[i][c], rows[off + 250][c]) << "row " << i << " column " << c;
  // As halcmd reads them, a while later.
  EXPECT_EQ(halcmd_getp("machplan.torch-on"), "FALSE");
  EXPECT_EQ(halcmd_getp("machplan.enable"), "FALSE");
  EXPECT_EQ(halcmd_getp("machplan.watchdog-ok"), "FALSE");
  const double x = pins.number("machplan.axis.0.pos-fb"), y = pins.number("machplan.axis.1.pos-fb");
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(pins.number("machplan.axis.0.pos-fb"), x);
  EXPECT_EQ(pins.number("machplan.axis.1.pos-fb"), y);
}

TEST(HalRun, EstopMidCutTorchOffTheSamePeriodControlledStopExit3) {
  test::HalSim sim;
  test::HalPins pins;
  test::TempDir dir;
  const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
  test::Child run(
      fmt::format("'{}' run datasets/parts/nested_sheet.ngc --machine thermal_gantry --backend hal --json", MACHPLAN_CLI),
      out, err);
  start_cutting(pins, run, err);
  if (HasFatalFailure()) return;
  test::SamplerRecording rec(pins, 800, (dir.path() / "samples").string());
  std::this_thread::sleep_for(100ms);
  pins.set_signal("estop-open", 1);
  EXPECT_EQ(run.wait(60s), 3) << slurp(err);
  const auto rows = rec.rows(30s);
  ASSERT_EQ(rows.size(), 800u);
  std::size_t open = rows.size();
  for (std::size_t i = 0; i < rows.size() && open == rows.size(); ++i)
    if (rows[i][kEstopOk] == 0) open = i;
  ASSERT_LT(open, rows.size());
  ASSERT_GT(open, 0u);
  EXPECT_EQ(rows[open - 1][kTorch], 1.0);  // cutting the period before
  EXPECT_EQ(rows[open][kTorch], 0.0);      // off in the period the chain opened
  EXPECT_EQ(rows[open][kEnable], 0.0);
  for (std::size_t i = open; i < rows.size(); ++i) ASSERT_EQ(rows[i][kTorch], 0.0) << "row " << i;

  const json j = json::parse(slurp(out));
  EXPECT_EQ(j["status"], "faulted");
  ASSERT_FALSE(j["faults"].empty());
  EXPECT_EQ(j["faults"][0]["kind"], "estop");
  EXPECT_TRUE(j["torch_off_at_end"].get<bool>());
  EXPECT_TRUE(j["stopped_at_rest"].get<bool>());
  EXPECT_NE(j["summary"].dump().find("E-stop"), std::string::npos) << j["summary"].dump();
  pins.set_signal("estop-open", 0);
}

TEST(HalRun, CalibrationOnTheVelocityModeSimulationFindsTheDrivesGainError) {
  test::HalSim sim("--velocity");
  test::HalPins pins;
  const test::Cli cli;
  const std::string log = (cli.dir() / "session.csv").string();
  const test::CliResult rec =
      cli.run(fmt::format("calibrate record --machine thermal_gantry --backend hal --out '{}'", log), kNoNamespace);
  ASSERT_EQ(rec.code, 0) << rec.err;
  const test::CliResult fit = cli.run(fmt::format("calibrate fit '{}' --machine thermal_gantry --json", log));
  ASSERT_EQ(fit.code, 0) << fit.err;
  const json j = json::parse(fit.out);
  EXPECT_EQ(j["status"], "done") << fit.out.substr(0, 2000);
  for (const char* axis : {"x", "y"}) {
    const double gain = pins.number(fmt::format("gain.{}.gain", axis));  // the simulated drive's gain error
    const double fitted = j["axes"][axis]["feed_factor"].get<double>();
    std::printf("axis %s: drive gain %.4f, fitted feed factor %.5f (%.3f %%)\n", axis, gain, fitted,
                100 * (fitted / gain - 1));
    EXPECT_NEAR(fitted / gain, 1.0, 0.005) << axis;
  }
}

}  // namespace
}  // namespace machplan
