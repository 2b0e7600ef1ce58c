// The dense re-check has one name on both commands, `--dense`; place's former `--dense-check`
// still works, with a warning on stderr.
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// The paper's machine with a small box and three poses above it: a dense check in no time.
std::string small_scene(const test::Cli& cli) {
  cli.write("path.csv", "x,y,z,i,j,k\n0,0,30,0,0,1\n10,0,30,0,0,1\n10,10,30,0,0,1\n");
  return cli.write("scene.yaml",
                   fmt::format("machine: {}/datasets/hexam-paper/machine.yaml\n"
                               "tooling: {{tool_diameter_mm: 10, stick_out_mm: 50, flute_length_mm: 20, "
                               "chuck_diameter_mm: 60, chuck_length_mm: 45}}\n"
                               "workpiece: {{box: {{size: [60, 60, 30]}}}}\ntoolpath: path.csv\n",
                               MACHPLAN_SOURCE_DIR));
}

TEST(DenseFlag, PlaceAndCheckCallItTheSame) {
  test::Cli cli;
  const std::string scene = small_scene(cli);
  const test::CliResult place = cli.run({"place", scene, "--dense", "--json"});
  ASSERT_EQ(place.code, 0) << place.err;
  EXPECT_THAT(place.out, HasSubstr("\"dense_check_free\": true"));
  EXPECT_THAT(place.err, Not(HasSubstr("warning")));
  const test::CliResult check = cli.run({"check", scene, "--at", "0,0,60", "--dense", "--json"});
  EXPECT_THAT(check.out, HasSubstr("\"method\": \"dense\"")) << check.err;
}

TEST(DenseFlag, TheFormerSpellingStillWorksWithAWarning) {
  test::Cli cli;
  const std::string scene = small_scene(cli);
  const test::CliResult r = cli.run({"place", scene, "--dense-check", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"dense_check_free\": true"));
  EXPECT_THAT(r.err, HasSubstr("warning: --dense-check is now --dense"));
  // Not offered any more.
  EXPECT_THAT(cli.run({"place", "--help"}).out, Not(HasSubstr("--dense-check")));
}

}  // namespace
}  // namespace machplan
