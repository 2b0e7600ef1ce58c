// `machplan run --controller KIND --gain NAME=VALUE`: the executor runs the chosen controller,
// the report names it, and bad kinds and gains exit with 2 naming the flag.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "solvers/motion/run.h"
#include "tests/support/datasets.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

using test::part;

using CliRun = test::CliResult;

CliRun machplan(const std::string& args) { return test::Cli().run(args); }

TEST(RunController, BadKindsAndGainsExitWithTwoAndNameTheFlag) {
  const std::string tri = "run '" + part("triangle_45.ngc") + "' --machine thermal_gantry ";
  const struct {
    std::string args, expect;
  } cases[] = {
      {"--controller pd", "--controller: unknown controller 'pd' (known: p, pid, pid_ff, zpetc, ccc, flc)"},
      {"--gain kp_per_s=100", "--gain: gains need a controller kind"},
      {"--controller p --gain kp_per_s", "--gain: 'kp_per_s': expected NAME=VALUE"},
      {"--controller p --gain kp_per_s=fast", "--gain: 'kp_per_s=fast': 'fast' is not a finite number"},
      {"--controller p --gain ki_per_s2=10", "--gain: controller 'p' has no gain 'ki_per_s2'"},
      {"--controller p --gain kp_per_s=1e9", "--gain: kp_per_s = 1000000000 is outside [1, 3000]"},
      {"--controller p --gain kp_per_s=50 --gain kp_per_s=60", "--gain: gain 'kp_per_s' given twice"},
  };
  for (const auto& c : cases) {
    const CliRun r = machplan(tri + c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.expect)) << c.args;
  }
}

// The run uses the chosen controller: "pid_ff" with its defaults is exactly the executor's
// default servo (same numbers to the last bit), and another kind gives another run.
TEST(RunController, TheChosenControllerRunsAndIsReported) {
  const std::string tri = "run '" + part("triangle_45.ngc") + "' --machine thermal_gantry --json ";
  const CliRun def = machplan(tri);
  const CliRun pid_ff = machplan(tri + "--controller pid_ff");
  const CliRun p = machplan(tri + "--controller p --gain kp_per_s=90");
  ASSERT_EQ(def.code, 0) << def.err;
  ASSERT_EQ(pid_ff.code, 0) << pid_ff.err;
  ASSERT_EQ(p.code, 0) << p.err;
  const auto jd = nlohmann::json::parse(def.out), jf = nlohmann::json::parse(pid_ff.out), jp = nlohmann::json::parse(p.out);
  EXPECT_EQ(jd["controller"], "pid_ff");
  EXPECT_EQ(jp["controller"], "p");
  EXPECT_EQ(jp["status"], "done");
  EXPECT_EQ(jd["max_true_contour_error_mm"], jf["max_true_contour_error_mm"]);
  EXPECT_EQ(jd["cycle_time_s"], jf["cycle_time_s"]);
  // Without feed-forward the P loop carries the gantry's 0.7 drive gain as lag: another run.
  EXPECT_NE(jd["max_true_contour_error_mm"], jp["max_true_contour_error_mm"]);
  const CliRun text = machplan("run '" + part("triangle_45.ngc") + "' --machine thermal_gantry --controller flc");
  EXPECT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("servo controller flc"));
}

}  // namespace
}  // namespace machplan
