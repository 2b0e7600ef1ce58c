#include "tests/support/hal_sim.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

extern "C" {
#include <hal.h>
}

namespace machplan::test {

namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// A pin's value, or a parameter's.
hal_data_u* pin_data(const std::string& name, hal_type_t& type) {
  hal_data_u* data = nullptr;
  bool connected = false;
  if (hal_get_pin_value_by_name(name.c_str(), &type, &data, &connected) == 0 && data) return data;
  if (hal_get_param_value_by_name(name.c_str(), &type, &data) == 0 && data) return data;
  throw std::runtime_error("HAL has no pin or parameter " + name);
}

}  // namespace

std::string hal_sim(const std::string& args, int timeout_s) {
  char tmpl[] = "/tmp/machplan-hal-sim-out-XXXXXX";
  const int fd = mkstemp(tmpl);
  if (fd < 0) throw std::runtime_error("mkstemp failed");
  close(fd);
  const std::string cmd =
      fmt::format("cd '{}' && timeout {} scripts/hal-sim {} > '{}' 2>&1", MACHPLAN_SOURCE_DIR, timeout_s, args, tmpl);
  const int rc = std::system(cmd.c_str());
  const std::string out = slurp(tmpl);
  std::remove(tmpl);
  if (!WIFEXITED(rc) || WEXITSTATUS(rc) != 0)
    throw std::runtime_error(fmt::format("scripts/hal-sim {} failed (status {}): {}", args, rc, out));
  return out;
}

HalSim::HalSim(const std::string& up_args) { hal_sim("up " + up_args); }
HalSim::~HalSim() {
  try {
    hal_sim("down");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
  }
}

void ensure_hal_sim(const std::string& up_args) {
  const std::string want = up_args.find("--velocity") != std::string::npos ? "velocity=1" : "velocity=0";
  std::string status;
  try {
    status = hal_sim("status", 30);
  } catch (const std::exception&) {
  }
  if (status.find("machine=thermal_gantry") == std::string::npos || status.find(want) == std::string::npos)
    hal_sim("up " + up_args);
}

HalPins::HalPins() {
  const std::string name = fmt::format("machplan-test-{}", getpid());
  comp_id_ = hal_init(name.c_str());
  if (comp_id_ < 0) throw std::runtime_error("HAL is not running (hal_init failed)");
  hal_ready(comp_id_);
}

HalPins::~HalPins() {
  if (comp_id_ >= 0) hal_exit(comp_id_);
}

// HAL keeps a value only as large and as aligned as its type (a u32 parameter may sit 4 bytes
// off an 8-byte boundary): read and write it through a copy of that size, never through the
// union.
template <class T>
T get(const hal_data_u* d) {
  T v;
  std::memcpy(&v, static_cast<const void*>(d), sizeof v);
  return v;
}
template <class T>
void put(hal_data_u* d, T v) {
  std::memcpy(static_cast<void*>(d), &v, sizeof v);
}

double HalPins::number(const std::string& pin) const {
  hal_type_t type;
  const hal_data_u* d = pin_data(pin, type);
  switch (type) {
    case HAL_FLOAT: return get<double>(d);
    case HAL_S32: return get<std::int32_t>(d);
    case HAL_U32: return get<std::uint32_t>(d);
    case HAL_BIT: return get<bool>(d) ? 1.0 : 0.0;
    default: throw std::runtime_error("pin " + pin + " has a type this helper does not read");
  }
}

bool HalPins::bit(const std::string& pin) const { return number(pin) != 0.0; }

void HalPins::set_signal(const std::string& signal, double value) {
  hal_type_t type;
  hal_data_u* d = nullptr;
  bool writers = false;
  if (hal_get_signal_value_by_name(signal.c_str(), &type, &d, &writers) != 0 || !d)
    throw std::runtime_error("HAL has no signal " + signal);
  if (writers) throw std::runtime_error("signal " + signal + " has a writer");
  if (type == HAL_BIT) put<bool>(d, value != 0.0);
  else if (type == HAL_FLOAT) put<double>(d, value);
  else throw std::runtime_error("signal " + signal + ": unsupported type");
}

void HalPins::set_pin(const std::string& pin, double value) {
  hal_type_t type;
  hal_data_u* d = pin_data(pin, type);
  if (type == HAL_BIT) put<bool>(d, value != 0.0);
  else if (type == HAL_FLOAT) put<double>(d, value);
  else if (type == HAL_S32) put<std::int32_t>(d, static_cast<std::int32_t>(value));
  else if (type == HAL_U32) put<std::uint32_t>(d, static_cast<std::uint32_t>(value));
}

void HalPins::stop_threads() { hal_stop_threads(); }
void HalPins::start_threads() { hal_start_threads(); }

bool HalPins::wait_bit(const std::string& pin, bool value, std::chrono::milliseconds timeout) const {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (bit(pin) == value) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return bit(pin) == value;
}

Child::Child(const std::string& command, const std::string& out_path, const std::string& err_path) {
  const std::string cmd = fmt::format("cd '{}' && exec {} > '{}' 2> '{}'", MACHPLAN_SOURCE_DIR, command, out_path, err_path);
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
}

Child::~Child() {
  if (!done_ && pid_ > 0) {
    ::kill(pid_, SIGKILL);
    waitpid(pid_, &status_, 0);
  }
}

bool Child::exited() {
  if (!done_ && waitpid(pid_, &status_, WNOHANG) == pid_) done_ = true;
  return done_;
}

int Child::wait(std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!exited()) {
    if (std::chrono::steady_clock::now() > end) {
      kill_now();
      throw std::runtime_error(fmt::format("process {} did not end within {} s: killed", pid_, timeout.count()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return WIFEXITED(status_) ? WEXITSTATUS(status_) : WIFSIGNALED(status_) ? -WTERMSIG(status_) : -1000;
}

void Child::kill_now() {
  if (done_) return;
  ::kill(pid_, SIGKILL);
  waitpid(pid_, &status_, 0);
  done_ = true;
}

SamplerRecording::SamplerRecording(HalPins& pins, int n, const std::string& path) : path_(path) {
  pins.set_pin("sampler.0.enable", 1);
  child_ = std::make_unique<Child>(fmt::format("halsampler -c 0 -n {}", n), path, path + ".err");
}

std::vector<std::vector<double>> SamplerRecording::rows(std::chrono::seconds timeout) {
  const int rc = child_->wait(timeout);
  if (rc != 0) throw std::runtime_error(fmt::format("halsampler failed ({}): {}", rc, slurp(path_ + ".err")));
  std::vector<std::vector<double>> out;
  std::istringstream in(slurp(path_));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::vector<double> row;
    std::string tok;
    while (ls >> tok) row.push_back(tok == "TRUE" ? 1.0 : tok == "FALSE" ? 0.0 : std::stod(tok));
    if (!row.empty()) out.push_back(std::move(row));
  }
  return out;
}

}  // namespace machplan::test
