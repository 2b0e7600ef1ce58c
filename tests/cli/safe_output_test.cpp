// The command line's output and option checks: a failed write to stdout is exit 1 with the
// reason, --json is valid UTF-8 whatever the input's bytes, an output path that is an input is
// refused before any work, and bad option values (NaN, infinities, too many or repeated
// rotations, absurd placements) exit 2 naming the flag.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/programs/mesh.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using test::TempDir;
namespace fs = std::filesystem;

struct Outcome {
  int code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs `machplan ARGS` (ARGS already quoted for the shell); stdout goes to `stdout_to` when
// given, else to a file that is returned.
Outcome machplan(const std::string& args, const std::string& stdout_to = "") {
  TempDir dir;
  const fs::path out = dir.path() / "out", err = dir.path() / "err";
  const int rc = std::system(fmt::format("'{}' {} > '{}' 2> '{}'", MACHPLAN_CLI, args,
                                         stdout_to.empty() ? out.string() : stdout_to, err.string())
                                 .c_str());
  Outcome r;
  r.code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

const std::string kSource = MACHPLAN_SOURCE_DIR;
const std::string kScene = kSource + "/datasets/hexam-paper/scene.yaml";
const std::string kProgram = kSource + "/datasets/programs/demo_plate.ngc";

TEST(SafeOutput, AFullStdoutIsExitOneWithTheReason) {
  if (!fs::exists("/dev/full")) GTEST_FAIL() << "/dev/full is needed by this test";
  const Outcome json = machplan(fmt::format("program --json '{}'", kProgram), "/dev/full");
  EXPECT_EQ(json.code, 1);
  EXPECT_THAT(json.err, HasSubstr("cannot write the output to standard output: No space left on device"));
  const Outcome text = machplan(fmt::format("program '{}'", kProgram), "/dev/full");
  EXPECT_EQ(text.code, 1);
  EXPECT_THAT(text.err, HasSubstr("No space left on device"));
  // Bad input keeps its own exit code even when stdout is broken too.
  EXPECT_EQ(machplan("program /nonexistent/x.ngc", "/dev/full").code, 2);
}

TEST(SafeOutput, JsonIsValidUtf8WhateverTheFileName) {
  TempDir dir;
  // A Latin-1 file name, as legacy systems write them: "pi\xe8ce.stl".
  const std::string name = dir.write("pi\xe8" "ce.stl", to_binary_stl(make_box_mesh({0, 0, 0}, {1, 2, 3})));
  const Outcome r = machplan(fmt::format("mesh --json '{}'", name));
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;  // parse() refuses invalid UTF-8
  EXPECT_THAT(j["source"].get<std::string>(), HasSubstr("pi\xef\xbf\xbd" "ce.stl"));  // U+FFFD
  EXPECT_THAT(r.err, HasSubstr("not valid UTF-8"));
  EXPECT_TRUE(j["closed"].get<bool>());
}

TEST(SafeOutput, AnOutputThatIsAnInputIsRefusedBeforeAnyWork) {
  TempDir dir;
  fs::copy(kSource + "/datasets/hexam-paper", dir.path() / "scene", fs::copy_options::recursive);
  const fs::path scene = dir.path() / "scene" / "scene.yaml";
  const std::string before = slurp(scene), toolpath_before = slurp(dir.path() / "scene" / "toolpath.csv");
  Outcome r = machplan(fmt::format("place '{}' --plot '{}'", scene.string(), scene.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("--plot: "));
  EXPECT_THAT(r.err, HasSubstr("is an input of this command"));
  EXPECT_EQ(r.out, "");  // nothing ran
  // The same file by another spelling, and a file the scene names.
  r = machplan(fmt::format("place '{}' --plot '{}/scene/../scene/toolpath.csv'", scene.string(), dir.path().string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("is an input of this command"));
  r = machplan(fmt::format("place '{}' --plot '{}/scene/workpiece.stl'", scene.string(), dir.path().string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(slurp(scene), before);
  EXPECT_EQ(slurp(dir.path() / "scene" / "toolpath.csv"), toolpath_before);
  // A folder that does not exist is found before the search, not after it.
  r = machplan(fmt::format("place '{}' --plot '{}/no/such/folder/p.png'", scene.string(), dir.path().string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("does not exist"));
  EXPECT_EQ(r.out, "");
}

TEST(SafeOutput, TheTimeEstimateOfAVeryLongProgramDoesNotOverflow) {
  TempDir dir;
  // 200 dwells of 999,999,999 s (the reader's largest P): 3,333,333,330 min, beyond an int.
  std::string text = "G21 G90\n";
  for (int k = 0; k < 200; ++k) text += "G4 P999999999\n";
  const std::string prog = dir.write("long.ngc", text + "M2\n");
  const Outcome r = machplan(fmt::format("program '{}'", prog));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("(3333333330:00.0 min"));
  EXPECT_THAT(r.out, Not(HasSubstr("-2147483648")));
}

TEST(BadOptions, NonFiniteAndAbsurdValuesExitTwoNamingTheFlag) {
  struct Case {
    std::string args, flag;
  };
  const Case cases[] = {
      {fmt::format("check '{}' --at 0,0,70 --rotation nan", kScene), "--rotation"},
      {fmt::format("check '{}' --at 0,0,70 --rotation inf", kScene), "--rotation"},
      {fmt::format("check '{}' --at 0,0,70 --rotation 1e9", kScene), "--rotation"},
      {fmt::format("check '{}' --at nan,0,70", kScene), "--at"},
      {fmt::format("check '{}' --at 1e308,0,70", kScene), "--at"},
      {fmt::format("check '{}' --at 0,0,1e300", kScene), "--at"},
      {fmt::format("place '{}' --rotations nan", kScene), "--rotations"},
      {fmt::format("place '{}' --rotations 0,90,360", kScene), "--rotations"},  // 360 repeats 0
      {fmt::format("program '{}' --rapid-mm-per-min nan", kProgram), "--rapid-mm-per-min"},
      {fmt::format("program '{}' --rapid-mm-per-min inf", kProgram), "--rapid-mm-per-min"},
      {fmt::format("program '{}' --rapid-mm-per-min -5", kProgram), "--rapid-mm-per-min"},
      {"mesh x.stl --scale nan", "--scale"},
      {"mesh x.stl --scale 0", "--scale"},
      {"mesh x.stl --weld-tolerance inf", "--weld-tolerance"},
      {"mesh x.stl --weld-tolerance -1", "--weld-tolerance"},
      {fmt::format("profile '{}' --tolerance nan", kSource + "/datasets/profiles/flange_plate.dxf"), "--tolerance"},
  };
  for (const Case& c : cases) {
    const Outcome r = machplan(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.flag)) << c.args;
    EXPECT_THAT(r.err, Not(HasSubstr("internal error"))) << c.args;
  }
}

TEST(BadOptions, TooManyRotationsAreRefusedWithTheLimit) {
  std::string many = "0";
  for (int k = 1; k < 100; ++k) many += fmt::format(",{}", k * 3.5);
  const Outcome r = machplan(fmt::format("place '{}' --rotations {}", kScene, many));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("--rotations: 100 rotations; at most 72"));
  EXPECT_EQ(r.out, "");
}

}  // namespace
}  // namespace machplan
