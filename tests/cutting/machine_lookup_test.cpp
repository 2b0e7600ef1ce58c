// Where `--machine NAME` looks (models/cutting/machine_config.h): the user's folder first,
// then the installed one, then (for this build tree) the source tree; never the current folder.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "engine/common/error.h"
#include "models/cutting/machine_config.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::cutting {
namespace {

using ::testing::HasSubstr;
using test::error_of;
using test::TempDir;
namespace fs = std::filesystem;

// Points XDG_CONFIG_HOME at a fresh folder for one test, and restores it after.
class UserConfig {
 public:
  UserConfig() {
    if (const char* old = std::getenv("XDG_CONFIG_HOME")) old_ = old, had_ = true;
    ::setenv("XDG_CONFIG_HOME", dir_.path().c_str(), 1);
  }
  ~UserConfig() {
    if (had_) ::setenv("XDG_CONFIG_HOME", old_.c_str(), 1);
    else ::unsetenv("XDG_CONFIG_HOME");
  }
  fs::path machines() const { return dir_.path() / "machplan" / "machines"; }

 private:
  TempDir dir_;
  std::string old_;
  bool had_ = false;
};

// Runs `f` with the current folder set to `dir`.
template <class F>
void in_folder(const fs::path& dir, F&& f) {
  const fs::path old = fs::current_path();
  fs::current_path(dir);
  try {
    f();
  } catch (...) {
    fs::current_path(old);
    throw;
  }
  fs::current_path(old);
}

const std::string kSourceMachines = (fs::path(MACHPLAN_SOURCE_DIR) / "datasets" / "machines").string();

TEST(MachineLookup, OrderIsUserInstalledSourceAndTheUserFolderIsCreated) {
  UserConfig user;
  ASSERT_FALSE(fs::exists(user.machines()));
  const auto folders = machine_folders();
  ASSERT_GE(folders.size(), 3u);
  EXPECT_EQ(folders.front().kind, "user");
  EXPECT_EQ(folders.front().path, user.machines().string());
  EXPECT_TRUE(folders.front().exists);
  EXPECT_TRUE(fs::is_directory(user.machines()));
  EXPECT_EQ(folders[1].kind, "installed");
  EXPECT_EQ(folders.back().kind, "source");  // this test runs from the build tree
  EXPECT_EQ(folders.back().path, fs::path(kSourceMachines).lexically_normal().string());
  for (const auto& f : folders) EXPECT_NE(f.path, "datasets/machines");
}

TEST(MachineLookup, TheUsersMachineReplacesTheBundledOne) {
  UserConfig user;
  EXPECT_EQ(fs::path(find_machine("thermal_gantry")).parent_path(), fs::path(kSourceMachines).lexically_normal());
  fs::create_directories(user.machines());
  fs::copy_file(fs::path(kSourceMachines) / "xy_table.yaml", user.machines() / "thermal_gantry.yaml");
  EXPECT_EQ(find_machine("thermal_gantry"), (user.machines() / "thermal_gantry.yaml").string());
  EXPECT_EQ(load_machine(find_machine("thermal_gantry")).name, "xy_table");

  const auto all = list_machines();
  int users = 0, shadowed = 0;
  for (const auto& m : all) {
    if (m.kind == "user") {
      ++users;
      EXPECT_FALSE(m.shadowed);
    }
    if (m.name == "thermal_gantry" && m.kind == "source") {
      ++shadowed;
      EXPECT_TRUE(m.shadowed);
    }
    if (m.name == "xy_table" && m.kind == "source") { EXPECT_FALSE(m.shadowed); }
  }
  EXPECT_EQ(users, 1);
  EXPECT_EQ(shadowed, 1);
}

TEST(MachineLookup, TheCurrentFolderIsUsedOnlyThroughAPath) {
  UserConfig user;
  TempDir here;
  fs::create_directories(here.path() / "datasets" / "machines");
  fs::copy_file(fs::path(kSourceMachines) / "xy_table.yaml", here.path() / "datasets" / "machines" / "stray.yaml");
  fs::copy_file(fs::path(kSourceMachines) / "xy_table.yaml", here.path() / "bare");
  in_folder(here.path(), [] {
    const std::string msg = error_of([] { find_machine("stray"); });
    EXPECT_THAT(msg, HasSubstr("machine: no machine named 'stray'"));
    EXPECT_THAT(msg, HasSubstr("(user)"));
    EXPECT_THAT(msg, HasSubstr("machplan machines"));
    EXPECT_THAT(error_of([] { find_machine("bare"); }), HasSubstr("no machine named 'bare'"));
    EXPECT_EQ(find_machine("./datasets/machines/stray.yaml"), "./datasets/machines/stray.yaml");
    EXPECT_EQ(find_machine("./bare"), "./bare");
    // A stray copy of a bundled name in ./datasets/machines changes nothing.
    fs::copy_file("datasets/machines/stray.yaml", "datasets/machines/thermal_gantry.yaml");
    EXPECT_EQ(load_machine(find_machine("thermal_gantry")).name, "thermal_gantry");
  });
  EXPECT_THAT(error_of([] { find_machine("missing/file.yaml"); }), HasSubstr("no such machine file"));
}

TEST(MachineLookup, MachinesCommandListsFoldersAndMachines) {
  test::Cli cli;  // its XDG_CONFIG_HOME is the user's folder of this test
  const fs::path user_machines = cli.config_home() / "machplan" / "machines";
  const test::CliResult text = cli.run({"machines"});
  EXPECT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("user      " + user_machines.string()));
  EXPECT_THAT(text.out, HasSubstr("source    " + fs::path(kSourceMachines).lexically_normal().string()));
  EXPECT_THAT(text.out, HasSubstr("thermal_gantry"));
  EXPECT_THAT(text.out, HasSubstr("xy_table"));
  // A machine file put in the user's folder is listed as the user's.
  fs::create_directories(user_machines);
  fs::copy_file(fs::path(kSourceMachines) / "xy_table.yaml", user_machines / "my_table.yaml");
  const test::CliResult json = cli.run({"machines", "--json"});
  EXPECT_EQ(json.code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr("\"kind\": \"user\""));
  EXPECT_THAT(json.out, HasSubstr("\"name\": \"my_table\""));
  EXPECT_THAT(json.out, HasSubstr("\"name\": \"thermal_gantry\""));
}

TEST(MachineLookup, EachMachineSaysWhatItIsFor) {
  UserConfig user;
  fs::create_directories(user.machines());
  // A HexaM file without `kind` is known by its struts; a broken file is listed, with why.
  fs::copy_file(fs::path(MACHPLAN_SOURCE_DIR) / "datasets" / "hexam-paper" / "machine.yaml", user.machines() / "hexam.yaml");
  std::ofstream(user.machines() / "broken.yaml") << "name: [unclosed\n";
  std::map<std::string, MachineEntry> by_name;
  for (const auto& m : list_machines()) by_name.emplace(m.name, m);
  ASSERT_TRUE(by_name.count("trunnion_ac") && by_name.count("thermal_gantry") && by_name.count("xy_table"));
  EXPECT_EQ(by_name.at("trunnion_ac").use, MachineUse::placement);
  EXPECT_EQ(by_name.at("hexam").use, MachineUse::placement);
  EXPECT_EQ(by_name.at("thermal_gantry").use, MachineUse::cutting);
  EXPECT_EQ(by_name.at("xy_table").use, MachineUse::cutting);
  EXPECT_EQ(by_name.at("broken").use, MachineUse::unreadable);
  EXPECT_THAT(by_name.at("broken").problem, HasSubstr("broken.yaml"));
  EXPECT_TRUE(by_name.at("xy_table").problem.empty());
}

TEST(MachineLookup, APlacementMachineIsRefusedForWhatItIsNotAKey) {
  const std::string path = find_machine("trunnion_ac");
  const std::string msg = error_of([&] { load_machine(path); });
  EXPECT_THAT(msg, HasSubstr(path + ": 'trunnion_ac' is a machine for placement (kind table_tilting)"));
  EXPECT_THAT(msg, HasSubstr("machplan place"));
  EXPECT_THAT(msg, ::testing::Not(HasSubstr("unknown key")));
  const std::string hexam = (fs::path(MACHPLAN_SOURCE_DIR) / "datasets" / "hexam-paper" / "machine.yaml").string();
  EXPECT_THAT(error_of([&] { load_machine(hexam); }), HasSubstr("is a machine for placement (a hexapod)"));
}

TEST(MachineLookup, MachinesCommandSaysWhatEachMachineIsForAndRunRefusesAPlacementMachine) {
  test::Cli cli;
  const test::CliResult text = cli.run({"machines"});
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_THAT(text.out, ::testing::ContainsRegex("trunnion_ac +source +placement: place, check "));
  EXPECT_THAT(text.out, ::testing::ContainsRegex("xy_table +source +cutting: run, tune, guard, calibrate, serve "));
  const test::CliResult json = cli.run({"machines", "--json"});
  ASSERT_EQ(json.code, 0) << json.err;
  EXPECT_THAT(json.out, HasSubstr("\"use\": \"placement\""));
  EXPECT_THAT(json.out, HasSubstr("\"use\": \"cutting\""));

  const test::CliResult run = cli.run("run datasets/parts/triangle_45.ngc --machine trunnion_ac");
  EXPECT_EQ(run.code, 2);
  EXPECT_THAT(run.err, HasSubstr("trunnion_ac.yaml: 'trunnion_ac' is a machine for placement"));
  EXPECT_THAT(run.err, ::testing::Not(HasSubstr("unknown key")));
}

}  // namespace
}  // namespace machplan::cutting
