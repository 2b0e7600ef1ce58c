// `machplan nest`: DXF parts nested on sheets, the nest certified, every copy's transform in
// the JSON checkable from the drawings alone; copies that fit nowhere and bad flags named.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"
#include "tests/support/rs274.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::string dxf(const std::string& entities) {
  return "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n" + entities + "0\nENDSEC\n0\nEOF\n";
}
std::string circle(double x, double y, double r) {
  return "0\nCIRCLE\n8\nCUT\n10\n" + std::to_string(x) + "\n20\n" + std::to_string(y) + "\n40\n" + std::to_string(r) + "\n";
}
// A closed rectangle as one LWPOLYLINE.
std::string rect(double x0, double y0, double x1, double y1) {
  std::string s = "0\nLWPOLYLINE\n8\nCUT\n90\n4\n70\n1\n";
  for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}})
    s += "10\n" + std::to_string(x) + "\n20\n" + std::to_string(y) + "\n";
  return s;
}
std::string text_of(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
// An L-shaped bracket, 200 x 150 with legs 60 wide, and a hole in each corner.
const std::string kBracket = dxf(
    "0\nLWPOLYLINE\n8\nCUT\n90\n6\n70\n1\n10\n0\n20\n0\n10\n200\n20\n0\n10\n200\n20\n60\n10\n60\n20\n60\n10\n60\n20\n150\n10\n0\n20\n150\n" +
    circle(30, 30, 8) + circle(170, 30, 8) + circle(30, 120, 8));

TEST(NestCli, PartsAreNestedCertifiedAndEachCopysTransformPutsItOnItsSheet) {
  test::TempDir dir;
  const std::string bracket = dir.write("bracket.dxf", kBracket);
  const std::string disc = dir.write("disc.dxf", dxf(circle(0, 0, 40) + circle(0, 0, 10)));
  const test::CliResult r = test::Cli().run("nest '" + bracket + "':5 '" + disc + "':6 --sheet 800x400 --spacing 6 --margin 10 --time 0.05 --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["certified"], true) << j["violations"];
  EXPECT_EQ(j["spacing_mm"], 6.0);
  ASSERT_EQ(j["placements"].size(), 11u);
  ASSERT_EQ(j["sheets"].size(), 1u);
  const double used = j["sheets"][0]["used_length_mm"].get<double>();
  // The discs' centres (the drawing's origin) land inside the usable area, at least 40 mm in.
  double right = 0.0;
  for (const auto& p : j["placements"]) {
    const double x = p["translate_mm"][0].get<double>(), y = p["translate_mm"][1].get<double>();
    if (p["file"].get<std::string>().find("disc") == std::string::npos) continue;
    EXPECT_GE(x, 50.0 - 1e-6);
    EXPECT_GE(y, 50.0 - 1e-6);
    EXPECT_LE(y, 350.0 + 1e-6);
    right = std::max(right, x + 40.0);
  }
  EXPECT_LE(right, used + 1e-6) << "the used length covers every part";
  const double area = 5 * (200 * 60 + 60 * 90 - 3 * M_PI * 64) + 6 * M_PI * (1600 - 100);
  EXPECT_NEAR(j["sheets"][0]["utilisation"].get<double>(), area / (used * 400), 1e-9);
  // The report for people says the same.
  const test::CliResult text = test::Cli().run("nest '" + bracket + "':5 '" + disc + "':6 --sheet 800x400 --time 0.05");
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("11 copies placed on 1 sheet(s)"));
  EXPECT_THAT(text.out, HasSubstr("certified"));
}

// The sheet's program: a ring with a disc nested in its hole; the disc is cut before the hole
// that holds it (or it would drop with the slug), and the program runs on the simulated gantry.
TEST(NestCli, TheSheetsProgramCutsAPartInAHoleBeforeTheHoleAndRunsOnTheGantry) {
  test::TempDir dir;
  const std::string ring = dir.write("ring.dxf", dxf(circle(0, 0, 100) + circle(0, 0, 60)));
  const std::string disc = dir.write("disc.dxf", dxf(circle(0, 0, 40)));
  const std::string out = (dir.path() / "programs").string();
  const test::CliResult r =
      test::Cli().run("nest '" + ring + "' '" + disc + "' --sheet 600x300 --time 0 --out '" + out + "' --machine thermal_gantry --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["sheets"].size(), 1u);
  const std::string program = j["sheets"][0]["program"];
  const std::string picture = j["sheets"][0]["picture"];
  EXPECT_GT(std::filesystem::file_size(picture), 1000u) << "the sheet's picture";
  // The disc in the ring's hole: its centre within 14 mm of the ring's (60 - 40 - 6).
  const auto& p = j["placements"];
  ASSERT_EQ(p.size(), 2u);
  const double dx = p[0]["translate_mm"][0].get<double>() - p[1]["translate_mm"][0].get<double>();
  const double dy = p[0]["translate_mm"][1].get<double>() - p[1]["translate_mm"][1].get<double>();
  EXPECT_LE(std::hypot(dx, dy), 14.0 + 1e-6) << "the disc went into the hole";
  // Three cuts: the disc (radius 40), the hole (60), the outline (100), in that order.
  const test::CliResult read = test::Cli().run("program '" + program + "' --json");
  ASSERT_EQ(read.code, 0) << read.err;
  std::vector<double> radii;
  const nlohmann::json moves = nlohmann::json::parse(read.out)["moves"];
  for (const auto& m : moves) {
    if (m["kind"] != "arc") continue;
    const double radius = std::hypot(m["end"][0].get<double>() - m["center"][0].get<double>(),
                                     m["end"][1].get<double>() - m["center"][1].get<double>());
    if (radius <= 5.0 + 1e-6) continue;  // a lead-in's quarter circle
    if (radii.empty() || std::abs(radii.back() - radius) > 1e-3) radii.push_back(radius);
  }
  ASSERT_EQ(radii.size(), 3u) << read.out.substr(0, 1000);
  EXPECT_NEAR(radii[0], 40.0, 1e-3);
  EXPECT_NEAR(radii[1], 60.0, 1e-3);
  EXPECT_NEAR(radii[2], 100.0, 1e-3);
  const test::CliResult run = test::Cli().run("run '" + program + "' --machine thermal_gantry --json");
  ASSERT_EQ(run.code, 0) << run.err;
  const nlohmann::json rj = nlohmann::json::parse(run.out);
  EXPECT_EQ(rj["status"], "done");
  EXPECT_EQ(rj["cuts"].size(), 3u);
  EXPECT_LT(rj["max_contour_error_mm"].get<double>(), 0.1);
  // The sheet's figures: three pierces, the cut length (the three circles and their lead-ins,
  // quarter circles of 5 mm at most), and the cycle planned on the machine, which the run takes.
  const auto& sheet = j["sheets"][0];
  EXPECT_EQ(sheet["pierces"], 3);
  const double circles = 2 * M_PI * (40 + 60 + 100);
  EXPECT_GT(sheet["cut_length_mm"].get<double>(), circles);
  EXPECT_LT(sheet["cut_length_mm"].get<double>(), circles + 3 * 5.0 * M_PI / 2 + 1e-6);
  EXPECT_NEAR(rj["cycle_time_s"].get<double>(), sheet["cycle_s"].get<double>(), 0.02 * sheet["cycle_s"].get<double>());
}

// QtPlasmaC's words (the material, its feed, the hole rules) and GRBL's dialect: each sheet
// program runs to completion on the simulated gantry as written.
TEST(NestCli, TheProgramsCarryQtPlasmaCsWordsOrGrblsAndRunOnTheGantry) {
  test::TempDir dir;
  const std::string plate = dir.write("plate.dxf", dxf(rect(0, 0, 120, 80) + circle(30, 40, 8) + circle(90, 40, 20)));
  const std::string qt = (dir.path() / "qt").string(), grbl = (dir.path() / "grbl").string();
  const test::CliResult r = test::Cli().run("nest '" + plate + "':3 --sheet 600x300 --time 0 --out '" + qt +
                                            "' --machine thermal_gantry --materials datasets/materials/thermal_gantry_material.cfg"
                                            " --material 1 --holes 2 --kerf 1.5 --overcut 2 --lead-out 2 --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const std::string program = nlohmann::json::parse(r.out)["sheets"][0]["program"];
  const std::string text = text_of(program);
  for (const char* word : {"M190 P1", "M66 P3 L3 Q1", "#<holes> = 2", "F#<_hal[plasmac.cut-feed-rate]>", "kerf 1.5 mm compensated"})
    EXPECT_THAT(text, HasSubstr(word));
  const test::CliResult run = test::Cli().run("run '" + program + "' --machine thermal_gantry --materials datasets/materials/thermal_gantry_material.cfg --json");
  ASSERT_EQ(run.code, 0) << run.err;
  EXPECT_EQ(nlohmann::json::parse(run.out)["status"], "done");
  const test::CliResult g = test::Cli().run("nest '" + plate + "':3 --sheet 600x300 --time 0 --out '" + grbl +
                                            "' --dialect grbl --machine thermal_gantry --json");
  ASSERT_EQ(g.code, 0) << g.err << g.out;
  const std::string gp = nlohmann::json::parse(g.out)["sheets"][0]["program"];
  EXPECT_THAT(text_of(gp), Not(HasSubstr("G91.1")));
  const test::CliResult grun = test::Cli().run("run '" + gp + "' --machine thermal_gantry --dialect grbl --json");
  ASSERT_EQ(grun.code, 0) << grun.err;
  EXPECT_EQ(nlohmann::json::parse(grun.out)["status"], "done");
  // What GRBL cannot say is refused before the search, naming the flag.
  const test::CliResult bad = test::Cli().run("nest '" + plate + "' --sheet 600x300 --out '" + grbl + "' --dialect grbl --holes 2");
  EXPECT_EQ(bad.code, 2);
  EXPECT_THAT(bad.err, HasSubstr("--holes"));
}

// A job file: two sheet sizes filled in order, per-part rotations, a must-nest part first, and
// drawings found beside the job file.
TEST(NestCli, AJobFileGivesTheSheetsAndEachPartsQuantityRotationsAndPriority) {
  test::TempDir dir;
  dir.write("bracket.dxf", kBracket);
  dir.write("disc.dxf", dxf(circle(0, 0, 40)));
  const std::string job = dir.write("job.yaml",
                                    "sheets:\n"
                                    "  - {width_mm: 450, height_mm: 300, margin_mm: 5}\n"
                                    "  - {width_mm: 800, height_mm: 400, count: 2}\n"
                                    "spacing_mm: 8\n"
                                    "parts:\n"
                                    "  - {file: disc.dxf, quantity: 6, priority: 2}\n"
                                    "  - {file: bracket.dxf, quantity: 4, rotations: [0, 180], mirror: true, priority: 1}\n");
  const test::CliResult r = test::Cli().run("nest '" + job + "' --time 0.05 --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["certified"], true) << j["violations"];
  EXPECT_EQ(j["spacing_mm"], 8.0);
  ASSERT_EQ(j["placements"].size(), 10u);
  ASSERT_FALSE(j["sheets"].empty());
  EXPECT_EQ(j["sheets"][0]["sheet"], 1) << "the first sheet is filled first";
  EXPECT_EQ(j["sheets"][0]["margin_mm"], 5.0);
  for (const auto& p : j["placements"])
    if (p["file"].get<std::string>().find("bracket") != std::string::npos) {
      const double deg = p["rotation_deg"].get<double>();
      EXPECT_TRUE(deg == 0.0 || deg == 180.0) << deg;
    }
  // The brackets (priority 1) were placed before the discs: the first sheet holds brackets.
  bool bracket_on_first = false;
  for (const auto& p : j["placements"])
    bracket_on_first |= p["sheet"] == 1 && p["file"].get<std::string>().find("bracket") != std::string::npos;
  EXPECT_TRUE(bracket_on_first);
  // A remnant drawing that is missing or does not close, an unknown key, and --sheet beside a
  // job file are refused.
  const std::string remnant = dir.write("remnant.yaml", "sheets:\n  - {outline: r.dxf}\nparts:\n  - {file: disc.dxf}\n");
  const test::CliResult rem = test::Cli().run("nest '" + remnant + "'");
  EXPECT_EQ(rem.code, 2);
  EXPECT_THAT(rem.err, HasSubstr("remnant.yaml:2"));
  EXPECT_THAT(rem.err, HasSubstr("r.dxf"));
  dir.write("r.dxf", dxf("0\nLWPOLYLINE\n8\nCUT\n90\n3\n70\n0\n10\n0\n20\n0\n10\n500\n20\n0\n10\n500\n20\n300\n"));
  const test::CliResult open = test::Cli().run("nest '" + remnant + "'");
  EXPECT_EQ(open.code, 2);
  EXPECT_THAT(open.err, HasSubstr("remnant.yaml:2"));
  EXPECT_THAT(open.err, HasSubstr("r.dxf"));
  // A `program:` section sets the program flags; a flag on the command line wins; a bad value is
  // refused at its line.
  const std::string with_program = dir.write("program.yaml", "sheets:\n  - {width_mm: 800, height_mm: 400}\nparts:\n"
                                                              "  - {file: disc.dxf, quantity: 2}\nprogram:\n  kerf: 1.5\n"
                                                              "  holes: 2\n  lead-in-shape: line\n");
  const std::string out = (dir.path() / "programmed").string();
  ASSERT_EQ(test::Cli().run("nest '" + with_program + "' --time 0 --out '" + out + "' --kerf 2").code, 0);
  const std::string program = text_of(out + "/sheet_1.ngc");
  EXPECT_THAT(program, HasSubstr("#<holes> = 2"));
  EXPECT_THAT(program, HasSubstr("lead-in line"));
  EXPECT_THAT(program, HasSubstr("kerf 2 mm compensated")) << "the flag, not the job file's 1.5";
  const std::string bad_program = dir.write("bad_program.yaml", "sheets:\n  - {width_mm: 800, height_mm: 400}\nparts:\n"
                                                                "  - {file: disc.dxf}\nprogram:\n  kerf: 100\n");
  const test::CliResult bp = test::Cli().run("nest '" + bad_program + "' --time 0");
  EXPECT_EQ(bp.code, 2);
  EXPECT_THAT(bp.err, HasSubstr("bad_program.yaml:6"));
  EXPECT_THAT(bp.err, HasSubstr("program.kerf"));
  const std::string unknown = dir.write("unknown.yaml", "sheets:\n  - {width_mm: 100, height_mm: 100}\nparts:\n  - {file: disc.dxf, qty: 2}\n");
  const test::CliResult unk = test::Cli().run("nest '" + unknown + "'");
  EXPECT_EQ(unk.code, 2);
  EXPECT_THAT(unk.err, HasSubstr("unknown.yaml:4"));
  EXPECT_THAT(unk.err, HasSubstr("qty"));
  const test::CliResult both = test::Cli().run("nest '" + job + "' --sheet 100x100");
  EXPECT_EQ(both.code, 2);
  EXPECT_THAT(both.err, HasSubstr("--sheet: the job file lists the sheets"));
}

// The bundled remnant job: the L-shaped offcut is filled first, every part on it inside its
// outline and clear of its cut-outs (the certificate), the rest on a whole sheet.
TEST(NestCli, ARemnantIsFilledInsideItsOutlineAndClearOfItsCutOuts) {
  test::TempDir dir;
  const std::string out = (dir.path() / "rem").string();
  const test::CliResult r = test::Cli().run("nest datasets/nesting/remnant_job.yaml --time 0.3 --out '" + out + "' --json");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["certified"], true) << j["violations"];
  ASSERT_EQ(j["sheets"].size(), 2u);
  const auto& rem = j["sheets"][0];
  EXPECT_THAT(rem["remnant"].get<std::string>(), HasSubstr("remnant.dxf"));
  EXPECT_EQ(rem["width_mm"], 900.0);
  EXPECT_EQ(rem["height_mm"], 600.0);
  EXPECT_EQ(rem["drawn_at_mm"][0], 100.0);
  EXPECT_EQ(rem["drawn_at_mm"][1], 50.0);
  EXPECT_GE(rem["parts"].get<int>(), 8) << "most of the job fits on the offcut";
  EXPECT_EQ(j["strip_search"]["note"], "") << "the last sheet, a whole one, is searched";
  EXPECT_THAT(text_of(rem["program"]), HasSubstr("remnant.dxf"));
}

TEST(NestCli, TheBundledJobNestsItsProfilesCertifiedOnOneSheet) {
  const test::CliResult r = test::Cli().run("nest datasets/nesting/sheet_job.yaml --time 0 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["certified"], true) << j["violations"];
  EXPECT_EQ(j["placements"].size(), 22u);
  EXPECT_TRUE(j["unplaced"].empty());
  EXPECT_EQ(j["sheets"].size(), 1u);
}

TEST(NestCli, ACopyThatFitsNowhereIsNamedTheRestIsNestedAndTheExitIs3) {
  test::TempDir dir;
  const std::string bracket = dir.write("bracket.dxf", kBracket);
  const std::string wide = dir.write("wide.dxf", dxf(circle(0, 0, 300)));
  const test::CliResult r = test::Cli().run("nest '" + bracket + "':2 '" + wide + "' --sheet 500x400 --time 0.05 --json");
  EXPECT_EQ(r.code, 3) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["placements"].size(), 2u);
  ASSERT_EQ(j["unplaced"].size(), 1u);
  EXPECT_THAT(j["unplaced"][0]["file"].get<std::string>(), HasSubstr("wide.dxf"));
  EXPECT_THAT(j["unplaced"][0]["reason"].get<std::string>(), HasSubstr("600.0 x 600.0 mm: larger than the sheet's usable area"));
}

// LinuxCNC's rs274 reads a sheet's program (arc leads, overcut, the kerf compensated, a disc in
// the bracket's corner) to the feed moves machplan reads from it. QtPlasmaC's words need its
// M-code files, which rs274 alone lacks; those programs run on the gantry above.
TEST(NestCli, Rs274ReadsASheetsProgramToTheSameMoves) {
  test::TempDir dir;
  const std::string bracket = dir.write("bracket.dxf", kBracket);
  const std::string disc = dir.write("disc.dxf", dxf(circle(0, 0, 40) + circle(0, 0, 10)));
  const std::string out = (dir.path() / "sheets").string();
  const test::CliResult r = test::Cli().run("nest '" + bracket + "':3 '" + disc + "':4 --sheet 800x400 --time 0 --out '" + out +
                                            "' --kerf 1.5 --overcut 2 --lead-out 2 --lead-out-shape arc --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string program = nlohmann::json::parse(r.out)["sheets"][0]["program"];
  const test::FeedEnds ours = test::machplan_feeds(program);
  EXPECT_GT(ours.size(), 40u);
  test::expect_same_feeds(test::rs274_feeds(program), ours);
}

// The spacing: --spacing, else the job file's, else the kerf plus the clearance (the torch paths
// of neighbouring parts then keep the clearance), else 6 mm. What only a job file gives is
// refused beside one, not silently dropped.
TEST(NestCli, TheSpacingIsTheFlagsElseTheJobsElseTheKerfPlusTheClearance) {
  test::TempDir dir;
  const std::string disc = dir.write("disc.dxf", dxf(circle(0, 0, 40)));
  const auto spacing = [](const std::string& args) {
    const test::CliResult r = test::Cli().run("nest " + args + " --time 0 --json");
    EXPECT_EQ(r.code, 0) << args << ": " << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
    EXPECT_EQ(j.is_discarded() ? false : j["certified"].get<bool>(), true) << args;
    return j.is_discarded() ? -1.0 : j["spacing_mm"].get<double>();
  };
  const std::string parts = "'" + disc + "':3 --sheet 400x200";
  EXPECT_EQ(spacing(parts), 6.0);
  EXPECT_EQ(spacing(parts + " --kerf 1.5"), 3.5);
  EXPECT_EQ(spacing(parts + " --kerf 1.5 --clearance 3"), 4.5);
  EXPECT_EQ(spacing(parts + " --kerf 1.5 --spacing 10"), 10.0);
  const std::string sheets = "sheets: [{width_mm: 400, height_mm: 200}]\nparts: [{file: disc.dxf, quantity: 3}]\n";
  const std::string kerf_only = dir.write("kerf.yaml", sheets + "program: {kerf: 2}\n");
  const std::string both = dir.write("both.yaml", sheets + "spacing_mm: 8\nprogram: {kerf: 2}\n");
  EXPECT_EQ(spacing("'" + kerf_only + "'"), 4.0);
  EXPECT_EQ(spacing("'" + both + "'"), 8.0);
  EXPECT_EQ(spacing("'" + both + "' --spacing 5"), 5.0);
  for (const std::string flag : {"--margin 5", "--rotations none", "--split"}) {
    const test::CliResult r = test::Cli().run("nest '" + both + "' " + flag + " --time 0");
    EXPECT_EQ(r.code, 2) << flag;
    EXPECT_THAT(r.err, HasSubstr(flag.substr(0, flag.find(' ')) + ": the job file gives each ")) << r.err;
  }
}

TEST(NestCli, BadFlagsAndDrawingsAreRefusedNamingThem) {
  test::TempDir dir;
  const std::string bracket = dir.write("bracket.dxf", kBracket);
  const std::string two = dir.write("two.dxf", dxf(circle(0, 0, 10) + circle(100, 0, 10)));
  const auto refused = [&](const std::string& args, const std::string& what) {
    const test::CliResult r = test::Cli().run("nest " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.out;
    EXPECT_THAT(r.err, HasSubstr(what)) << args;
  };
  refused("'" + bracket + "' --sheet 800", "--sheet: '800' is not WIDTHxHEIGHT[:COUNT]");
  refused("'" + bracket + "' --sheet 800x400:0", "--sheet");
  refused("'" + bracket + "':0 --sheet 800x400", "the quantity after the colon must be 1 .. 100000");
  refused("'" + bracket + "' --sheet 800x400 --rotations 0,x", "--rotations");
  std::string many = "0";  // 361 rotations: one more than a part may list
  for (int k = 0; k < 360; ++k) many.append(",").append(std::to_string(k)).append(".5");
  refused("'" + bracket + "' --sheet 800x400 --rotations " + many, "--rotations: lists 361 rotations; at most 360");
  const std::string many_job = dir.write("many.yaml", "sheets: [{width_mm: 800, height_mm: 400}]\nparts:\n  - {file: bracket.dxf, rotations: [" + many + "]}\n");
  refused("'" + many_job + "'", "many.yaml:3");
  refused("'" + bracket + "' --sheet 800x400 --spacing -1", "--spacing");
  refused("'" + bracket + "' --sheet 800x400 --spacing 900", "--spacing: a spacing of 900 mm is longer than every sheet");
  const std::string wide = dir.write("wide.yaml", "sheets: [{width_mm: 800, height_mm: 400}]\nspacing_mm: 850\nparts: [{file: bracket.dxf}]\n");
  refused("'" + wide + "'", "wide.yaml:2");
  refused("'" + bracket + "' --sheet 100x100 --margin 60", "leaves no usable area");
  refused("'" + two + "' --sheet 800x400", "holds 2 outer contours");
  const test::CliResult split = test::Cli().run("nest '" + two + "' --split --sheet 800x400 --time 0 --json");
  EXPECT_EQ(split.code, 0) << split.err;
}

}  // namespace
}  // namespace machplan
