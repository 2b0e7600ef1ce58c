#include "tests/support/cli_run.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <cerrno>

#include <chrono>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <thread>
#include <utility>

#include <fmt/format.h>

extern char** environ;

namespace machplan::test {
namespace {

namespace fs = std::filesystem;

// Variables the sandbox sets itself (or, for the proxies' opposites, removes).
bool replaced(const std::string& entry) {
  static const char* const kNames[] = {"HOME",        "USER",        "XDG_CONFIG_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME",
                                       "XDG_STATE_HOME", "XDG_CONFIG_DIRS", "XDG_DATA_DIRS", "http_proxy",  "https_proxy",
                                       "ftp_proxy",   "all_proxy",   "HTTP_PROXY",      "HTTPS_PROXY",   "FTP_PROXY",
                                       "ALL_PROXY",   "no_proxy",    "NO_PROXY"};
  for (const char* n : kNames) {
    const std::size_t len = std::strlen(n);
    if (entry.compare(0, len, n) == 0 && entry.size() > len && entry[len] == '=') return true;
  }
  return false;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs argv with stdin, stdout and stderr from/to the given files and returns its exit status.
int run_quietly(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, args[0], &fa, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int exit_code(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace

bool Cli::network_namespace() {
  static const bool available = run_quietly({"unshare", "-rn", "--", "true"}) == 0;
  return available;
}

Cli::Cli() {
  for (const fs::path& p : {home(), config_home(), data_home()}) fs::create_directories(p);
}

CliProcess Cli::spawn(const std::vector<std::string>& words, const CliIo& io) const {
  std::vector<std::string> argv;
  if (io.isolate && network_namespace()) argv = {"unshare", io.small_disk_kb > 0 ? "-rmn" : "-rn", "--"};
  argv.insert(argv.end(), words.begin(), words.end());

  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e)
    if (!replaced(*e)) env.emplace_back(*e);
  env.push_back("HOME=" + home().string());
  env.push_back("USER=machplan-test");
  env.push_back("XDG_CONFIG_HOME=" + config_home().string());
  env.push_back("XDG_DATA_HOME=" + data_home().string());
  env.push_back("XDG_CACHE_HOME=" + (dir() / "cache").string());
  env.push_back("XDG_STATE_HOME=" + (dir() / "state").string());
  if (!network_namespace())
    for (const char* p : {"http_proxy", "https_proxy", "ftp_proxy", "all_proxy", "HTTP_PROXY", "HTTPS_PROXY", "FTP_PROXY",
                          "ALL_PROXY"})
      env.push_back(std::string(p) + "=http://127.0.0.1:9");

  const int n = runs_++;
  const std::string out = io.stdout_path.empty() ? (dir() / fmt::format("stdout.{}", n)).string() : io.stdout_path;
  const std::string err = (dir() / fmt::format("stderr.{}", n)).string();
  const std::string cwd = io.cwd.empty() ? std::string(MACHPLAN_SOURCE_DIR) : io.cwd.string();

  std::vector<char*> args, envp;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addchdir_np(&fa, cwd.c_str());
  posix_spawn_file_actions_addopen(&fa, 0, io.stdin_path.c_str(), O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, args[0], &fa, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(rc)));
  return CliProcess(pid, out, err, io.stdout_path.empty());
}

CliResult Cli::run(const std::string& args, const CliIo& io) const {
  if (io.small_disk_kb > 0) {
    if (!io.isolate || !network_namespace())
      throw std::runtime_error("a small disk needs the run's own namespaces (unshare -rmn)");
    // In the run's mount namespace: mount, prepare, run, copy out; machplan's status.
    const std::string script =
        fmt::format("mount -t tmpfs -o size={}k machplan-test \"{}\" || exit 125\n{}\n\"$0\" {}\nrc=$?\n{}\nexit $rc\n",
                    io.small_disk_kb, io.small_disk_at, io.small_disk_before, args, io.small_disk_after);
    return spawn({"/bin/sh", "-c", script, MACHPLAN_CLI}, io).wait();
  }
  // The shell splits and unquotes `args`; `exec` leaves machplan as the process waited for.
  return spawn({"/bin/sh", "-c", "exec \"$0\" " + args, MACHPLAN_CLI}, io).wait();
}

CliResult Cli::run(const std::vector<std::string>& args, const CliIo& io) const { return start(args, io).wait(); }

CliProcess Cli::start(const std::vector<std::string>& args, const CliIo& io) const {
  std::vector<std::string> argv{MACHPLAN_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  return spawn(argv, io);
}

CliProcess::CliProcess(pid_t pid, std::string out, std::string err, bool out_captured)
    : pid_(pid), out_path_(std::move(out)), err_path_(std::move(err)), out_captured_(out_captured) {}

CliProcess::CliProcess(CliProcess&& o) noexcept
    : pid_(std::exchange(o.pid_, -1)),
      out_path_(std::move(o.out_path_)),
      err_path_(std::move(o.err_path_)),
      out_captured_(o.out_captured_) {}

CliProcess::~CliProcess() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
}

bool CliProcess::signal(int sig) const { return pid_ > 0 && ::kill(pid_, sig) == 0; }

bool CliProcess::wait_until_catching(int sig, double guard_s) const {
  if (pid_ <= 0) return false;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(guard_s);
  const std::string status = fmt::format("/proc/{}/status", pid_);
  while (std::chrono::steady_clock::now() < end) {
    std::ifstream in(status);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("State:", 0) == 0 && line.find('Z') != std::string::npos) return false;  // ended
      if (line.rfind("SigCgt:", 0) != 0) continue;
      const unsigned long long mask = std::stoull(line.substr(7), nullptr, 16);
      if (mask & (1ull << (sig - 1))) return true;
    }
    if (!in.is_open() && ::kill(pid_, 0) != 0) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

CliResult CliProcess::wait() {
  CliResult r;
  if (pid_ <= 0) return r;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  r.code = exit_code(status);
  if (out_captured_) r.out = slurp(out_path_);
  r.err = slurp(err_path_);
  return r;
}

}  // namespace machplan::test
