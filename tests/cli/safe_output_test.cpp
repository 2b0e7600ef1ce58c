// The command line's output and option checks: a failed write to stdout is exit 4 with the
// reason, output files are written whole or not at all (a full disk leaves the old file and no
// partial one), inputs that are not regular files are refused at once, --json is valid UTF-8 whatever the input's bytes, an output path that is an input is
// refused before any work, and bad option values (NaN, infinities, too many or repeated
// rotations, absurd placements) exit 2 naming the flag.
#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/programs/mesh.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using test::TempDir;
namespace fs = std::filesystem;

using Outcome = test::CliResult;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs `machplan ARGS` (ARGS already quoted for the shell); stdout goes to `stdout_to` when
// given, else it is captured.
Outcome machplan(const std::string& args, const std::string& stdout_to = "") {
  test::CliIo io;
  io.stdout_path = stdout_to;
  return test::Cli().run(args, io);
}

const std::string kSource = MACHPLAN_SOURCE_DIR;
const std::string kScene = kSource + "/datasets/hexam-paper/scene.yaml";
const std::string kProgram = kSource + "/datasets/programs/demo_plate.ngc";

TEST(SafeOutput, AFullStdoutIsExitFourWithTheReason) {
  if (!fs::exists("/dev/full")) GTEST_FAIL() << "/dev/full is needed by this test";
  const Outcome json = machplan(fmt::format("program --json '{}'", kProgram), "/dev/full");
  EXPECT_EQ(json.code, 4);
  EXPECT_THAT(json.err, HasSubstr("cannot write the output to standard output: No space left on device"));
  const Outcome text = machplan(fmt::format("program '{}'", kProgram), "/dev/full");
  EXPECT_EQ(text.code, 4);
  EXPECT_THAT(text.err, HasSubstr("No space left on device"));
  // Bad input keeps its own exit code even when stdout is broken too.
  EXPECT_EQ(machplan("program /nonexistent/x.ngc", "/dev/full").code, 2);
}

// Inputs that are not regular files: a FIFO would block the reader until someone writes to it
// (for ever), /dev/zero has no end and reads as an empty GRBL program, a folder is no file.
// Each is refused at once, exit 2, naming the file and what it is. (A reader that blocked
// would hang this test: there is no writer on the FIFO.)
TEST(InputFiles, AFifoADeviceOrAFolderIsRefusedAtOnceNamingIt) {
  test::Cli cli;
  const std::string fifo = (cli.dir() / "part.ngc").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  const std::string folder = cli.dir().string();
  struct Case {
    std::vector<std::string> args;
    std::string path, what;
  };
  const Case cases[] = {
      {{"run", fifo, "--machine", "thermal_gantry"}, fifo, "is a FIFO (named pipe), not a regular file"},
      {{"order", fifo}, fifo, "is a FIFO (named pipe), not a regular file"},
      {{"program", fifo}, fifo, "is a FIFO (named pipe), not a regular file"},
      {{"run", "/dev/zero", "--machine", "thermal_gantry"}, "/dev/zero", "is a character device, not a regular file"},
      {{"program", "/dev/zero"}, "/dev/zero", "is a character device, not a regular file"},
      {{"profile", "/dev/zero"}, "/dev/zero", "is a character device, not a regular file"},
      {{"run", kProgram, "--machine", fifo}, fifo, "is a FIFO (named pipe), not a regular file"},
      {{"program", folder}, folder, "is a folder, expected a file"},
  };
  for (const Case& c : cases) {
    const Outcome r = cli.run(c.args);
    EXPECT_EQ(r.code, 2) << fmt::format("{}", fmt::join(c.args, " ")) << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.path + ": " + c.what)) << fmt::format("{}", fmt::join(c.args, " "));
    EXPECT_EQ(r.out, "");
  }
}

TEST(InputFiles, AnEmptyProgramIsRefused) {
  test::Cli cli;
  const std::string empty = cli.write("empty.ngc", "");
  for (const char* command : {"run", "program", "order"}) {
    std::vector<std::string> args = {command, empty};
    if (std::string(command) == "run") args.insert(args.end(), {"--machine", "thermal_gantry"});
    const Outcome r = cli.run(args);
    EXPECT_EQ(r.code, 2) << command << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(empty + ": the file is empty (0 bytes)")) << command;
  }
}

// Outputs on a full file system: a 64 KiB tmpfs in the run's own mount namespace, filled up
// before machplan runs. Each output fails with exit 4 (neither bad input nor a bug), names the
// file and the system's reason, leaves an existing file byte for byte and no partial file.
class FullDisk : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!test::Cli::network_namespace()) GTEST_FAIL() << "this test needs user and mount namespaces (unshare -rmn)";
    disk_ = cli_.dir() / "disk";
    fs::create_directories(disk_);
    fs::create_directories(cli_.dir() / "out");
  }
  // Runs `args` with the disk mounted and filled; `before` runs after the mount, before the
  // fill. The disk's listing (ls -A) afterwards is in listing().
  Outcome run_full(const std::string& args, const std::string& before = "") {
    test::CliIo io;
    io.small_disk_kb = 64;
    io.small_disk_at = disk_.string();
    io.small_disk_before = before + fmt::format("\ndd if=/dev/zero of='{}/fill' bs=1k count=1024 2>/dev/null\n", disk_.string());
    io.small_disk_after = fmt::format("ls -A '{}' > '{}/listing'; cp -p '{}'/*.ngc '{}/' 2>/dev/null", disk_.string(),
                                      (cli_.dir() / "out").string(), disk_.string(), (cli_.dir() / "out").string());
    return cli_.run(args, io);
  }
  std::string listing() const { return slurp(cli_.dir() / "out" / "listing"); }
  test::Cli cli_;
  fs::path disk_;
};

TEST_F(FullDisk, OrderOntoAnExistingProgramLeavesItByteForByte) {
  const std::string old_text = slurp(kProgram);
  const std::string target = (disk_ / "old.ngc").string();
  const Outcome r = run_full(fmt::format("order '{}' -o '{}'", kSource + "/datasets/parts/nested_sheet.ngc", target),
                             fmt::format("cp '{}' '{}'", kProgram, target));
  EXPECT_EQ(r.code, 4) << r.err;
  EXPECT_THAT(r.err, HasSubstr(target + ": cannot write: No space left on device"));
  EXPECT_EQ(slurp(cli_.dir() / "out" / "old.ngc"), old_text);  // the old program, whole
  EXPECT_EQ(listing(), "fill\nold.ngc\n");                     // and nothing else
}

TEST_F(FullDisk, TracePlotLogAndNewStoreLeaveNoFile) {
  const std::string part = kSource + "/datasets/parts/triangle_45.ngc";
  const struct {
    std::string args, file;
  } cases[] = {
      {fmt::format("run '{}' --machine thermal_gantry --trace '{}/trace.csv'", part, disk_.string()), "trace.csv"},
      {fmt::format("run '{}' --machine thermal_gantry --plot '{}/run.png'", part, disk_.string()), "run.png"},
      {fmt::format("calibrate record --machine thermal_gantry --speeds 0.3 --out '{}/session.csv'", disk_.string()),
       "session.csv"},
      {fmt::format("calibrate history --db '{}/new.db'", disk_.string()), "new.db"},
  };
  for (const auto& c : cases) {
    const Outcome r = run_full(c.args);
    EXPECT_EQ(r.code, 4) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.file + ": cannot write: ")) << c.args;
    EXPECT_THAT(r.err, HasSubstr("No space left on device")) << c.args;
    EXPECT_EQ(listing(), "fill\n") << c.args;  // no partial file, no temporary
  }
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
      {"mesh x.stl --weld-tolerance 1e308", "--weld-tolerance"},
      {fmt::format("run '{}' --machine thermal_gantry --max-machine-time nan", kProgram), "--max-machine-time"},
      {fmt::format("profile '{}' --tolerance nan", kSource + "/datasets/profiles/flange_plate.dxf"), "--tolerance"},
  };
  for (const Case& c : cases) {
    const Outcome r = machplan(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.flag)) << c.args;
    EXPECT_THAT(r.err, Not(HasSubstr("internal error"))) << c.args;
  }
}

TEST(BadOptions, ThePaperStrategyRefusesRotations) {
  const Outcome r = machplan(fmt::format("place '{}' --strategy paper --rotations 90", kScene));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("--rotations: the paper strategy searches the workpiece as given"));
  EXPECT_EQ(r.out, "");
}

TEST(BadOptions, TooManyRotationsAreRefusedWithTheLimit) {
  const Outcome r = machplan(fmt::format("place '{}' --rotations 0:360:0.05", kScene));
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("--rotations: range '0:360:0.05' has 7201 rotations; at most 3600"));
  EXPECT_EQ(r.out, "");
}

// A program of `n` short lines round a square, with a torch cycle every 50 moves: about 60 bytes
// of G-code and one move per line.
std::string long_program(int n) {
  std::string text = "G21 G90\nG0 X10 Y10\n";
  text.reserve(static_cast<std::size_t>(n) * 24);
  for (int k = 0; k < n; ++k) {
    if (k % 50 == 0) text += "M3\n";
    text += fmt::format("G1 X{} Y{} F1800\n", 10 + (k % 4 == 1 || k % 4 == 2) * 5, 10 + (k % 4 >= 2) * 5);
    if (k % 50 == 49) text += "M5\n";
  }
  return text + "M5\nM2\n";
}

TEST(SafeOutput, JsonOfALongProgramIsStreamedAndStaysValid) {
  TempDir dir;
  const int n = 20000;
  const std::string prog = dir.write("long.ngc", long_program(n));
  const Outcome r = machplan(fmt::format("program --json '{}'", prog));
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out.substr(0, 400);
  ASSERT_TRUE(j["moves"].is_array());
  EXPECT_GE(j["moves"].size(), static_cast<std::size_t>(n));
  EXPECT_EQ(j["moves"].back()["kind"], "torch_off");
  EXPECT_EQ(j["units"], "mm");
  EXPECT_TRUE(j["ends_with_program_end"].get<bool>());
  // A full disk part way through: exit 4 with the reason, and no claim of success.
  const Outcome full = machplan(fmt::format("program --json '{}'", prog), "/dev/full");
  EXPECT_EQ(full.code, 4);
  EXPECT_THAT(full.err, HasSubstr("No space left on device"));
}

TEST(SafeOutput, ProfileJsonOfALatin1LayerNameIsValidUtf8) {
  TempDir dir;
  // A 40 x 20 mm rectangle on layer "Kontur_\xe4u\xdfen" (Latin-1, as older CAD exports write it).
  std::string dxf = "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n";
  dxf += "0\nLWPOLYLINE\n5\nA1\n8\nKontur_\xe4u\xdf" "en\n90\n4\n70\n1\n";
  for (const auto& [x, y] : {std::pair{0, 0}, {40, 0}, {40, 20}, {0, 20}}) dxf += fmt::format("10\n{}\n20\n{}\n", x, y);
  dxf += "0\nENDSEC\n0\nEOF\n";
  const std::string path = dir.write("latin1.dxf", dxf);
  const Outcome r = machplan(fmt::format("profile --json '{}'", path));
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;  // parse() refuses invalid UTF-8
  ASSERT_EQ(j["contours"].size(), 1u);
  // Each invalid byte became U+FFFD; the rest of the name is kept, and stderr says so.
  EXPECT_EQ(j["contours"][0]["layer"].get<std::string>(), "Kontur_\xef\xbf\xbdu\xef\xbf\xbd" "en");
  EXPECT_THAT(r.err, HasSubstr("not valid UTF-8"));
  EXPECT_NEAR(j["contours"][0]["area_mm2"].get<double>(), 800.0, 1e-9);
}

TEST(RunLimits, ARunLongerThanTheMachineTimeLimitIsRefusedBeforeItStarts) {
  TempDir dir;
  struct Case {
    std::string name, args, says;
  };
  // 1e-6 mm/s is F0.00006 (mm/min): 10 mm take 1e7 s.
  const std::string slow = dir.write("slow.ngc", "G21 G90\nG0 X10 Y10\nM3\nG1 X20 F0.00006\nM5\nM2\n");
  // A helix of 9999 turns of radius 400 mm (Z is dropped on this machine: 25 km of circles).
  const std::string helix =
      dir.write("helix.ngc", "G21 G90\nG0 X1000 Y1400\nM3\nG2 X1000 Y1400 Z-1 I400 J0 P9999 F3000\nM5\nM2\n");
  // Machine files whose speed limit is a thousandth of a millimetre per second, and whose
  // acceleration is a millionth of a millimetre per second squared.
  std::ifstream in(kSource + "/datasets/machines/thermal_gantry.yaml");
  const std::string machine((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string text = machine;
    const auto at = text.find(from);
    return at == std::string::npos ? "<" + from + " not in the machine file>" : text.replace(at, from.size(), to);
  };
  const std::string crawl = dir.write("crawl.yaml", with("velocity_mm_per_s: 80", "velocity_mm_per_s: 0.001"));
  const std::string sluggish =
      dir.write("sluggish.yaml", with("acceleration_mm_per_s2: 500 ", "acceleration_mm_per_s2: 0.000001 "));
  const std::string triangle = kSource + "/datasets/parts/triangle_45.ngc";  // about 13 s of machine time
  const Case cases[] = {
      {"feed of 1e-6 mm/s", fmt::format("run '{}' --machine thermal_gantry", slow), "limit of 4.0 h (14400 s)"},
      {"enormous helix", fmt::format("run '{}' --machine thermal_gantry", helix), "limit of 4.0 h"},
      {"crawling machine", fmt::format("run '{}' --machine '{}'", triangle, crawl), "at least: every move at its feed"},
      {"tiny acceleration", fmt::format("run '{}' --machine '{}'", triangle, sluggish), "the planned motion plus"},
      {"a limit below the part's time",
       fmt::format("run '{}' --machine thermal_gantry --max-machine-time 5", triangle), "limit of 5.0 s"},
  };
  for (const Case& c : cases) {
    const Outcome r = machplan(c.args);
    EXPECT_EQ(r.code, 3) << c.name << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr("of machine time")) << c.name;
    EXPECT_THAT(r.err, HasSubstr(c.says)) << c.name << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr("raise the limit with --max-machine-time")) << c.name;
    EXPECT_EQ(r.out, "") << c.name;  // nothing ran, nothing reported as done
  }
  // Raised above the part's own time, the same run goes through.
  const Outcome ok = machplan(fmt::format("run '{}' --machine thermal_gantry --max-machine-time 600 --json", triangle));
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_FALSE(nlohmann::json::parse(ok.out, nullptr, false).is_discarded()) << ok.out;
  for (const std::string bad : {"nan", "0", "-1", "inf", "1e300"}) {
    const Outcome r = machplan(fmt::format("run '{}' --machine thermal_gantry --max-machine-time {}", triangle, bad));
    EXPECT_EQ(r.code, 2) << bad << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr("--max-machine-time")) << bad;
  }
}

}  // namespace
}  // namespace machplan
