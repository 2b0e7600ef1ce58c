// Placement speed on the rebuilt HexaM scene (datasets/hexam-paper/scene.yaml, 123,201 poses).
// Run: build/release/bench/placement_bench
// Results are saved in bench/results/placement.txt with the machine they ran on.
//
//   BM_LoadScene        reading machine, tooling, STL and the tool path
//   BM_Class1           building a Checker: the placement-independent class-1 walk
//   BM_DecideAtAnswer   one certified decision over the whole path at the optimal answer
//                       (counter poses_per_s: tool poses certified per second)
//   BM_ReportAtAnswer   the full per-kind report at the answer (minima to 0.25 mm)
//   BM_DenseRecheck     every pose plus 0.5 mm interpolation, exact, no bounds (reference)
//   BM_Optimal          `machplan place --strategy optimal` end to end, scene already loaded
//   BM_Paper            the paper's evasion search, scene already loaded
#include <benchmark/benchmark.h>

#include "solvers/placement/search.h"

namespace {

using namespace machplan::placement;

const std::string kScene = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/hexam-paper/scene.yaml";

const Scene& scene() {
  static const Scene s = load_scene(kScene);
  return s;
}

const Placement& answer() {
  static const Placement p = [] {
    PlacementOptions o;
    o.strategy = PlacementOptions::Strategy::optimal;
    return place(scene(), o).placement;
  }();
  return p;
}

void BM_LoadScene(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(load_scene(kScene).tips_mm.size());
}
BENCHMARK(BM_LoadScene)->Unit(benchmark::kMillisecond);

void BM_Class1(benchmark::State& state) {
  for (auto _ : state) {
    Checker c(scene());
    benchmark::DoNotOptimize(c.class1().clearance_mm);
  }
}
BENCHMARK(BM_Class1)->Unit(benchmark::kMillisecond);

// The checker keeps exact values between scans at the same placement; a scan elsewhere (not
// timed) makes every timed scan start cold.
void forget(benchmark::State& state, Checker& c) {
  state.PauseTiming();
  c.decide({0, 0, 0, 0}, 0.0);
  state.ResumeTiming();
}

void BM_DecideAtAnswer(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  long queries = 0;
  for (auto _ : state) {
    forget(state, c);
    const long before = c.counts().exact_queries;
    if (c.decide(p, 0.0) != Decision::feasible) state.SkipWithError("the answer is not free");
    queries += c.counts().exact_queries - before;
  }
  state.counters["poses_per_s"] =
      benchmark::Counter(static_cast<double>(c.pose_count()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["exact_queries"] = static_cast<double>(queries) / state.iterations();
}
BENCHMARK(BM_DecideAtAnswer)->Unit(benchmark::kMillisecond);

void BM_ReportAtAnswer(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  for (auto _ : state) {
    forget(state, c);
    benchmark::DoNotOptimize(c.report(p).free());
  }
}
BENCHMARK(BM_ReportAtAnswer)->Unit(benchmark::kMillisecond);

void BM_DenseRecheck(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  long poses = 0;
  for (auto _ : state) poses = c.dense_check(p).counts.exact_queries;
  state.counters["poses"] = static_cast<double>(poses);
  state.counters["poses_per_s"] = benchmark::Counter(static_cast<double>(poses) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DenseRecheck)->Unit(benchmark::kMillisecond)->Iterations(1);

void run_search(benchmark::State& state, PlacementOptions::Strategy strategy) {
  PlacementOptions o;
  o.strategy = strategy;
  PlacementResult r;
  for (auto _ : state) r = place(scene(), o);
  state.counters["x_mm"] = r.placement.x_mm;
  state.counters["y_mm"] = r.placement.y_mm;
  state.counters["pad_mm"] = r.placement.pad_mm;
  state.counters["placements"] = static_cast<double>(r.placements_examined);
  state.counters["verified"] = r.verified ? 1 : 0;
}
void BM_Optimal(benchmark::State& state) { run_search(state, PlacementOptions::Strategy::optimal); }
BENCHMARK(BM_Optimal)->Unit(benchmark::kMillisecond)->UseRealTime();
void BM_Paper(benchmark::State& state) { run_search(state, PlacementOptions::Strategy::paper); }
BENCHMARK(BM_Paper)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
