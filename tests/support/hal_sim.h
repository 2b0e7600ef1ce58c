// The HAL-simulated machine (scripts/hal-sim) from a test: start and stop it, home its axes,
// read and set its pins and signals, run programs beside it with time limits.
//
// Every call has a time limit and reports what failed (a std::runtime_error with the output);
// nothing here skips. A test that starts HAL stops it again when its HalSim goes out of scope,
// failed assertions included; ctest's hal_sim_down cleanup (tests/CMakeLists.txt) stops it
// after a crash.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace machplan::test {

// Runs `scripts/hal-sim ARGS` from the source tree; returns its output, throws on failure.
std::string hal_sim(const std::string& args, int timeout_s = 120);

// HAL up for the life of the object.
class HalSim {
 public:
  explicit HalSim(const std::string& up_args = "");  // e.g. "--velocity", "--file F.hal"
  ~HalSim();
  HalSim(const HalSim&) = delete;
  HalSim& operator=(const HalSim&) = delete;
};

// Brings up the position-mode thermal gantry unless it already runs (tests that share one
// simulation across processes; ctest's cleanup stops it).
void ensure_hal_sim(const std::string& up_args = "");

// A connection of the test's own to HAL (its userspace API): what halcmd getp, setp and sets
// do, without starting a process each time.
class HalPins {
 public:
  HalPins();  // throws when HAL is not running
  ~HalPins();
  HalPins(const HalPins&) = delete;
  HalPins& operator=(const HalPins&) = delete;
  double number(const std::string& pin) const;  // a float, s32, u32 or bit pin or parameter
  bool bit(const std::string& pin) const;
  void set_signal(const std::string& signal, double value);  // halcmd sets
  void set_pin(const std::string& pin, double value);        // halcmd setp (an unlinked pin)
  void stop_threads();
  void start_threads();
  // Waits until `pin` (a bit) reads `value`; false after `timeout`.
  bool wait_bit(const std::string& pin, bool value, std::chrono::milliseconds timeout) const;

 private:
  int comp_id_ = -1;
};

// A child process running `command` through the shell (stdout and stderr to files), from the
// source tree.
class Child {
 public:
  Child(const std::string& command, const std::string& out_path, const std::string& err_path);
  ~Child();  // kills it if it still runs
  pid_t pid() const { return pid_; }
  // Waits for the exit; returns the exit code, -(signal) when killed, or throws after `timeout`.
  int wait(std::chrono::seconds timeout);
  bool exited();    // has it ended (without waiting)?
  void kill_now();  // SIGKILL

 private:
  pid_t pid_ = -1;
  bool done_ = false;
  int status_ = 0;
};

// Reads `n` samples of the simulation's sampler (halsampler -c 0 -n N) after turning it on;
// each row: period-count, missed-periods, torch-on, enable, watchdog-ok, estop-ok, pos-cmd X,
// Y, pos-fb X, Y. Starts halsampler at once and returns a handle to collect the rows.
class SamplerRecording {
 public:
  SamplerRecording(HalPins& pins, int n, const std::string& path);
  std::vector<std::vector<double>> rows(std::chrono::seconds timeout);

 private:
  std::string path_;
  std::unique_ptr<Child> child_;
};

}  // namespace machplan::test
