// A tuning whose baseline faults: no figure from the faulted run reads as a measurement, the
// report says where it faulted, and the comparison is made on what both completed.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "solvers/tuning/tune.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::tuning {
namespace {

// These calls have no stop, deadline or budget of the caller's.
Termination no_stop;

// On the XY table the axial P baseline faults on the triangle: its first long rapid runs the
// following error past the limit.
const std::string kTriangle = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/triangle_45.ngc";

TEST(TuneBaseline, AFaultedBaselineGivesNoRatio) {
  EvaluationOptions eo;
  eo.machine = "xy_table";
  const Evaluator ev(eo, {parse_contour("program:" + kTriangle), parse_contour("circle:20:960")});
  TuneOptions o;
  o.kind = "ccc";
  o.evaluation = eo;
  o.optimizer.max_evaluations = 3;
  o.fresh_check = false;
  const TuneResult r = tune(ev, o, no_stop);
  ASSERT_TRUE(r.baseline.faulted);
  ASSERT_TRUE(r.baseline.contours[0].faulted);
  ASSERT_FALSE(r.baseline.contours[1].faulted);
  // Compared on the circle alone, which the baseline completed.
  ASSERT_EQ(r.improvement.contours.size(), 1u);
  EXPECT_EQ(r.improvement.contours[0], "circle:20:960");
  ASSERT_EQ(r.improvement.faulted.size(), 1u);
  EXPECT_NE(r.improvement.faulted[0].find("following error"), std::string::npos) << r.improvement.faulted[0];
  EXPECT_DOUBLE_EQ(r.improvement.baseline_max_mm, r.baseline.contours[1].max_mm);
  EXPECT_DOUBLE_EQ(r.improvement.tuned_max_mm, r.tuned.contours[1].max_mm);
  const std::string report = r.summary.full_report();
  EXPECT_NE(report.find("baseline (axial P)                     FAULTED on program:"), std::string::npos) << report;
  EXPECT_NE(report.find("triangle_45.ngc:"), std::string::npos) << "where it faulted";
  EXPECT_NE(report.find("(left out, a run did not complete: program:"), std::string::npos) << report;
  EXPECT_EQ(report.find("max 0.0000 mm"), std::string::npos) << report;
}

TEST(TuneBaseline, TheCommandSaysSoInTextAndJson) {
  const test::Cli cli;
  const std::string args = "tune --machine xy_table --controller ccc --contour program:'" + kTriangle +
                           "' --evaluations 2 --noise-runs 1";
  const test::CliResult text = cli.run(args);
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("FAULTED on program:"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("no improvement figure: baseline and tuned gains completed none of the contours together"), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("improvement on the baseline: max"), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("0.00x"), std::string::npos) << text.out;

  const test::CliResult json = cli.run(args + " --json");
  ASSERT_EQ(json.code, 0) << json.err;
  const auto j = nlohmann::json::parse(json.out);
  EXPECT_TRUE(j["baseline"]["faulted"].get<bool>());
  EXPECT_TRUE(j["baseline"]["max_contour_error_mm"].is_null());
  EXPECT_TRUE(j["baseline"]["contours"][0]["max_contour_error_mm"].is_null());
  EXPECT_FALSE(j["improvement"].contains("max_ratio"));
  EXPECT_EQ(j["improvement"]["baseline_faulted"].size(), 1u);
}

}  // namespace
}  // namespace machplan::tuning
