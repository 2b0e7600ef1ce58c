// Cooperative cancellation of long work: a StopSource owns a flag; StopTokens read it. Setting
// the flag is a single lock-free atomic store, safe from another thread and from a signal
// handler (std::atomic<bool> is always lock-free on our targets). Work that takes a token
// checks it at points where stopping is safe (the executor: once per servo period, after
// which it stops the machine in a controlled way and reports).
//
// Work with no safe partial answer (rapid and feed planning before a run, an interference
// check) throws Cancelled instead: a kind of Infeasible (engine/common/error.h), so the CLI
// reports it and exits 3.
#pragma once

#include <atomic>

#include "engine/common/error.h"

namespace machplan {

class StopToken {
 public:
  StopToken() = default;
  explicit StopToken(const std::atomic<bool>* flag) : flag_(flag) {}
  bool stop_requested() const noexcept { return flag_ && flag_->load(std::memory_order_relaxed); }
  // Whether a StopSource stands behind this token.
  bool bound() const noexcept { return flag_ != nullptr; }

 private:
  const std::atomic<bool>* flag_ = nullptr;
};

class StopSource {
 public:
  static_assert(std::atomic<bool>::is_always_lock_free);
  void request_stop() noexcept { flag_.store(true, std::memory_order_relaxed); }
  void reset() noexcept { flag_.store(false, std::memory_order_relaxed); }
  bool stop_requested() const noexcept { return flag_.load(std::memory_order_relaxed); }
  StopToken token() const noexcept { return StopToken(&flag_); }

 private:
  std::atomic<bool> flag_{false};
};

class Cancelled : public Infeasible {
 public:
  using Infeasible::Infeasible;
};

}  // namespace machplan
