// Placing a program on the machine: `run --origin`, Z words on the 2-axis machines, and the
// arcs those machines cannot make (solvers/motion/run.h, engine/motion/make_job.h).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli/json/run.h"
#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "solvers/motion/run.h"
#include "tests/support/cli_run.h"

namespace machplan {
namespace {

namespace fs = std::filesystem;

// A program written to a scratch file (run_program reads files).
class ProgramFile {
 public:
  ProgramFile(const std::string& name, const std::string& text)
      : path_(fs::temp_directory_path() / (std::to_string(::getpid()) + "_" + name)) {
    std::ofstream(path_) << text;
  }
  ~ProgramFile() { fs::remove(path_); }
  std::string path() const { return path_.string(); }

 private:
  fs::path path_;
};

// Part zero at the sheet corner: the lead-in starts at negative X and Y.
const char* kCornerPart = "G21 G90\nG0 X-4 Y-3\nM3 S1\nG1 X6 Y-3 F3000\nG1 X6 Y5\nM5\nM2\n";

TEST(GcodePlacement, OriginMovesTheProgramOntoTheMachine) {
  const ProgramFile f("corner.ngc", kCornerPart);
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  const motion::RunOutcome outside = motion::run_program(f.path(), o);
  EXPECT_EQ(outside.summary.status, Status::infeasible) << "X -4 lies outside the travel without an origin";
  EXPECT_NE(outside.summary.message.find("outside the travel"), std::string::npos) << outside.summary.message;
  o.origin_mm = Eigen::Vector2d(100, 200);
  const motion::RunOutcome run = motion::run_program(f.path(), o);
  EXPECT_EQ(run.origin_from, "given");
  EXPECT_DOUBLE_EQ(run.origin_mm.x(), 100);
  EXPECT_NEAR(run.programmed.start_mm.x(), 100, 1e-12);
  EXPECT_NEAR(run.programmed.start_mm.y(), 200, 1e-12);
  ASSERT_FALSE(run.programmed.stretches.empty());
  const auto& first = run.programmed.stretches.front().segments.front();
  EXPECT_NEAR(first.end.x(), 96, 1e-9);
  EXPECT_NEAR(first.end.y(), 197, 1e-9);
  EXPECT_NE(run.summary.full_report().find("X 100.000 Y 200.000 mm on the machine (given)"), std::string::npos)
      << run.summary.full_report();
  EXPECT_EQ(cli::to_json(run).at("origin_from"), "given");
  EXPECT_FALSE(run.faulted());
}

// A program off the machine is refused naming the end it crosses, by how much, against what
// travel, and the origin that puts the whole job on the machine (the flag that sets it).
TEST(GcodePlacement, AProgramOutsideTheTravelNamesTheLimitAndTheOriginThatFits) {
  test::Cli cli;
  const std::string corner = cli.write("corner.ngc", kCornerPart);
  const test::CliResult r = cli.run({"run", corner, "--machine", "xy_table"});
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("outside the travel of machine 'xy_table' (X 0 .. 400, Y 0 .. 350 mm): "
                                          "X reaches -4.000 mm, 4.000 mm below its low end and Y reaches -3.000 mm, "
                                          "3.000 mm below its low end."));
  EXPECT_THAT(r.err, ::testing::HasSubstr("The job spans X -4.000 .. 6.000, Y -3.000 .. 5.000 mm; it fits with the "
                                          "program's zero at X 4.000, Y 3.000 on the machine (it is at X 0.000, "
                                          "Y 0.000): move the zero there with --origin"));
  // The advice is right: there the job runs; and an origin too far the other way is advised back.
  EXPECT_EQ(cli.run({"run", corner, "--machine", "xy_table", "--origin", "4,3"}).code, 0);
  const test::CliResult high = cli.run({"run", corner, "--machine", "xy_table", "--origin", "397,3"});
  EXPECT_EQ(high.code, 3);
  EXPECT_THAT(high.err, ::testing::HasSubstr("X reaches 403.000 mm, 3.000 mm beyond its high end"));
  EXPECT_THAT(high.err, ::testing::HasSubstr("program's zero at X 394.000, Y 3.000 on the machine (it is at X 397.000, Y 3.000)"));
  // A job larger than the travel has no origin to advise.
  const std::string wide = cli.write("wide.ngc", "G21 G90\nG0 X0 Y0\nM3 S1\nG1 X500 Y0 F3000\nM5\nM2\n");
  const test::CliResult big = cli.run({"run", wide, "--machine", "xy_table"});
  EXPECT_EQ(big.code, 3);
  EXPECT_THAT(big.err, ::testing::HasSubstr("X reaches 500.000 mm, 100.000 mm beyond its high end"));
  EXPECT_THAT(big.err, ::testing::HasSubstr("larger than the travel, so no program origin fits it"));
  EXPECT_THAT(big.err, ::testing::Not(::testing::HasSubstr("--origin")));
}

TEST(GcodePlacement, ZWordsAreDroppedWithOneWarningUnlessStrict) {
  const ProgramFile f("with_z.ngc", "G21\nG0 X10 Y10\nG0 Z5\nG1 Z-1 F100\nM3 S1\nG1 X20 F3000\nG1 Z3\nM5\nM2\n");
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  const motion::RunOutcome run = motion::run_program(f.path(), o);
  ASSERT_EQ(run.warnings.size(), 1u);
  EXPECT_NE(run.warnings[0].find("with_z.ngc:3: Z words dropped"), std::string::npos) << run.warnings[0];
  EXPECT_EQ(run.origin_from, "none");
  o.strict_z = true;
  try {
    motion::run_program(f.path(), o);
    ADD_FAILURE() << "--strict-z must refuse a program whose Z moves";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(std::string(e.what()).find("Z is not programmable"), std::string::npos) << e.what();
  }
}

TEST(GcodePlacement, LenientEndAndParametersReachTheRun) {
  const ProgramFile f("grbl.ngc", "G21\nF#<_hal[plasmac.cut-feed-rate]>\nG0 X10 Y10\nM3 $0 S1\nG1 X20\nM5 $0\n");
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  o.gcode.params["_hal[plasmac.cut-feed-rate]"] = 3000;
  EXPECT_THROW(motion::run_program(f.path(), o), InputError) << "no M2: refused as rs274 does";
  o.gcode.require_program_end = false;
  const motion::RunOutcome run = motion::run_program(f.path(), o);
  ASSERT_EQ(run.warnings.size(), 1u);
  EXPECT_NE(run.warnings[0].find("no end"), std::string::npos);
  ASSERT_GE(run.programmed.stretches.size(), 2u);
  EXPECT_NEAR(run.programmed.stretches[1].feed_mm_per_s.front(), 50, 1e-9);
}

TEST(GcodePlacement, MachineFileGivesOriginParametersAndSpindles) {
  // The bundled gantry reads QtPlasmaC's cut feed and $1 (scribe) from its file.
  const ProgramFile f("qtplasmac.ngc",
                      "G21\nF#<_hal[plasmac.cut-feed-rate]>\nG0 X-10 Y-10\nM3 $1 S1\nG1 X10\nM5 $1\nM2\n");
  std::string yaml;
  {
    std::ifstream in(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
    std::stringstream ss;
    ss << in.rdbuf();
    yaml = ss.str();
  }
  const std::string from = "value: 4000";
  ASSERT_NE(yaml.find(from), std::string::npos);
  yaml.replace(yaml.find(from), from.size(), "value: 1800");
  const ProgramFile machine("placed_gantry.yaml", yaml + "origin_mm: [500, 400]\n");
  motion::RunOptions o;
  o.session.machine = machine.path();
  const motion::RunOutcome run = motion::run_program(f.path(), o);
  EXPECT_EQ(run.origin_from, "machine file");
  EXPECT_NEAR(run.programmed.start_mm.x(), 500, 1e-12);
  ASSERT_GE(run.programmed.stretches.size(), 2u);
  EXPECT_NEAR(run.programmed.stretches[1].feed_mm_per_s.front(), 30, 1e-9);  // 1800 mm/min
  o.gcode.params["_hal[plasmac.cut-feed-rate]"] = 2400;                      // --param wins
  o.origin_mm = Eigen::Vector2d(600, 600);                                   // --origin wins
  const motion::RunOutcome again = motion::run_program(f.path(), o);
  EXPECT_EQ(again.origin_from, "given");
  EXPECT_NEAR(again.programmed.stretches[1].feed_mm_per_s.front(), 40, 1e-9);
}

TEST(GcodePlacement, WordsTheMachineIgnoresAreNotedOncePerKind) {
  const ProgramFile f("notes.ngc", "G21 F1000\nM8\nM52 P1\nG0 X10 Y10\nM3 S1\nG1 X20\nM9\nM5\nM2\n");
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  const motion::RunOutcome run = motion::run_program(f.path(), o);
  EXPECT_TRUE(run.warnings.empty());
  ASSERT_EQ(run.notes.size(), 2u);
  EXPECT_NE(run.notes[0].find("notes.ngc:2: coolant (2 in the program) ignored"), std::string::npos) << run.notes[0];
  EXPECT_NE(run.notes[1].find("notes.ngc:3: feed_override"), std::string::npos) << run.notes[1];
}

TEST(GcodePlacement, ArcsOutsideTheXyPlaneAreRefusedByName) {
  const Program p = read_gcode("G21 F100\nG18 G2 X10 Z0 I5 K0\nM2\n", "xz.ngc");
  try {
    motion::make_job(p);
    ADD_FAILURE() << "an XZ arc cannot run on an XY machine";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(std::string(e.what()).find("arc in the XZ plane (G18)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace machplan
