// The newest value of something one thread produces and other threads read, handed over
// without making the producer wait: a triple buffer. The producer writes into a spare slot and
// swaps it in with one atomic exchange; a reader swaps the newest slot out the same way. The
// producer never blocks, never allocates and never takes a lock (it may be the executor's
// real-time tick); readers take a mutex among themselves only (read()), so any number of reader
// threads may share one Latest, or a single reader thread reads without one (read_single()).
//
// T must be copyable; a reader sees whole values only (never half of one write and half of
// the next), the newest published when it looks, or the last it saw when nothing new came.
//
// Used both ways: OperatorChannel (engine/hardware/operator_channel.h) carries a panel's
// inputs into the tick; the executor's LiveState (engine/executor/live_state.h) carries the
// tick's state out to a panel.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>

namespace machplan {

template <class T>
class Latest {
 public:
  Latest() = default;
  explicit Latest(const T& initial) { slots_.fill(initial); }
  Latest(const Latest&) = delete;
  Latest& operator=(const Latest&) = delete;

  // The producer (one thread at a time). Lock-free, allocation-free when T's copy is.
  void publish(const T& value) noexcept {
    slots_[back_] = value;
    back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & kIndex;
  }
  // A reader: the newest value published (or the last one read when nothing new came).
  T read() {
    const std::lock_guard<std::mutex> lock(read_);
    return read_single();
  }
  // The same for a Latest with exactly one reader thread ever (the tick reading an operator
  // channel): no lock, no allocation.
  const T& read_single() noexcept {
    if (middle_.load(std::memory_order_acquire) & kFresh)
      front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return slots_[front_];
  }

 private:
  static constexpr std::uint8_t kFresh = 0x4, kIndex = 0x3;
  std::array<T, 3> slots_{};
  std::atomic<std::uint8_t> middle_{1};
  std::uint8_t back_ = 2;   // the producer's spare slot
  std::uint8_t front_ = 0;  // the readers' slot (guarded by read_)
  std::mutex read_;
};

}  // namespace machplan
