// QtPlasmaC's own sample programs (LinuxCNC ships them in /usr/share/linuxcnc/ncfiles/plasmac)
// run on the thermal gantry with the bundled material file (material 1 where a program selects
// none) and an origin, as a plasma operator
// would run them: each completes, every cut in a material of the file (or of the program's own
// material comments), and the program that changes material cuts each piece in the material
// it selects.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

namespace fs = std::filesystem;
const fs::path kSamples = "/usr/share/linuxcnc/ncfiles/plasmac";
const std::string kMaterialFile = "datasets/materials/thermal_gantry_material.cfg";

std::vector<std::string> samples() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(kSamples, ec))
    if (e.path().extension() == ".ngc") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

nlohmann::json run_sample(const std::string& name) {
  test::Cli cli;
  const test::CliResult r = cli.run({"run", (kSamples / (name + ".ngc")).string(), "--machine", "thermal_gantry",
                                     "--materials", kMaterialFile, "--material", "1", "--origin", "100,100", "--json"});
  EXPECT_EQ(r.code, 0) << name << ": " << r.err;
  if (r.code != 0) return {};
  return nlohmann::json::parse(r.out);
}

TEST(QtPlasmacSamples, AreAllThere) {
  // The package ships nine metric and nine imperial programs; a test over none would prove nothing.
  EXPECT_GE(samples().size(), 18u) << "LinuxCNC's QtPlasmaC samples are missing from " << kSamples;
}

class QtPlasmacSample : public ::testing::TestWithParam<std::string> {};

TEST_P(QtPlasmacSample, RunsWithTheMaterialFileAndAnOrigin) {
  const nlohmann::json j = run_sample(GetParam());
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j["summary"]["status"], "done") << j["summary"].dump();
  EXPECT_EQ(j["origin_from"], "given");
  ASSERT_GT(j["cuts"].size(), 0u);
  for (const auto& cut : j["cuts"]) {
    ASSERT_TRUE(cut.contains("material")) << cut.dump();
    const int m = cut["material"].get<int>();
    ASSERT_GE(m, 0);
    ASSERT_LT(m, static_cast<int>(j["materials"].size()));
  }
}

INSTANTIATE_TEST_SUITE_P(All, QtPlasmacSample, ::testing::ValuesIn(samples()),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param; });

TEST(QtPlasmacSamples, MaterialChangeCutsEachPieceInItsMaterial) {
  const nlohmann::json j = run_sample("metric_material_change");
  ASSERT_FALSE(j.is_null());
  std::vector<int> numbers;
  for (const auto& cut : j["cuts"]) numbers.push_back(j["materials"][cut["material"].get<int>()]["number"].get<int>());
  // M190 P1 .. P4, one cut each (the closing M190 P0 selects the default after the last cut).
  ASSERT_GE(numbers.size(), 4u);
  EXPECT_EQ(std::vector<int>(numbers.begin(), numbers.begin() + 4), (std::vector<int>{1, 2, 3, 4}));
  // Each material's cut feed from the file.
  EXPECT_DOUBLE_EQ(j["materials"][j["cuts"][0]["material"].get<int>()]["cut_feed_mm_per_min"].get<double>(), 4500.0);
}

}  // namespace
}  // namespace machplan
