// Runs the machplan command line from a test: the one way every CLI test does it.
//
//     test::Cli cli;                                    // a sandbox of its own
//     const test::CliResult r = cli.run("run datasets/parts/triangle_45.ngc --machine thermal_gantry --json");
//     EXPECT_EQ(r.code, 0) << r.err;
//
// Each Cli is a sandbox:
//   * a temporary folder (dir(), removed with the Cli) holding the run's HOME (home()),
//     XDG_CONFIG_HOME (config_home(): a test puts user machines in
//     config_home()/machplan/machines) and XDG_DATA_HOME (data_home(): the calibration and
//     tuning stores), so that nothing of the user's is read or written; XDG_CACHE_HOME and
//     XDG_STATE_HOME point there too, USER is "machplan-test";
//   * no network: each run gets a network namespace of its own with nothing in it (`unshare
//     -rn`) where the system allows one (Cli::network_namespace()); where it does not, the
//     proxy variables point at a closed local port, so a well-behaved client fails at once;
//   * the current folder is the source tree (bundled data by relative path: datasets/...),
//     stdin is /dev/null, stdout and stderr are captured.
// The rest of the environment (PATH, the sanitizers' options) is passed on.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

#include "tests/support/temp_dir.h"

namespace machplan::test {

struct CliResult {
  int code = -1;  // exit status; 128 + N when signal N ended the program
  std::string out, err;
};

// Where a run reads and writes, when not the defaults.
struct CliIo {
  std::string stdin_path = "/dev/null";
  std::string stdout_path;    // empty: captured into CliResult::out
  std::filesystem::path cwd;  // empty: the source tree
  // A network namespace of its own (no network) where the system allows one. Off for runs
  // that drive a machine through HAL: in the namespace's user namespace the process may not
  // lock its memory or take a real-time priority.
  bool isolate = true;
  // A full disk on demand (Cli::run with the shell form only): a tmpfs of `small_disk_kb` KiB
  // mounted at `small_disk_at` (an existing folder) in a mount namespace of the run's own
  // (`unshare -rmn`), where `small_disk_before` (shell commands: copy a file in, fill the disk)
  // runs first and `small_disk_after` after machplan (copy out what the test checks: the tmpfs
  // goes away with the run). The exit status is machplan's; 125 when the tmpfs could not be
  // mounted. Needs Cli::network_namespace().
  int small_disk_kb = 0;
  std::string small_disk_at, small_disk_before, small_disk_after;
};

class CliProcess;

class Cli {
 public:
  Cli();

  const std::filesystem::path& dir() const { return dir_.path(); }
  std::filesystem::path home() const { return dir() / "home"; }
  std::filesystem::path config_home() const { return dir() / "config"; }
  std::filesystem::path data_home() const { return dir() / "data"; }
  // Writes `bytes` to NAME in dir() and returns its path.
  std::string write(const std::string& name, const std::string& bytes) const { return dir_.write(name, bytes); }

  // `args`: the words after `machplan` as a shell reads them (quote file names in it).
  CliResult run(const std::string& args, const CliIo& io = {}) const;
  // The words after `machplan`, one per element, passed as they are.
  CliResult run(const std::vector<std::string>& args, const CliIo& io = {}) const;
  // The same for a braced list (`cli.run({"machines", "--json"})`), which would otherwise be
  // ambiguous with the shell form.
  CliResult run(std::initializer_list<std::string> args, const CliIo& io = {}) const {
    return run(std::vector<std::string>(args), io);
  }
  // Starts machplan and returns at once: for tests that signal it while it runs.
  CliProcess start(const std::vector<std::string>& args, const CliIo& io = {}) const;

  // Whether runs get a network namespace of their own (else the proxies point nowhere).
  static bool network_namespace();

 private:
  friend class CliProcess;
  CliProcess spawn(const std::vector<std::string>& argv, const CliIo& io) const;

  TempDir dir_;
  mutable int runs_ = 0;
};

// A machplan started by Cli::start(). Destroying it before wait() kills it and waits.
class CliProcess {
 public:
  CliProcess(CliProcess&& o) noexcept;
  CliProcess& operator=(CliProcess&&) = delete;
  ~CliProcess();

  pid_t pid() const { return pid_; }
  // Sends `sig`; false when the process is gone.
  bool signal(int sig) const;
  // Waits until the program has installed a handler for `sig` (its /proc status shows the
  // signal caught), so that a signal sent next reaches the program's own handling; false if
  // it ended first or `guard_s` passed (a guard against a hang, not a measure of speed).
  bool wait_until_catching(int sig, double guard_s = 120.0) const;
  // Waits for the end and returns the exit status and what it printed.
  CliResult wait();

 private:
  friend class Cli;
  CliProcess(pid_t pid, std::string out, std::string err, bool out_captured);

  pid_t pid_ = -1;
  std::string out_path_, err_path_;
  bool out_captured_ = true;
};

}  // namespace machplan::test
