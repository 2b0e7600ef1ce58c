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
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

std::string part(const std::string& name) { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/" + name; }

struct CliRun {
  int code = -1;
  std::string out, err;
};

CliRun machplan(const std::string& args) {
  test::TempDir dir;
  const std::string out = (dir.path() / "out.txt").string(), err = (dir.path() / "err.txt").string();
  const int rc = std::system(fmt::format("'{}' {} > '{}' 2> '{}'", MACHPLAN_CLI, args, out, err).c_str());
  CliRun r;
  r.code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  std::ifstream o(out), e(err);
  r.out.assign(std::istreambuf_iterator<char>(o), {});
  r.err.assign(std::istreambuf_iterator<char>(e), {});
  return r;
}

TEST(RunController, BadKindsAndGainsExitWithTwoAndNameTheFlag) {
  const std::string tri = "run '" + part("triangle_45.ngc") + "' --machine thermal_gantry ";
  const struct {
    std::string args, expect;
  } cases[] = {
      {"--controller pd", "--controller: unknown controller 'pd' (kinds: p, pid, pid_ff, zpetc, ccc, flc)"},
      {"--gain kp_per_s=100", "--gain: gains need a controller (--controller KIND)"},
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

// The run uses the chosen controller: the cross-coupled one holds the contour of the bundled
// triangle far better than the plain axial P on the same gains (the gantry's 0.7 drive gain is
// left to the loops: neither has feed-forward).
TEST(RunController, TheChosenControllerRunsAndIsReported) {
  const std::string tri = "run '" + part("triangle_45.ngc") + "' --machine thermal_gantry --json ";
  const CliRun p = machplan(tri + "--controller p --gain kp_per_s=90");
  const CliRun ccc = machplan(tri + "--controller ccc --gain kp_per_s=90 --gain ccc_kp_per_s=200");
  ASSERT_EQ(p.code, 0) << p.err;
  ASSERT_EQ(ccc.code, 0) << ccc.err;
  const auto jp = nlohmann::json::parse(p.out), jc = nlohmann::json::parse(ccc.out);
  EXPECT_EQ(jp["controller"], "p");
  EXPECT_EQ(jc["controller"], "ccc");
  EXPECT_EQ(jc["status"], "completed");
  const double ep = jp["max_true_contour_error_mm"], ec = jc["max_true_contour_error_mm"];
  std::printf("triangle_45 on the gantry: max true contour error P %.4f mm, CCC %.4f mm\n", ep, ec);
  EXPECT_LT(ec, ep / 2);
  const CliRun text = machplan("run '" + part("triangle_45.ngc") + "' --machine thermal_gantry --controller flc");
  EXPECT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("servo controller flc"));
}

}  // namespace
}  // namespace machplan
