#include "tests/support/rs274.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace machplan::test {

FeedEnds rs274_feeds(const std::string& program) {
  const std::filesystem::path dir = std::filesystem::path(program).parent_path();
  const std::string lock = (std::filesystem::temp_directory_path() / "machplan_rs274.lock").string();
  const int rc = std::system(("cd '" + dir.string() + "' && flock '" + lock + "' timeout 60 /usr/bin/rs274 -g '" + program +
                              "' > rs274.out 2> rs274.err")
                                 .c_str());
  if (rc != 0) {
    ADD_FAILURE() << "rs274 refused " << program << " (exit " << rc << ")";
    return {};
  }
  std::ifstream f(dir / "rs274.out");
  std::stringstream text;
  text << f.rdbuf();
  FeedEnds pts;
  static const std::regex call(R"((STRAIGHT_FEED|ARC_FEED)\(([^,]+),\s*([^,]+))");
  for (std::string line; std::getline(text, line);) {
    std::smatch m;
    if (std::regex_search(line, m, call)) pts.emplace_back(std::stod(m[2]), std::stod(m[3]));
  }
  return pts;
}

FeedEnds machplan_feeds(const std::string& program, const std::string& dialect) {
  const CliResult r = Cli().run("program '" + program + "' --json --dialect " + dialect);
  if (r.code != 0) {
    ADD_FAILURE() << "machplan program refused " << program << ": " << r.err;
    return {};
  }
  const nlohmann::json j = nlohmann::json::parse(r.out);
  FeedEnds pts;
  for (const auto& m : j["moves"])
    if (m["kind"] == "line" || m["kind"] == "arc") pts.emplace_back(m["end"][0], m["end"][1]);
  return pts;
}

void expect_same_feeds(const FeedEnds& rs274, const FeedEnds& machplan, double tol_mm) {
  ASSERT_EQ(rs274.size(), machplan.size()) << "feed moves read by rs274 and by machplan";
  for (std::size_t k = 0; k < rs274.size(); ++k) {
    EXPECT_NEAR(rs274[k].first, machplan[k].first, tol_mm) << "feed move " << k;
    EXPECT_NEAR(rs274[k].second, machplan[k].second, tol_mm) << "feed move " << k;
  }
}

}  // namespace machplan::test
