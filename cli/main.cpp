// The `machplan` command: parses arguments, hands them to engine/solvers, prints. Nothing else.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <vector>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "engine/common/error.h"
#include "engine/common/output_file.h"

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

namespace {

// Every command writes its results to stdout (printf or std::cout, which share the stdio
// buffer); an error on any of those writes sticks to the stream. Checked once, here, so that a
// full disk or a closed pipe is exit 4 (an output could not be written, engine/common/error.h)
// with the reason instead of a silent success.
int check_stdout(int code) {
  std::cout.flush();
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  int err = errno;
  if (flushed && !std::ferror(stdout) && std::cout.good()) return code;
  if (err == 0) {
    // The failed write happened earlier, inside a printf, and its errno is gone. The output is
    // already incomplete; one more byte written directly finds the reason again (a full disk,
    // an I/O error).
    errno = 0;
    if (::write(STDOUT_FILENO, "\n", 1) < 0) err = errno;
  }
  std::fprintf(stderr, "machplan: cannot write the output to standard output: %s; the output is incomplete\n",
               err != 0 ? std::strerror(err) : "write error");
  return code == 0 ? 4 : code;
}

int run(int argc, char** argv);

}  // namespace

int main(int argc, char** argv) { return check_stdout(run(argc, argv)); }

namespace {

int run(int argc, char** argv) {
  using namespace machplan;
  CLI::App app{
      "machplan: planning engine and runtime for machine tools.\n"
      "Places workpieces on parallel-kinematic machines, calibrates and tunes axes, and runs\n"
      "part programs. Exit codes: 0 done, 1 internal error, 2 bad input, 3 cannot be done\n(or, for `check`, interference found), 4 an output could not be written (full disk, no\npermission: the system's reason is printed).",
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
    // FILE:LINE: message, or --flag: message (a field error renamed to the flag that set it)
    std::fprintf(stderr, "%s\n", cli::for_user(e, app).what());
    return 2;
  } catch (const Infeasible& e) {
    std::fprintf(stderr, "machplan: %s\n", cli::for_user(e, app).what());
    return 3;
  } catch (const OutputError& e) {
    // FILE: cannot write: REASON. The old file, if any, is as it was (AtomicOutput).
    std::fprintf(stderr, "machplan: %s\n", e.what());
    return 4;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "machplan: internal error: %s\n", e.what());
    return 1;
  }
  return cli::g_exit_code;
}

}  // namespace
