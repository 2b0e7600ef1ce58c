// machplan run --materials / --material: a QtPlasmaC material file and a program that changes
// material as QtPlasmaC programs do, the materials in the report and the JSON, and bad files
// and flags named with exit 2. Our own program and file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;

const char* kMaterials = "[MATERIAL_NUMBER_1]\nNAME = Thin\nKERF_WIDTH = 1\nPIERCE_HEIGHT = 3\nPIERCE_DELAY = 0.2\n"
                         "CUT_HEIGHT = 1\nCUT_SPEED = 3000\n\n[MATERIAL_NUMBER_2]\nNAME = Thick\nKERF_WIDTH = 2\n"
                         "PIERCE_HEIGHT = 4\nPIERCE_DELAY = 0.8\nCUT_HEIGHT = 1.5\nCUT_SPEED = 1500\n";

const char* kProgram = "G21 G64 P0.1\nM52 P1\n"
                       "M190 P2\nM66 P3 L3 Q1\nF#<_hal[plasmac.cut-feed-rate]>\nG0 X20 Y20\nM3 $0 S1\nG1 X80\nM5 $0\n"
                       "G0 X20 Y40\nM3 $0 S1\nG1 X80\nM5 $0\n"
                       "M190 P-1\nG0 X20 Y60\nM3 $0 S1\nG1 X80\nM5 $0\nG0 X0 Y0\nM2\n";

// Runs our program with our material file and `flags`.
test::CliResult run_parts(const test::Cli& cli, const std::string& flags) {
  const std::string mats = cli.write("mats.cfg", kMaterials);
  const std::string prog = cli.write("parts.ngc", kProgram);
  return cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + mats + "' --origin 100,100 " + flags);
}

TEST(MaterialsCli, CutsRunWithTheirMaterials) {
  test::Cli cli;
  const test::CliResult r = run_parts(cli, "--material 1 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["materials"].size(), 2u);
  ASSERT_EQ(j["cuts"].size(), 3u);
  // Two cuts in material 2 (selected by M190 P2), the last in the default (--material 1).
  const auto number_of_cut = [&](std::size_t i) { return j["materials"][j["cuts"][i]["material"].get<int>()]["number"]; };
  EXPECT_EQ(number_of_cut(0), 2);
  EXPECT_EQ(number_of_cut(1), 2);
  EXPECT_EQ(number_of_cut(2), 1);
  EXPECT_DOUBLE_EQ(j["materials"][0]["kerf_mm"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(j["materials"][0]["cut_feed_mm_per_min"].get<double>(), 1500.0);
  // No note calls M190 or M66 ignored; the report lists the materials with their kerf.
  const test::CliResult text = run_parts(cli, "");
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, ::testing::Not(HasSubstr("user_m_code")));
  EXPECT_THAT(text.out, ::testing::Not(HasSubstr("wait_input")));
  EXPECT_THAT(text.out, HasSubstr("material 2 'Thick': cut feed 1500 mm/min"));
  EXPECT_THAT(text.out, HasSubstr("kerf 2.00 mm"));
}

// --kerf material: each closed cut by its material's KERF_WIDTH.
TEST(MaterialsCli, KerfMaterialCompensatesEachCutByItsMaterialsKerf) {
  test::Cli cli;
  const std::string mats = cli.write("mats.cfg", kMaterials);
  // A 40 mm square in material 2 (kerf 2) and one in material 1 (kerf 1).
  const std::string prog = cli.write("squares.ngc",
                                     "G21 G90\nF#<_hal[plasmac.cut-feed-rate]>\n"
                                     "M190 P2\nG0 X0 Y0\nM3 $0 S1\nG1 X40\nG1 Y40\nG1 X0\nG1 Y0\nM5 $0\n"
                                     "M190 P1\nG0 X60 Y0\nM3 $0 S1\nG1 X100\nG1 Y40\nG1 X60\nG1 Y0\nM5 $0\nM2\n");
  const test::CliResult r = cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + mats +
                                    "' --origin 100,100 --kerf material --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kerf"]["from_materials"], true);
  EXPECT_EQ(j["kerf"]["compensated"], 2);
  // The report says which kerf each material cut with (the offsets per cut: tests/motion/kerf_test.cpp).
  const test::CliResult text = cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + mats +
                                       "' --origin 100,100 --kerf material");
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("kerf of each cut's material: 2 of 2 closed cuts compensated"));
  EXPECT_THAT(text.out, HasSubstr("kerf 2.00 mm (compensated)"));
}

TEST(MaterialsCli, BadFilesAndFlagsExitTwoNamingWhere) {
  test::Cli cli;
  const std::string prog = cli.write("parts.ngc", kProgram);
  const std::string bad = cli.write("bad.cfg", "[MATERIAL_NUMBER_2]\nPIERCE_HEIGHT = 4\nCUT_SPEED = fast\n");
  const test::CliResult r = cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + bad + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr("bad.cfg:3: CUT_SPEED must be a number"));
  const std::string mats = cli.write("mats.cfg", kMaterials);
  const std::string other = cli.write("other.ngc", "M190 P9\nG0 X10 Y10\nM2\n");
  const test::CliResult missing = cli.run("run '" + other + "' --machine thermal_gantry --materials '" + mats + "'");
  EXPECT_EQ(missing.code, 2);
  EXPECT_THAT(missing.err, HasSubstr("other.ngc:1: M190 P9: material 9 is not in"));
  const test::CliResult no_file = cli.run("run '" + prog + "' --machine thermal_gantry --material 1");
  EXPECT_EQ(no_file.code, 2);
  EXPECT_THAT(no_file.err, HasSubstr("--material"));
  const test::CliResult unknown = cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + mats + "' --material 5");
  EXPECT_EQ(unknown.code, 2);
  EXPECT_THAT(unknown.err, HasSubstr("--material: material 5 is not in"));
}

TEST(MaterialsCli, ProgramsThatChangeMaterialKeepTheirOrder) {
  test::Cli cli;
  const test::CliResult r = run_parts(cli, "--material 1 --order nearest");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("parts.ngc:3: cuts left in program order"));
}

// A cut chart's volts far from the machine's own arc (its 70 V base and 10 V/mm): the simulated
// arc takes the chart in force as its physics, so THC holds each cut at that material's height.
// Before, a chart of 130 V at 1 mm held the torch 5 mm too high: the machine's arc reads 130 V at
// 6 mm.
TEST(MaterialsCli, THCHoldsEachCutAtItsChartsHeight) {
  test::Cli cli;
  const std::string mats = cli.write("volts.cfg",
                                     "[MATERIAL_NUMBER_1]\nNAME = High volts\nPIERCE_HEIGHT = 3\nPIERCE_DELAY = 0.2\n"
                                     "CUT_HEIGHT = 1\nCUT_SPEED = 2000\nCUT_VOLTS = 130\nTHC = 1\n\n"
                                     "[MATERIAL_NUMBER_2]\nNAME = Low volts\nPIERCE_HEIGHT = 4\nPIERCE_DELAY = 0.2\n"
                                     "CUT_HEIGHT = 2\nCUT_SPEED = 2000\nCUT_VOLTS = 95\nTHC = 1\n");
  const std::string prog = cli.write("volts.ngc", "G21\nM190 P1\nM66 P3 L3 Q1\nF#<_hal[plasmac.cut-feed-rate]>\n"
                                                  "G0 X0 Y0\nM3 $0 S1\nG1 X300\nG1 Y100\nM5 $0\n"
                                                  "M190 P2\nM66 P3 L3 Q1\nF#<_hal[plasmac.cut-feed-rate]>\n"
                                                  "G0 X0 Y150\nM3 $0 S1\nG1 X300\nG1 Y250\nM5 $0\nG0 X0 Y0\nM2\n");
  const test::CliResult r =
      cli.run("run '" + prog + "' --machine thermal_gantry --materials '" + mats + "' --origin 100,100 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["cuts"].size(), 2u);
  for (const auto& cut : j["cuts"]) {
    ASSERT_TRUE(cut["thc"].is_object()) << cut.dump();
    EXPECT_TRUE(cut["complete"].get<bool>());
    EXPECT_LT(cut["thc"]["max_height_error_mm"].get<double>(), 0.1) << cut.dump();
  }
  EXPECT_DOUBLE_EQ(j["cuts"][0]["thc"]["target_v"].get<double>(), 130.0);
  EXPECT_DOUBLE_EQ(j["cuts"][1]["thc"]["target_v"].get<double>(), 95.0);
}

}  // namespace
}  // namespace machplan
