// A scene that points to a missing or broken file (the machine, the workpiece mesh, the tool
// path, a peripheral's mesh) is refused naming the scene file, the key's line and the key,
// then the file and what is wrong with it.
#include "solvers/placement/scene/scene.h"
#include "tests/support/datasets.h"

#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using test::error_of;
using test::TempDir;


struct Files {
  std::string machine, workpiece, toolpath;
  std::string peripheral;  // a mesh; empty: no peripherals
};

// machine on line 1, the workpiece's mesh on line 3, the tool path on line 4, the first
// peripheral on line 6.
std::string write_scene(const TempDir& dir, const Files& f) {
  std::string text = fmt::format(
      "machine: {}\n"
      "tooling: {{tool_diameter_mm: 10, stick_out_mm: 50, chuck_diameter_mm: 60, chuck_length_mm: 45}}\n"
      "workpiece: {{mesh: {}}}\n"
      "toolpath: {}\n",
      f.machine, f.workpiece, f.toolpath);
  if (!f.peripheral.empty()) text += fmt::format("peripherals:\n  - {{name: fixture, mesh: {}}}\n", f.peripheral);
  return dir.write("scene.yaml", text);
}

TEST(Scene, AMissingOrBrokenFileIsNamedWithTheSceneAndItsKey) {
  TempDir dir;
  const std::string path = dir.write("path.csv", "x,y,z,i,j,k\n0,0,100,0,0,1\n");
  const std::string bad_yaml = dir.write("bad.yaml", "name: [unclosed\n");
  const std::string bad_stl = dir.write("bad.stl", "solid x\n  facet normal 0 0 1\n  nonsense\n");
  const std::string bad_csv = dir.write("bad.csv", "x,y,z,i,j,k\n0,0,abc,0,0,1\n");
  const std::string missing = (dir.path() / "missing.file").string();
  const std::string folder = dir.path().string();
  struct Case {
    Files files;
    std::string where, file;  // "scene.yaml:LINE: key 'KEY': ", the file named after it
  };
  const std::string scene = (dir.path() / "scene.yaml").string();
  const auto at = [&](int line, const char* key) { return fmt::format("{}:{}: key '{}': ", scene, line, key); };
  const std::string machine = test::kHexamPaper + "machine.yaml", workpiece = test::kHexamPaper + "workpiece.stl";
  const Case cases[] = {
      {{missing, workpiece, path, ""}, at(1, "machine"), missing},
      {{bad_yaml, workpiece, path, ""}, at(1, "machine"), bad_yaml + ":"},
      {{folder, workpiece, path, ""}, at(1, "machine"), folder},
      {{machine, missing, path, ""}, at(3, "workpiece.mesh"), missing},
      {{machine, bad_stl, path, ""}, at(3, "workpiece.mesh"), bad_stl + ":"},
      {{machine, folder, path, ""}, at(3, "workpiece.mesh"), folder},
      {{machine, workpiece, missing, ""}, at(4, "toolpath"), missing},
      {{machine, workpiece, bad_csv, ""}, at(4, "toolpath"), bad_csv + ":2:"},
      {{machine, workpiece, folder, ""}, at(4, "toolpath"), folder},
      {{machine, workpiece, path, missing}, at(6, "peripherals[0].mesh"), missing},
      {{machine, workpiece, path, bad_stl}, at(6, "peripherals[0].mesh"), bad_stl + ":"},
  };
  for (const Case& c : cases) {
    write_scene(dir, c.files);
    const std::string msg = error_of([&] { load_scene(scene); });
    EXPECT_THAT(msg, StartsWith(c.where + c.file)) << msg;
  }
  // The scene itself, when sound, loads (so the cases above fail for the one file each breaks).
  write_scene(dir, {machine, workpiece, path, ""});
  EXPECT_NO_THROW(load_scene(scene));
}

TEST(Scene, TheCommandNamesTheKeyOfAMissingFile) {
  TempDir dir;
  const std::string path = dir.write("path.csv", "x,y,z,i,j,k\n0,0,100,0,0,1\n");
  const std::string scene =
      write_scene(dir, {test::kHexamPaper + "machine.yaml", (dir.path() / "x.stl").string(), path, ""});
  const test::CliResult r = test::Cli().run("check '" + scene + "' --at 0,0,50");
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, StartsWith(scene + ":3: key 'workpiece.mesh': " + (dir.path() / "x.stl").string() + ": "));
}

}  // namespace
}  // namespace machplan::placement
