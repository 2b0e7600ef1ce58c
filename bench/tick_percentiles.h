// The tail of a series of durations, as the benches report it: the counters p50, p99, p99.9
// and max of `values` (sorted here), each named PREFIX + that + UNIT, and their number as
// `count`. A run's tick times: p50_us, p99_us, p99.9_us, max_us and ticks.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace machplan::bench {

inline void report_percentiles(benchmark::State& state, std::vector<double>& values, const std::string& prefix,
                               const std::string& unit, const std::string& count) {
  if (values.empty()) return;
  std::sort(values.begin(), values.end());
  const auto at = [&](double q) { return values[std::min(values.size() - 1, static_cast<std::size_t>(q * values.size()))]; };
  state.counters[prefix + "p50" + unit] = at(0.5);
  state.counters[prefix + "p99" + unit] = at(0.99);
  state.counters[prefix + "p99.9" + unit] = at(0.999);
  state.counters[prefix + "max" + unit] = values.back();
  state.counters[count] = static_cast<double>(values.size());
}

// One duration per tick, in microseconds.
inline void report_tick_percentiles(benchmark::State& state, std::vector<double>& us) {
  report_percentiles(state, us, "", "_us", "ticks");
}

}  // namespace machplan::bench
