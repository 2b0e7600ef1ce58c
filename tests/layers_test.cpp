// The layering docs/architecture.md states, read from the sources' #include lines:
//   * a layer uses only the layers below it: cli -> solvers -> models -> engine;
//   * the folders inside one layer form no cycle (engine/control does not include
//     engine/executor while engine/executor includes engine/control, and so on);
//   * FCL, OMPL, Ceres, NLopt, SQLite and Cairo are included only by the modules that wrap them.
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace machplan {
namespace {

namespace fs = std::filesystem;

const fs::path kRoot = MACHPLAN_SOURCE_DIR;
const std::vector<std::string> kLayers = {"engine", "models", "solvers", "cli"};  // lowest first

struct Include {
  std::string file;    // relative to the source root
  std::string target;  // what is included, as written
  bool quoted = false;
};

std::vector<Include> every_include() {
  static const std::regex line(R"(^\s*#\s*include\s*([<"])([^>"]+)[>"])");
  std::vector<Include> all;
  for (const std::string& layer : kLayers)
    for (const auto& e : fs::recursive_directory_iterator(kRoot / layer)) {
      const std::string ext = e.path().extension().string();
      if (ext != ".h" && ext != ".cpp") continue;
      std::ifstream in(e.path());
      const std::string file = fs::relative(e.path(), kRoot).generic_string();
      for (std::string l; std::getline(in, l);) {
        std::smatch m;
        if (std::regex_search(l, m, line)) all.push_back({file, m[2], m[1] == "\""});
      }
    }
  return all;
}

int layer_of(const std::string& path) {
  for (std::size_t i = 0; i < kLayers.size(); ++i)
    if (path.rfind(kLayers[i] + "/", 0) == 0) return static_cast<int>(i);
  return -1;
}

// "engine/control/pid.h" -> "engine/control"; a file directly in a layer's folder -> the layer.
std::string folder_of(const std::string& path) {
  const auto first = path.find('/');
  const auto second = path.find('/', first + 1);
  return second == std::string::npos ? path.substr(0, first) : path.substr(0, second);
}

TEST(Layers, EachLayerUsesOnlyTheLayersBelowIt) {
  const auto includes = every_include();
  ASSERT_GT(includes.size(), 500u);  // the scan sees the tree
  for (const Include& i : includes) {
    if (!i.quoted) continue;
    const int from = layer_of(i.file), to = layer_of(i.target);
    if (to < 0) continue;
    EXPECT_LE(to, from) << i.file << " includes " << i.target;
  }
}

TEST(Layers, TheFoldersInsideALayerFormNoCycle) {
  std::map<std::string, std::set<std::string>> uses;
  std::map<std::pair<std::string, std::string>, std::string> example;
  for (const Include& i : every_include()) {
    if (!i.quoted || layer_of(i.target) < 0) continue;
    const std::string a = folder_of(i.file), b = folder_of(i.target);
    if (a == b || layer_of(a) != layer_of(b)) continue;
    uses[a].insert(b);
    example.emplace(std::make_pair(a, b), i.file + " includes " + i.target);
  }
  ASSERT_TRUE(uses.count("engine/executor"));
  // a -> b is on a cycle when b reaches a.
  std::function<bool(const std::string&, const std::string&, std::set<std::string>&)> reaches =
      [&](const std::string& from, const std::string& to, std::set<std::string>& seen) {
        if (from == to) return true;
        if (!seen.insert(from).second) return false;
        for (const std::string& n : uses[from])
          if (reaches(n, to, seen)) return true;
        return false;
      };
  for (const auto& [a, targets] : uses)
    for (const std::string& b : targets) {
      std::set<std::string> seen;
      EXPECT_FALSE(reaches(b, a, seen)) << a << " -> " << b << " closes a cycle (" << example[{a, b}] << ")";
    }
}

TEST(Layers, ThirdPartyLibrariesStayInsideTheirModules) {
  // Include prefix -> the files (or the folder, ending in '/') allowed to include it.
  const std::map<std::string, std::vector<std::string>> allowed = {
      {"fcl/", {"engine/interference/collision.cpp"}},
      {"ompl/", {"solvers/motion/"}},
      {"ceres/", {"solvers/calibration/fit.cpp"}},
      {"nlopt", {"solvers/tuning/optimizer.cpp"}},
      {"sqlite3", {"solvers/common/internal/sqlite_db.cpp"}},
      {"cairo", {"solvers/"}},
  };
  for (const Include& i : every_include()) {
    if (i.quoted) continue;
    for (const auto& [prefix, where] : allowed) {
      if (i.target.rfind(prefix, 0) != 0) continue;
      bool ok = false;
      for (const std::string& w : where) ok = ok || (w.back() == '/' ? i.file.rfind(w, 0) == 0 : i.file == w);
      EXPECT_TRUE(ok) << i.file << " includes <" << i.target << ">";
    }
  }
}

}  // namespace
}  // namespace machplan
