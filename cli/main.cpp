// The `machplan` command: parses arguments, hands them to engine/solvers, prints. Nothing else.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

#include "cli/command.h"
#include "engine/common/error.h"

namespace machplan::cli {
namespace {

struct Entry {
  int rank;
  AddCommand add;
};

std::vector<Entry>& registry() {
  static std::vector<Entry> entries;
  return entries;
}

int g_exit_code = 0;

}  // namespace

Registration::Registration(int rank, AddCommand add) { registry().push_back({rank, std::move(add)}); }

void set_exit_code(int code) { g_exit_code = code; }

}  // namespace machplan::cli

int main(int argc, char** argv) {
  using namespace machplan;
  CLI::App app{
      "machplan: planning engine and runtime for machine tools.\n"
      "Places workpieces on parallel-kinematic machines, calibrates and tunes axes, and runs\n"
      "part programs. Exit codes: 0 done, 1 internal error, 2 bad input, 3 cannot be done\n(or, for `check`, interference found).",
      "machplan"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "machplan 0.1.0");
  auto entries = cli::registry();
  std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.rank < b.rank; });
  for (const auto& e : entries) e.add(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // FILE:LINE: message
    return 2;
  } catch (const Infeasible& e) {
    std::fprintf(stderr, "machplan: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "machplan: internal error: %s\n", e.what());
    return 1;
  }
  return cli::g_exit_code;
}
