// End to end on the bundled part programs (datasets/parts) through the pipeline behind
// `machplan run` (solvers/motion/run.h), and the command itself: exit codes and messages.
//
//   * planned mode at 80 mm/s on the thermal gantry, every plant effect on: the contour error
//     while the torch burns stays within 0.1 mm, the cycle time within 10 % of its lower
//     bound, no fault, the torch off at the end;
//   * the paper's modes on the whole triangle program (rapids included) at its 4 mm/s;
//   * bad flags answered with exit 2 naming the flag, faults and impossible jobs with exit 3.
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/programs/gcode.h"
#include "tests/support/datasets.h"
#include "solvers/motion/run.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using executor::ExecutionResult;
using executor::Mode;
using ::testing::HasSubstr;

using test::part;

std::size_t torch_on_count(const Job& job) {
  std::size_t n = 0;
  for (const Step& s : job.steps) n += s.kind == Step::Kind::torch_on;
  return n;
}

// The checks every planned run at 80 mm/s must pass.
void expect_planned_run_meets_the_issue(const RunOutcome& r, const std::string& name) {
  SCOPED_TRACE(name);
  ASSERT_EQ(r.result.summary.status, Status::done) << r.summary.full_report();
  EXPECT_TRUE(r.result.faults.empty());
  EXPECT_TRUE(r.result.torch_off_at_end);
  EXPECT_TRUE(r.rapids.ok()) << r.rapids.summary.full_report();
  // The programs really cut at 80 mm/s (F4800).
  for (const Stretch& s : r.job.stretches) {
    if (!s.cutting) continue;
    for (double f : s.feed_mm_per_s) EXPECT_DOUBLE_EQ(f, 80.0);
  }
  // One measured cut per torch-on, each run to its end.
  ASSERT_EQ(r.result.cuts.size(), torch_on_count(r.job));
  for (const auto& c : r.result.cuts) {
    EXPECT_TRUE(c.complete) << "line " << c.source_line;
    EXPECT_GT(c.samples, 100u) << "line " << c.source_line;
  }
  EXPECT_LE(r.result.max_contour_error_mm(), 0.1);
  EXPECT_LE(r.result.max_true_contour_error_mm(), 0.1);
  // The bound is a bound (nothing beats it) and the run is within 10 % of it.
  EXPECT_GE(r.motion_ratio, 1.0);
  EXPECT_GE(r.cycle_ratio, 1.0);
  EXPECT_LE(r.cycle_ratio, 1.10);
  std::printf("%-24s %2zu cuts  max %.4f mm (true %.4f), rms %.4f mm  cycle %.2f s  bound %.2f s  ratio %.4f  "
              "(motion %.4f)\n",
              name.c_str(), r.result.cuts.size(), r.result.max_contour_error_mm(), r.result.max_true_contour_error_mm(),
              r.rms_contour_error_mm, r.result.cycle_time_s, r.lower_bound_s, r.cycle_ratio, r.motion_ratio);
}

TEST(RunParts, PlannedAt80OnTheGantryMeetsAccuracyAndCycleTime) {
  RunOptions o;  // thermal_gantry, planned, seed 1
  o.session.executor.record_trace = false;
  for (const char* name : {"triangle_45.ngc", "contour_lines_arcs.ngc", "nested_sheet.ngc"})
    expect_planned_run_meets_the_issue(run_program(part(name), o), name);
}

TEST(RunParts, NestedSheetHasSeveralDozenCutsAndRapidsRoundTheParts) {
  RunOptions o;
  o.session.executor.record_trace = false;
  const RunOutcome r = run_program(part("nested_sheet.ngc"), o);
  EXPECT_GE(torch_on_count(r.job), 36u);
  // Every cut closes; the 14 parts' outlines are zones, the holes' slugs (all under the
  // machine's 50 mm tip size) are crossed.
  EXPECT_EQ(r.rapids.cut_zones + r.rapids.small_slugs, torch_on_count(r.job));
  EXPECT_EQ(r.rapids.cut_zones, 14u);
  EXPECT_GT(r.rapids.replaced, 0u);
  EXPECT_GE(r.rapids.length_mm, r.rapids.straight_length_mm);
  double extra = 0;
  for (const RapidReport& rr : r.rapids.rapids)
    if (rr.replaced) {
      EXPECT_GE(rr.min_clearance_mm, o.rapids.clearance_mm - 1e-9) << "rapid at line " << rr.source_line;
      // Every detour is round a cut part and says so.
      EXPECT_THAT(rr.reason, HasSubstr("part cut at line")) << "rapid at line " << rr.source_line;
      EXPECT_GT(rr.extra_length_mm, 0.0);
      extra += rr.extra_length_mm;
    } else {
      EXPECT_TRUE(rr.reason.empty());
    }
  EXPECT_NEAR(r.rapids.detour_extra_mm, extra, 1e-6);
  EXPECT_NEAR(r.rapids.length_mm, r.rapids.straight_length_mm + extra, 1e-6);
  // What ran is what the report says.
  EXPECT_NEAR(r.result.rapid_distance_mm, r.rapids.length_mm, 1e-6);
}

// The trace never shows the torch firing outside a cut's sequence, and ends with the torch off
// and the drives disabled.
TEST(RunParts, TorchOnlyFiresForCutsAndIsOffAtTheEnd) {
  RunOptions o;
  const RunOutcome r = run_program(part("contour_lines_arcs.ngc"), o);
  ASSERT_EQ(r.result.summary.status, Status::done);
  ASSERT_FALSE(r.result.trace.empty());
  for (const auto& s : r.result.trace) {
    if (!s.torch_fire || s.step < 0) continue;
    const Step& st = r.job.steps.at(s.step);
    const bool allowed = st.kind != Step::Kind::move || r.job.stretches[st.stretch].cutting;
    EXPECT_TRUE(allowed) << "torch fires during step " << s.step << " at t = " << s.t_s;
  }
  EXPECT_FALSE(r.result.trace.back().torch_fire);
  EXPECT_FALSE(r.result.trace.back().drives_enabled);
}

TEST(RunParts, KerfCompensatedContourStaysOnItsCompensatedPath) {
  RunOptions o;
  o.kerf_mm = 1.5;
  o.session.executor.record_trace = false;
  const RunOutcome r = run_program(part("contour_lines_arcs.ngc"), o);
  ASSERT_TRUE(r.kerf.has_value());
  EXPECT_EQ(r.kerf->compensated_count(), 1u);
  ASSERT_EQ(r.result.summary.status, Status::done);
  EXPECT_LE(r.result.max_contour_error_mm(), 0.1);
  // The torch path moved: its length differs from the programmed one.
  double programmed = 0, compensated = 0;
  for (const Stretch& s : r.programmed.stretches)
    if (s.cutting)
      for (const Segment& g : s.segments) programmed += length(g);
  for (const Stretch& s : r.job.stretches)
    if (s.cutting)
      for (const Segment& g : s.segments) compensated += length(g);
  EXPECT_GT(std::abs(compensated - programmed), 1.0);
}

// --- the paper's modes on the whole triangle program (from home, rapids included) ----------

double paper_run(Mode mode, double blu, double calibration, double* rms = nullptr) {
  RunOptions o;
  o.session.executor.mode = mode;
  o.session.executor.blu_mm = blu;
  o.session.executor.calibration_factor = calibration;
  o.session.executor.record_trace = false;
  o.feed_override_mm_per_s = 4.0;  // the paper's feed
  const RunOutcome r = run_program(part("triangle_45.ngc"), o);
  EXPECT_EQ(r.result.summary.status, Status::done) << r.summary.full_report();
  EXPECT_EQ(r.machine.axes[0].plant.decoding, 1);  // measured as the paper did
  std::printf("%-12s BLU %5.1f mm  factor %.4f  max %7.3f mm (true %7.3f)  rms %.3f mm\n", executor::to_string(mode), blu,
              calibration, r.result.max_contour_error_mm(), r.result.max_true_contour_error_mm(), r.rms_contour_error_mm);
  if (rms) *rms = r.rms_true_contour_error_mm;
  return r.result.max_true_contour_error_mm();
}

// The paper's calibration on the same pipeline: a 100 mm move along X at the feed, open
// loop, uncalibrated; the factor is programmed / travelled.
double stopwatch_factor() {
  test::TempDir dir;
  const std::string prog = dir.write("calibrate.ngc", "G21 G90\nG1 X100 F240\nM2\n");
  RunOptions o;
  o.session.executor.mode = Mode::paper_open;
  const RunOutcome r = run_program(prog, o);
  EXPECT_EQ(r.result.summary.status, Status::done);
  return 100.0 / r.result.trace.back().true_mm.x();
}

TEST(RunParts, PaperModesOnTheWholeTriangleProgram) {
  double rms_small = 0, rms_best = 0;
  const double small = paper_run(Mode::paper_closed, 0.3, 1.0, &rms_small);
  const double best = paper_run(Mode::paper_closed, 3.0, 1.0, &rms_best);
  const double large = paper_run(Mode::paper_closed, 20.0, 1.0);
  EXPECT_LT(best, 1.5);  // about +-1 mm at BLU 3
  EXPECT_GT(best, 0.1);
  EXPECT_GT(large, 3.0 * best);          // long vectors: the open-loop part of each vector grows
  EXPECT_GT(rms_small, 2.0 * rms_best);  // short vectors: the computation time dominates
  EXPECT_GT(small, 0.5 * best);

  const double k = stopwatch_factor();
  std::printf("stopwatch calibration factor %.4f\n", k);
  EXPECT_GT(k, 1 / 0.7);
  EXPECT_LT(k, 1 / 0.7 * 1.15);
  const double uncalibrated = paper_run(Mode::paper_open, 3.0, 1.0);
  const double calibrated = paper_run(Mode::paper_open, 3.0, k);
  EXPECT_GT(uncalibrated, 20.0);  // 30 % short on every move, from home on
  EXPECT_LT(calibrated, 2.0);
}

// --- the command ----------------------------------------------------------------------------

using CliRun = test::CliResult;

CliRun machplan(const std::string& args) { return test::Cli().run(args); }

TEST(RunCommand, BadFlagsExitWithTwoAndNameTheFlag) {
  const std::string tri = fmt::format("'{}'", part("triangle_45.ngc"));
  const struct {
    std::string args, expect;
  } cases[] = {
      {"run " + tri + " --machine thermal_gantry --mode fast", "--mode: unknown mode 'fast'"},
      {"run " + tri + " --machine thermal_gantry --mode paper-closed --blu abc", "--blu: 'abc' is not a number"},
      {"run " + tri + " --machine thermal_gantry --mode paper-closed --blu 0", "--blu: 0 is out of range"},
      {"run " + tri + " --machine thermal_gantry --blu 5", "--blu: 5 mm: a vector length applies to the paper modes only"},
      {"run " + tri + " --machine thermal_gantry --mode paper-open --calibration 0", "--calibration: 0 is out of range"},
      {"run " + tri + " --machine thermal_gantry --kerf -1", "--kerf: -1 is out of range"},
      {"run " + tri + " --machine thermal_gantry --kerf 1e3", "--kerf: 1000 is out of range"},
      {"run " + tri + " --machine thermal_gantry --kerf 1e-6", "--kerf: 1e-06 mm is below 0.001 mm"},
      {"run " + tri + " --machine thermal_gantry --feed 0", "--feed: 0 must be > 0"},
      {"run " + tri + " --machine thermal_gantry --magnify 0", "--magnify: 0 must be > 0"},
      {"run " + tri + " --machine thermal_gantry --plot out.jpg", "--plot: 'out.jpg' must end in .png or .svg"},
      {"run " + tri + " --machine thermal_gantry --seed -3", "--seed: '-3' is not a whole number"},
      {"run " + tri + " --machine no_such_machine", "no_such_machine"},
      {"run " + tri + " --machine thermal_gantry --no-go /nonexistent/zones.yaml", "/nonexistent/zones.yaml"},
      {"run /nonexistent/part.ngc --machine thermal_gantry", "/nonexistent/part.ngc"},
      {"run " + tri, "--machine is required"},
  };
  for (const auto& c : cases) {
    const CliRun r = machplan(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.expect)) << c.args;
  }
}

TEST(RunCommand, JsonPlotAndTrace) {
  test::TempDir dir;
  const std::string png = (dir.path() / "run.png").string(), csv = (dir.path() / "trace.csv").string();
  const CliRun r = machplan(fmt::format("run '{}' --machine thermal_gantry --json --plot '{}' --trace '{}' --magnify 50",
                                        part("triangle_45.ngc"), png, csv));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"cycle_time_s", "max_contour_error_mm", "rms_contour_error_mm", "cuts", "faults", "lower_bound_s",
                          "cycle_ratio", "torch_on_s", "rapid_distance_mm"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["cuts"].size(), 1u);
  EXPECT_TRUE(j["faults"].empty());
  EXPECT_NEAR(j["cycle_ratio"].get<double>(), j["cycle_time_s"].get<double>() / j["lower_bound_s"].get<double>(), 1e-9);
  EXPECT_LE(j["max_contour_error_mm"].get<double>(), 0.1);
  std::ifstream p(png, std::ios::binary);
  std::string magic(8, '\0');
  p.read(magic.data(), 8);
  EXPECT_EQ(magic, std::string("\x89PNG\r\n\x1a\n", 8));
  std::ifstream t(csv);
  std::string header;
  std::getline(t, header);
  EXPECT_THAT(header, HasSubstr("t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm"));
  std::size_t rows = 0;
  for (std::string line; std::getline(t, line);) ++rows;
  EXPECT_GT(rows, 10000u);  // about 14 s at 1 kHz
}

TEST(RunCommand, FaultDuringTheRunExitsWithThree) {
  // The gantry with a torch whose arc never starts.
  std::ifstream in(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
  std::string yaml((std::istreambuf_iterator<char>(in)), {});
  const std::string key = "arc_start_failure_probability: 0.0";
  ASSERT_NE(yaml.find(key), std::string::npos);
  yaml.replace(yaml.find(key), key.size(), "arc_start_failure_probability: 1.0");
  test::TempDir dir;
  const std::string machine = dir.write("dead_torch.yaml", yaml);
  const CliRun r = machplan(fmt::format("run '{}' --machine '{}' --json", part("triangle_45.ngc"), machine));
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, HasSubstr("no arc OK within"));
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["faults"].size(), 1u);
  EXPECT_EQ(j["faults"][0]["kind"], "arc_start_failed");
  EXPECT_EQ(j["torch_off_at_end"], true);
  EXPECT_EQ(j["status"], "faulted");
}

TEST(RunCommand, JobsTheMachineCannotDoExitWithThree) {
  // The sheet is larger than the XY table's 400 x 350 mm.
  const CliRun big = machplan(fmt::format("run '{}' --machine xy_table", part("nested_sheet.ngc")));
  EXPECT_EQ(big.code, 3) << big.err;
  EXPECT_THAT(big.err, HasSubstr("outside the travel of machine 'xy_table'"));
  // A clamp on the triangle's pierce point: the torch would cut into it.
  test::TempDir dir;
  const std::string clamp =
      dir.write("clamp.yaml", "no_go:\n  - name: clamp\n    polygon: [[190, 190], [210, 190], [210, 210], [190, 210]]\n");
  const CliRun on_clamp = machplan(fmt::format("run '{}' --machine thermal_gantry --no-go '{}'", part("triangle_45.ngc"), clamp));
  EXPECT_EQ(on_clamp.code, 3) << on_clamp.err;
  EXPECT_THAT(on_clamp.err, HasSubstr("triangle_45.ngc:9: the cut enters the no-go zone 'clamp' declared at " + clamp + ":2"));
}

// --frame: the triangle's outline traced with the torch off, from and back to the start; a
// clamp on the outline (clear of the cut) refuses the frame, not the job.
TEST(RunCommand, FrameTracesTheJobsOutlineWithTheTorchOff) {
  const CliRun r = machplan(fmt::format("run '{}' --machine thermal_gantry --frame --frame-feed 50 --json", part("triangle_45.ngc")));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "done");
  EXPECT_EQ(j["frame"]["x_mm"], nlohmann::json({200.0, 300.0}));
  EXPECT_EQ(j["frame"]["y_mm"], nlohmann::json({200.0, 300.0}));
  EXPECT_EQ(j["frame"]["feed_mm_per_s"], 50.0);
  EXPECT_EQ(j["torch_on_s"], 0.0);
  EXPECT_TRUE(j["cuts"].empty());
  // 400 mm of outline at 50 mm/s, and the rapids there and back.
  EXPECT_GT(j["cycle_time_s"].get<double>(), 8.0);
  EXPECT_THAT(r.err, HasSubstr("framing"));

  test::TempDir dir;
  const std::string clamp =
      dir.write("clamp.yaml", "no_go:\n  - name: clamp\n    polygon: [[240, 295], [260, 295], [260, 305], [240, 305]]\n");
  EXPECT_EQ(machplan(fmt::format("run '{}' --machine thermal_gantry --no-go '{}'", part("triangle_45.ngc"), clamp)).code, 0);
  const CliRun framed = machplan(fmt::format("run '{}' --machine thermal_gantry --no-go '{}' --frame", part("triangle_45.ngc"), clamp));
  EXPECT_EQ(framed.code, 3) << framed.err;
  EXPECT_THAT(framed.err, HasSubstr("the move (torch off) enters the no-go zone 'clamp'"));

  const CliRun stray = machplan(fmt::format("run '{}' --machine thermal_gantry --frame-margin 5", part("triangle_45.ngc")));
  EXPECT_EQ(stray.code, 2);
  EXPECT_THAT(stray.err, HasSubstr("--frame-margin: is for --frame"));
  const CliRun paper = machplan(fmt::format("run '{}' --machine thermal_gantry --frame --mode paper-open", part("triangle_45.ngc")));
  EXPECT_EQ(paper.code, 2);
  EXPECT_THAT(paper.err, HasSubstr("--frame"));
  // With the laser pointer (60 mm along +X from the torch): the same outline, traced by the dot.
  const CliRun laser = machplan(fmt::format("run '{}' --machine thermal_gantry --frame --laser --json", part("triangle_45.ngc")));
  ASSERT_EQ(laser.code, 0) << laser.err;
  const auto jl = nlohmann::json::parse(laser.out);
  EXPECT_EQ(jl["frame"]["x_mm"], nlohmann::json({200.0, 300.0}));
  EXPECT_EQ(jl["frame"]["pointer_offset_mm"], nlohmann::json({60.0, 0.0}));
  EXPECT_THAT(laser.err, HasSubstr("traced by the laser pointer"));
  EXPECT_THAT(machplan(fmt::format("run '{}' --machine thermal_gantry --laser", part("triangle_45.ngc"))).err,
              HasSubstr("--laser: is for --frame"));
  const CliRun no_laser = machplan(fmt::format("run '{}' --machine xy_table --frame --laser", part("triangle_45.ngc")));
  EXPECT_EQ(no_laser.code, 2);
  EXPECT_THAT(no_laser.err, HasSubstr("--laser: machine 'xy_table' has no laser pointer"));
}

// A fence of clamps round the triangle: no rapid can reach its pierce point, and the
// programmed one runs through a clamp.
TEST(RunParts, RapidWithNoClearRouteThroughAClampIsRefused) {
  test::TempDir dir;
  const std::string fence = dir.write("fence.yaml",
                                      "no_go:\n"
                                      "  - name: south\n    polygon: [[150, 150], [350, 150], [350, 160], [150, 160]]\n"
                                      "  - name: east\n    polygon: [[340, 150], [350, 150], [350, 350], [340, 350]]\n"
                                      "  - name: north\n    polygon: [[150, 340], [350, 340], [350, 350], [150, 350]]\n"
                                      "  - name: west\n    polygon: [[150, 150], [160, 150], [160, 350], [150, 350]]\n");
  RunOptions o;
  o.no_go_path = fence;
  o.rapids.max_samples = 2000;  // the goal is walled in: spend little before saying so
  // No answer is a status, not an exception: nothing runs.
  const RunOutcome r = run_program(part("triangle_45.ngc"), o);
  EXPECT_EQ(r.summary.status, Status::infeasible);
  EXPECT_THAT(r.summary.message, HasSubstr("triangle_45.ngc:6: the rapid from (0.000, 0.000) to (200.000, 200.000) has no clear route"));
  EXPECT_THAT(r.summary.message, HasSubstr("enters a declared no-go zone"));
  EXPECT_EQ(r.result.cycle_time_s, 0.0) << "the executor never started";
}

TEST(RunCommand, RapidsGoRoundADeclaredClamp) {
  // A clamp across the straight rapid from home to the triangle's pierce point at (200, 200).
  test::TempDir dir;
  const std::string zones = dir.write("clamp.yaml", "no_go:\n  - name: clamp\n    polygon: [[80, 60], [140, 120], [120, 140], [60, 80]]\n");
  const CliRun r = machplan(fmt::format("run '{}' --machine thermal_gantry --no-go '{}' --json", part("triangle_45.ngc"), zones));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["rapids"]["declared_zones"], 1);
  EXPECT_GE(j["rapids"]["re_routed"].get<int>(), 1);
  EXPECT_GT(j["rapids"]["planned_length_mm"].get<double>(), j["rapids"]["straight_length_mm"].get<double>());
  EXPECT_LE(j["max_contour_error_mm"].get<double>(), 0.1);
}

}  // namespace
}  // namespace machplan::motion
