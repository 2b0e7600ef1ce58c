// Long work that a person can stop and watch, the same way in every command.
//
//   StopOnSignals   while it lives, SIGINT, SIGTERM and SIGHUP set one process-wide stop flag
//                   (a lock-free atomic store, safe in a signal handler) instead of killing the
//                   process; the command's work polls stop_token() and ends in a controlled
//                   way (the executor stops the machine, a search returns `cancelled`), reports
//                   and exits 3. The previous handlers come back when it goes.
//   ProgressBar     a one-line bar on stderr for work longer than about a second, drawn only
//                   when stderr is a terminal and the output is not --json; at most ten
//                   redraws a second, cleared when done (done() or the destructor).
//   ProgressWatch   a ProgressBar fed from the work's Progress (engine/common/progress.h), which
//                   the worker reports into and never draws itself (a real-time loop must
//                   not): polled ten times a second by a thread of its own until the watch goes.
#pragma once

#include <atomic>
#include <csignal>
#include <functional>
#include <string>
#include <thread>

#include "engine/common/progress.h"
#include "engine/common/stop.h"

namespace machplan::cli {

class StopOnSignals {
 public:
  StopOnSignals();
  ~StopOnSignals();
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;
  static StopToken stop_token();

 private:
  struct sigaction old_[3];
};

class ProgressBar {
 public:
  ProgressBar(std::string label, bool wanted);
  ~ProgressBar();
  // `detail` follows the percentage (the best figure so far, say).
  void update(double fraction, const std::string& detail = "");
  // Clears the bar now (the work is over but the command goes on); later updates draw nothing.
  void done();
  // Whether it draws at all (wanted, and stderr is a terminal).
  bool drawing() const noexcept { return on_; }

 private:
  std::string label_;
  bool on_ = false, drawn_ = false;
  int drawn_width_ = 0;  // characters of the widest line drawn
  double last_s_ = -1.0, start_s_ = 0.0;
};

class ProgressWatch {
 public:
  // Watches a Progress (engine/common/progress.h); the bar is cleared once it reads 1. `detail`
  // (from the watching thread) is drawn after the percentage.
  ProgressWatch(std::string label, bool wanted, const Progress& progress, std::function<std::string()> detail = {});
  ~ProgressWatch();
  ProgressWatch(const ProgressWatch&) = delete;
  ProgressWatch& operator=(const ProgressWatch&) = delete;

 private:
  void start();
  ProgressBar bar_;
  std::function<double()> read_;
  std::function<std::string()> detail_;
  bool clear_at_one_ = false;
  std::atomic<bool> over_{false};
  std::thread thread_;
};

}  // namespace machplan::cli
