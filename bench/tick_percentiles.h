// The tail of a run's tick times, as the benches report it: the counters p50_us, p99_us,
// p99.9_us, max_us and ticks of `us` (one duration per tick, microseconds; sorted here).
#pragma once

#include <algorithm>
#include <vector>

#include <benchmark/benchmark.h>

namespace machplan::bench {

inline void report_tick_percentiles(benchmark::State& state, std::vector<double>& us) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  const auto at = [&](double q) { return us[std::min(us.size() - 1, static_cast<std::size_t>(q * us.size()))]; };
  state.counters["p50_us"] = at(0.5);
  state.counters["p99_us"] = at(0.99);
  state.counters["p99.9_us"] = at(0.999);
  state.counters["max_us"] = us.back();
  state.counters["ticks"] = static_cast<double>(us.size());
}

}  // namespace machplan::bench
