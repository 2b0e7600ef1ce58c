#include "engine/executor/trace.h"

#include <algorithm>
#include <chrono>
#include <memory>
#include <string_view>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/executor/executor.h"

namespace machplan::executor {

std::size_t format_trace_csv(const TraceSample& s, char* buf, std::size_t size) {
  const auto r = fmt::format_to_n(buf, size, "{:.4f},{},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{},{},{:d},{:d},{:d},{:.4f},{:.4f},{:.2f}\n",
                                  s.t_s, s.step, s.commanded_mm.x(), s.commanded_mm.y(), s.measured_mm.x(),
                                  s.measured_mm.y(), s.true_mm.x(), s.true_mm.y(), s.dac_x, s.dac_y, s.drives_enabled,
                                  s.torch_fire, s.arc_ok, s.torch_height_mm, s.torch_gap_mm, s.arc_voltage_v);
  return std::min(r.size, size);
}

void TraceRecorder::prepare(std::vector<TraceSample>& into, std::size_t samples) {
  buf_ = &into;
  n_ = 0;
  truncated_ = false;
  // resize() value-initialises every sample: each page is written once here, not in the tick.
  into.assign(std::min(samples, kMaxInMemorySamples), TraceSample{});
}

TraceStream::TraceStream(const std::string& path, std::size_t ring_samples) : path_(path) {
  std::size_t n = 1;
  while (n < ring_samples) n <<= 1;
  ring_.assign(n, TraceSample{});  // touched now, not in the tick
  mask_ = n - 1;
  // Streamed into a temporary beside `path`, renamed into place by close(): a run that fails
  // to write its trace leaves no partial file and an old trace as it was.
  out_ = std::make_unique<AtomicOutput>(path);
  file_ = out_->stream();
  if (std::fputs(kTraceCsvHeader, file_) < 0) write_failed_.store(true);
  thread_ = std::thread([this] { writer(); });
}

TraceStream::~TraceStream() {
  // Not closed: the writer stops and the temporary goes (AtomicOutput's destructor); the
  // target is left as it was.
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void TraceStream::writer() {
  char line[256];
  for (;;) {
    const std::size_t h = head_.load(std::memory_order_acquire);
    std::size_t t = tail_.load(std::memory_order_relaxed);
    if (t == h) {
      if (stop_.load(std::memory_order_acquire) && head_.load(std::memory_order_acquire) == t) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      continue;
    }
    for (; t != h; ++t) {
      const std::size_t len = format_trace_csv(ring_[t & mask_], line, sizeof line);
      if (std::fwrite(line, 1, len, file_) != len) write_failed_.store(true);
      ++written_;
      tail_.store(t + 1, std::memory_order_release);
    }
  }
}

void TraceStream::close() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  if (file_) {
    file_ = nullptr;
    // A failed write stuck to the stream; commit() finds it with its reason (OutputError).
    out_->commit();
  }
}

void ExecutionResult::write_trace_csv(const std::string& path) const {
  AtomicOutput out(path);
  out.write(kTraceCsvHeader);
  char line[256];
  for (const TraceSample& s : trace) out.write(std::string_view(line, format_trace_csv(s, line, sizeof line)));
  out.commit();
}

}  // namespace machplan::executor
