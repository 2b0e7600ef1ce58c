// Runs the machplan command line from a test: from the source tree, with its own data folder
// (XDG_DATA_HOME inside the test's temporary folder, so no store of the user's is touched),
// stdout and stderr captured.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "tests/support/temp_dir.h"

namespace machplan::test {

struct CliResult {
  int code = -1;  // exit status; -1 when the program did not exit normally
  std::string out, err;
};

// `args` is pasted into a shell command line after the program: quote file names in it.
inline CliResult run_cli(const TempDir& dir, const std::string& args) {
  const auto out = (dir.path() / "stdout").string(), err = (dir.path() / "stderr").string();
  const int rc = std::system(fmt::format("cd '{}' && XDG_DATA_HOME='{}/xdg' '{}' {} > '{}' 2> '{}'", MACHPLAN_SOURCE_DIR,
                                         dir.path().string(), MACHPLAN_CLI, args, out, err)
                                 .c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(out), slurp(err)};
}

}  // namespace machplan::test
