// The executor's trace: one sample per servo period (or every n-th), recorded without ever
// faulting a page or allocating inside the tick.
//
//   TraceRecorder  into a vector sized before the first tick and written through once
//                  (pre-touched), so that every page exists before the loop starts; when it is
//                  full, further samples are dropped and the trace is marked truncated. At most
//                  `kMaxInMemorySamples` samples (about 30 minutes at 1 kHz).
//   TraceStream    a CSV file written while the run goes on, for sessions of any length: the
//                  tick pushes each sample into a pre-touched single-producer single-consumer
//                  ring (two atomics, no lock) and a writer thread drains it to the file. A
//                  full ring never blocks a real-time tick: the sample is dropped and counted
//                  (a simulation faster than real time waits for the writer instead).
// CSV columns (both): t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm,meas_y_mm,true_x_mm,true_y_mm,
// dac_x,dac_y,enabled,torch_fire,arc_ok,torch_height_mm,torch_gap_mm (truth; nan: unknown),arc_v
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "engine/common/output_file.h"

namespace machplan::executor {

struct TraceSample {
  double t_s = 0.0;
  int step = -1;
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d measured_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d true_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::int32_t dac_x = 0, dac_y = 0;
  bool drives_enabled = false;
  bool torch_fire = false;
  bool arc_ok = false;
  double torch_height_mm = 0.0;  // the height axis' position (0 without one)
  double torch_gap_mm = std::numeric_limits<double>::quiet_NaN();  // the backend's truth: torch to plate
  double arc_voltage_v = 0.0;    // plasma: as measured (0: none)
};

inline constexpr const char* kTraceCsvHeader =
    "t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm,meas_y_mm,true_x_mm,true_y_mm,dac_x,dac_y,enabled,torch_fire,arc_ok,"
    "torch_height_mm,torch_gap_mm,arc_v\n";
// One CSV line (with its newline) into `buf`; returns its length.
std::size_t format_trace_csv(const TraceSample& s, char* buf, std::size_t size);

class TraceRecorder {
 public:
  static constexpr std::size_t kMaxInMemorySamples = 2'000'000;
  // Sizes and touches the buffer for `samples` samples (capped). Not real time.
  void prepare(std::vector<TraceSample>& into, std::size_t samples);
  // Real time: stores one sample, or drops it when full.
  void record(const TraceSample& s) noexcept {
    if (n_ >= buf_->size()) {
      truncated_ = true;
      return;
    }
    (*buf_)[n_++] = s;
  }
  // After the run: shrinks the vector to the samples recorded.
  void finish() {
    if (buf_) buf_->resize(n_);
  }
  bool truncated() const { return truncated_; }

 private:
  std::vector<TraceSample>* buf_ = nullptr;
  std::size_t n_ = 0;
  bool truncated_ = false;
};

class TraceStream {
 public:
  // Opens a temporary beside `path` (throws OutputError naming it when it cannot) and starts
  // the writer thread. `ring_samples` is rounded up to a power of two. The trace appears
  // under `path` only when close() succeeds (engine/common/output_file.h).
  explicit TraceStream(const std::string& path, std::size_t ring_samples = 1u << 16);
  ~TraceStream();
  TraceStream(const TraceStream&) = delete;
  TraceStream& operator=(const TraceStream&) = delete;

  // Producer side (one thread); never allocates. With `may_wait` false (a real-time loop) it
  // never blocks: a full ring drops the sample. With `may_wait` (a simulation running faster
  // than real time, where nothing depends on the loop's timing) it yields until the writer
  // has made room, so that no sample is lost.
  void push(const TraceSample& s, bool may_wait) noexcept {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    while (h - tail_.load(std::memory_order_acquire) >= ring_.size()) {
      if (!may_wait || write_failed_.load(std::memory_order_relaxed)) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return;
      }
      std::this_thread::yield();
    }
    ring_[h & mask_] = s;
    head_.store(h + 1, std::memory_order_release);
  }
  // Drains what is left, stops the writer and renames the file into place; throws
  // OutputError (the system's reason) on a write error, leaving no file. Called once after the
  // run (without it the destructor stops the writer and removes the temporary).
  void close();
  std::size_t written() const { return written_; }
  std::size_t dropped() const { return dropped_.load(); }
  const std::string& path() const { return path_; }

 private:
  void writer();
  std::string path_;
  std::unique_ptr<AtomicOutput> out_;  // the temporary the writer fills, renamed by close()
  std::FILE* file_ = nullptr;
  std::vector<TraceSample> ring_;
  std::size_t mask_ = 0;
  std::atomic<std::size_t> head_{0}, tail_{0}, dropped_{0};
  std::atomic<bool> stop_{false};
  std::size_t written_ = 0;
  std::atomic<bool> write_failed_{false};
  std::thread thread_;
};

}  // namespace machplan::executor
