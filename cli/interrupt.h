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
//   ProgressWatch   a ProgressBar fed from another thread's progress (an atomic share that a
//                   real-time loop stores and must not draw itself): polled ten times a
//                   second by a thread of its own until the watch goes.
#pragma once

#include <atomic>
#include <csignal>
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
  void update(double fraction);
  // Clears the bar now (the work is over but the command goes on); later updates draw nothing.
  void done();
  // Whether it draws at all (wanted, and stderr is a terminal).
  bool drawing() const noexcept { return on_; }

 private:
  std::string label_;
  bool on_ = false, drawn_ = false;
  double last_s_ = -1.0, start_s_ = 0.0;
};

class ProgressWatch {
 public:
  // Watches `share` (0 .. 1) under `label`; draws nothing unless `wanted` (see ProgressBar).
  ProgressWatch(std::string label, bool wanted, const std::atomic<double>& share);
  // Watches a Progress (engine/common/progress.h) the same way.
  ProgressWatch(std::string label, bool wanted, const Progress& progress);
  ~ProgressWatch();
  ProgressWatch(const ProgressWatch&) = delete;
  ProgressWatch& operator=(const ProgressWatch&) = delete;

 private:
  void start();
  ProgressBar bar_;
  const std::atomic<double>& share_;
  const Progress* progress_ = nullptr;
  std::atomic<bool> over_{false};
  std::thread thread_;
};

}  // namespace machplan::cli
