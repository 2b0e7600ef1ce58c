// Placement speed on the rebuilt HexaM scene (datasets/hexam-paper/scene.yaml, 123,201 poses)
// and on the bundled trunnion scene (datasets/trunnion-5axis/scene.yaml).
// Run: build/bench/bench/placement_bench   (a Release build with -DMACHPLAN_BENCH=ON)
// Results are saved in bench/results/placement.txt with the machine they ran on.
//
//   BM_LoadScene          reading machine, tooling, STL and the tool path
//   BM_Class1             the placement-independent class-1 walk (a fresh checker)
//   BM_DecideAtAnswer     one certified decision over the whole path at the optimal answer
//                         (counter poses_per_s: tool poses certified per second)
//   BM_ReportAtAnswer     the full per-kind report at the answer (minima to 0.25 mm)
//   BM_DenseRecheck       every pose plus 0.5 mm interpolation, exact, no bounds (reference)
//   BM_Optimal/T          `machplan place --threads T` end to end, scene already loaded
//   BM_Paper              the paper's evasion search, scene already loaded
//   BM_AnyRotation/T      `machplan place --rotations any --threads T`
//   BM_Trunnion/T         the trunnion scene's least-travel search
//   BM_TrunnionTime/T     the trunnion scene's least-planned-time search (`--objective time`)
//   BM_WeiLeeTime/T       datasets/wei-lee-2020's least-planned-time search
//   BM_AxisPlanner        one run of the 5-axis feed planner over the trunnion scene's path
#include <benchmark/benchmark.h>

#include "solvers/placement/search/search.h"

namespace {

using namespace machplan;
using namespace machplan::placement;

const std::string kScene = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/hexam-paper/scene.yaml";
const std::string kTrunnion = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/trunnion-5axis/scene.yaml";
const std::string kWeiLee = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/wei-lee-2020/scene.yaml";

const Scene& scene() {
  static const Scene s = load_scene(kScene);
  return s;
}

const Placement& answer() {
  static const Placement p = [] {
    Termination term;
    return place(scene(), PlacementOptions{}, term).placement;
  }();
  return p;
}

void BM_LoadScene(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(load_scene(kScene).tips_mm.size());
}
BENCHMARK(BM_LoadScene)->Unit(benchmark::kMillisecond);

void BM_Class1(benchmark::State& state) {
  Termination term;
  for (auto _ : state) {
    Checker c(scene());
    benchmark::DoNotOptimize(c.class1(0.0, term).clearance_mm);
  }
}
BENCHMARK(BM_Class1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The checker keeps exact values between scans at the same placement; a scan elsewhere (not
// timed) makes every timed scan start cold.
void forget(benchmark::State& state, Checker& c, Termination& term) {
  state.PauseTiming();
  c.decide({0, 0, 0, 0}, {}, term);
  state.ResumeTiming();
}

void BM_DecideAtAnswer(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  Termination term;
  c.class1(0.0, term);
  long queries = 0;
  for (auto _ : state) {
    forget(state, c, term);
    const long before = c.counts().exact_queries;
    if (c.decide(p, {}, term) != Decision::feasible) state.SkipWithError("the answer is not free");
    queries += c.counts().exact_queries - before;
  }
  state.counters["poses_per_s"] =
      benchmark::Counter(static_cast<double>(c.pose_count()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["exact_queries"] = static_cast<double>(queries) / state.iterations();
}
BENCHMARK(BM_DecideAtAnswer)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ReportAtAnswer(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  Termination term;
  c.class1(0.0, term);
  for (auto _ : state) {
    forget(state, c, term);
    benchmark::DoNotOptimize(c.report(p, term).free());
  }
}
BENCHMARK(BM_ReportAtAnswer)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DenseRecheck(benchmark::State& state) {
  const Placement p = answer();
  Checker c(scene());
  Termination term;
  long before = 0, poses = 0;
  for (auto _ : state) {
    before = c.counts().exact_queries;
    benchmark::DoNotOptimize(c.dense_check(p, 0.5, term).free());
    poses = c.counts().exact_queries - before;
  }
  state.counters["poses"] = static_cast<double>(poses);
  state.counters["poses_per_s"] = benchmark::Counter(static_cast<double>(poses) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DenseRecheck)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

void run_search(benchmark::State& state, const Scene& s, PlacementOptions o) {
  o.threads = static_cast<int>(state.range(0));
  PlacementResult r;
  for (auto _ : state) {
    Termination term;
    r = place(s, o, term);
  }
  state.counters["x_mm"] = r.placement.x_mm;
  state.counters["y_mm"] = r.placement.y_mm;
  state.counters["pad_mm"] = r.placement.pad_mm;
  state.counters["rot_deg"] = r.placement.rotation_deg;
  state.counters["placements"] = static_cast<double>(r.placements_examined);
  state.counters["verified"] = r.verified ? 1 : 0;
  if (r.travel && r.centre_travel) {
    state.counters["saving_pct"] = 100.0 * (1.0 - r.travel->linear_mm / r.centre_travel->linear_mm);
    state.counters["time_saving_pct"] = 100.0 * (1.0 - r.travel->time_s / r.centre_travel->time_s);
  }
}

void BM_Optimal(benchmark::State& state) { run_search(state, scene(), PlacementOptions{}); }
BENCHMARK(BM_Optimal)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Paper(benchmark::State& state) {
  PlacementOptions o;
  o.strategy = PlacementOptions::Strategy::paper;
  run_search(state, scene(), o);
}
BENCHMARK(BM_Paper)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_AnyRotation(benchmark::State& state) {
  PlacementOptions o;
  o.any_rotation = true;
  run_search(state, scene(), o);
}
BENCHMARK(BM_AnyRotation)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

void BM_Trunnion(benchmark::State& state) {
  static const Scene s = load_scene(kTrunnion);
  run_search(state, s, PlacementOptions{});
}
BENCHMARK(BM_Trunnion)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

PlacementOptions least_time() {
  PlacementOptions o;
  o.objective = PlacementOptions::Objective::time;
  return o;
}

void BM_TrunnionTime(benchmark::State& state) {
  static const Scene s = load_scene(kTrunnion);
  run_search(state, s, least_time());
}
BENCHMARK(BM_TrunnionTime)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_WeiLeeTime(benchmark::State& state) {
  static const Scene s = load_scene(kWeiLee);
  run_search(state, s, least_time());
}
BENCHMARK(BM_WeiLeeTime)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_AxisPlanner(benchmark::State& state) {
  static const Scene s = load_scene(kTrunnion);
  const Placement centre{0, 0, 0, 0};
  double time_s = 0;
  for (auto _ : state) time_s = axis_travel(s, centre)->time_s;  // the velocity-only time and one plan
  state.counters["planned_s"] = time_s;
  state.counters["poses"] = static_cast<double>(s.tips_mm.size());
}
BENCHMARK(BM_AxisPlanner)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
