// Rapid planning time round a few no-go zones (solvers/motion/rapid_planner.h).
// Run: build/bench/bench/rapids_bench (a Release build with -DMACHPLAN_BENCH=ON).
// Results are saved in bench/results/rapids.txt with the machine they ran on.
//
// Scenes, all on a 5 mm clearance:
//   Straight5       a clear rapid beside five zones: the exact straight check only
//   OneClamp        a 100 x 40 mm clamp across a 300 mm rapid
//   ThreeZones      two clamps and a round cut part (arcs) across a 600 mm rapid
//   FiveZones       four clamps and a cut part with a hole-like notch, 900 mm rapid
//   NestedSheet     plan_rapids on the whole nested sheet (datasets/parts/nested_sheet.ngc):
//                   65 rapids, the parts' outlines as zones, the holes' slugs crossed;
//                   counters: straight and final rapid length, detours and their extra mm
// Each planned scene runs with the defaults (3 attempts, shorten, smooth), with one
// attempt, and without shortening or smoothing (the bare RRT-Connect search). Counters:
// length and straight length of the result, mm; samples drawn; polyline vertices.
#include <benchmark/benchmark.h>

#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "solvers/motion/rapid_planner.h"
#include "solvers/motion/rapids.h"

namespace {

using machplan::Contour;
using machplan::motion::plan_rapid;
using machplan::motion::RapidOptions;
using machplan::motion::RapidPlan;
using Eigen::Vector2d;

Contour box(double x0, double y0, double x1, double y1) {
  return Contour({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, {0, 0, 0, 0});
}

struct Scene {
  Vector2d from, to;
  std::vector<Contour> zones;
};

Scene one_clamp() { return {{-150, 0}, {150, 0}, {box(-50, -20, 50, 20)}}; }

Scene three_zones() {
  return {{0, 100}, {600, 120}, {box(120, 60, 160, 150), Contour::circle({300, 110}, 45), box(430, 20, 470, 180)}};
}

Scene five_zones() {
  // Clamps along the sheet edge and across the path, plus a cut part with a notch.
  Contour part({{350, 40}, {520, 40}, {520, 200}, {450, 200}, {450, 120}, {420, 120}, {420, 200}, {350, 200}},
               {0, 0, 0, 0, 0, 0, 0.4, 0});
  return {{0, 110},
          {900, 130},
          {box(100, 60, 140, 180), box(200, -20, 240, 130), part, box(600, 90, 650, 300), box(720, 0, 760, 150)}};
}

void run(benchmark::State& state, const Scene& scene, const RapidOptions& o) {
  RapidPlan p;
  for (auto _ : state) {
    machplan::Termination never;
    p = plan_rapid(scene.from, scene.to, scene.zones, o, never);
    benchmark::DoNotOptimize(p.polyline.data());
  }
  if (!p.ok()) state.SkipWithError(p.message.c_str());
  state.counters["length_mm"] = p.length_mm;
  state.counters["straight_mm"] = p.straight_length_mm;
  state.counters["samples"] = p.samples;
  state.counters["vertices"] = static_cast<double>(p.polyline.size());
}

RapidOptions variant(int v) {
  RapidOptions o;
  if (v == 1) o.attempts = 1;
  if (v == 2) o.attempts = 1, o.simplify = false, o.smooth = false;
  return o;
}

void BM_Straight5(benchmark::State& state) {
  Scene s = five_zones();
  s.from = {0, 400}, s.to = {900, 420};
  run(state, s, RapidOptions{});
}
BENCHMARK(BM_Straight5)->Unit(benchmark::kMicrosecond);

void BM_OneClamp(benchmark::State& state) { run(state, one_clamp(), variant(state.range(0))); }
BENCHMARK(BM_OneClamp)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_ThreeZones(benchmark::State& state) { run(state, three_zones(), variant(state.range(0))); }
BENCHMARK(BM_ThreeZones)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_FiveZones(benchmark::State& state) { run(state, five_zones(), variant(state.range(0))); }
BENCHMARK(BM_FiveZones)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

void BM_NestedSheet(benchmark::State& state) {
  machplan::motion::JobOptions jo;
  jo.rapid_feed_mm_per_s = 80.0;
  const machplan::motion::Job job =
      machplan::motion::make_job(machplan::read_gcode_file(MACHPLAN_SOURCE_DIR "/datasets/parts/nested_sheet.ngc"), jo);
  RapidOptions o;
  o.bounds = Eigen::AlignedBox2d(Vector2d(0, 0), Vector2d(2800, 2800));  // the gantry's travel
  machplan::motion::RapidsReport r;
  for (auto _ : state) {
    machplan::motion::Job j = job;
    machplan::Termination never;
    r = machplan::motion::plan_rapids(j, {}, o, true, never);
    benchmark::DoNotOptimize(j.stretches.data());
  }
  if (!r.ok()) state.SkipWithError("a rapid without a clear route");
  state.counters["rapids"] = static_cast<double>(r.rapids.size());
  state.counters["straight_mm"] = r.straight_length_mm;
  state.counters["final_mm"] = r.length_mm;
  state.counters["detours"] = static_cast<double>(r.detours);
  state.counters["extra_mm"] = r.detour_extra_mm;
}
BENCHMARK(BM_NestedSheet)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
