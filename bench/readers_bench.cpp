// Reader speed on the bundled data. Run: build/release/bench/readers_bench
// Results are saved in bench/results/readers.txt with the machine they ran on.
#include <benchmark/benchmark.h>

#include "engine/common/text_file.h"
#include "engine/programs/toolpath.h"

namespace {

const std::string kToolPath = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/hexam-paper/toolpath.csv";

void BM_ReadHexamToolPathCsv(benchmark::State& state) {
  const std::string text = machplan::read_text_file(kToolPath);
  for (auto _ : state) {
    const machplan::ToolPath p = machplan::read_toolpath_csv(text, kToolPath);
    benchmark::DoNotOptimize(p.poses.data());
    state.counters["poses"] = static_cast<double>(p.poses.size());
  }
}
BENCHMARK(BM_ReadHexamToolPathCsv)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
