// Motion benchmarks: the interpolation part of the executor's 1 ms tick (Trajectory::sample),
// feed-planning throughput on a long contour, and the time-optimal reference
// (engine/motion/time_optimal.h) on the same contour's executed path, with its counters: the
// planned duration, the optimum, their ratio and the grid size.
//
// The contour: a 2000-vertex closed "flower" polyline (0.3 to 1.2 mm segments, turning at
// every vertex, so every junction is blended) followed by 200 arcs, run as one stretch on the
// thermal gantry's limits.
#include <cmath>
#include <numbers>

#include <benchmark/benchmark.h>

#include "engine/geometry/contour.h"
#include "engine/motion/feed_planner.h"
#include "engine/motion/time_optimal.h"

namespace {

using namespace machplan;
using namespace machplan::motion;

Stretch long_contour() {
  Stretch st;
  st.cutting = true;
  const int n = 2000;
  std::vector<Eigen::Vector2d> pts;
  for (int k = 0; k <= n; ++k) {
    const double th = 2 * std::numbers::pi * k / n;
    const double r = 150 + 20 * std::sin(7 * th);
    pts.emplace_back(r * std::cos(th), r * std::sin(th));
  }
  for (int k = 0; k < n; ++k) st.segments.push_back(make_segment(pts[k], pts[k + 1], 0.0));
  Eigen::Vector2d at = pts[n];
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector2d next = at + Eigen::Vector2d(0, 5);
    st.segments.push_back(make_segment(at, next, (k % 2) ? 0.4 : -0.4));
    at = next;
  }
  st.feed_mm_per_s.assign(st.segments.size(), 80.0);
  for (std::size_t k = 0; k < st.segments.size(); ++k) st.source_lines.push_back(static_cast<int>(k) + 1);
  return st;
}

void BM_PlanLongContour(benchmark::State& state) {
  const Stretch st = long_contour();
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  double duration = 0;
  for (auto _ : state) {
    auto tr = plan_stretch(st, o);
    duration = tr->duration_s();
    benchmark::DoNotOptimize(tr);
  }
  state.counters["segments"] = static_cast<double>(st.segments.size());
  state.counters["motion_s"] = duration;
  state.SetItemsProcessed(state.iterations() * static_cast<long>(st.segments.size()));
}
BENCHMARK(BM_PlanLongContour)->Unit(benchmark::kMillisecond);

void BM_TimeOptimalLongContour(benchmark::State& state) {
  const PlannerOptions o = PlannerOptions::thermal_gantry();
  const auto tr = plan_stretch_detailed(long_contour(), o);
  TimeOptimalProfile p;
  for (auto _ : state) {
    p = time_optimal_profile(tr->executed_path(), o);
    benchmark::DoNotOptimize(p);
  }
  state.counters["planned_s"] = tr->duration_s();
  state.counters["optimum_s"] = p.time_s;
  state.counters["ratio"] = tr->duration_s() / p.time_s;
  state.counters["grid_points"] = static_cast<double>(p.s_mm.size());
}
BENCHMARK(BM_TimeOptimalLongContour)->Unit(benchmark::kMillisecond);

// One sample per benchmark iteration, 1 ms apart (the servo period), walking through the
// whole trajectory and starting over, as the executor does.
template <class T>
void sample_every_period(benchmark::State& state, const T& trajectory) {
  Setpoint sp;
  double t = 0;
  for (auto _ : state) {
    trajectory.sample(t, sp);
    benchmark::DoNotOptimize(sp);
    t += 0.001;
    if (t > trajectory.duration_s()) t = 0;
  }
}

void BM_SampleLongContour(benchmark::State& state) {
  const auto tr = plan_stretch_detailed(long_contour(), PlannerOptions::thermal_gantry());
  sample_every_period(state, *tr);
  state.counters["phases"] = static_cast<double>(tr->profile().size());
  state.counters["pieces"] = static_cast<double>(tr->executed_path().segments.size());
}
BENCHMARK(BM_SampleLongContour);

// The same on a single line (the cheapest case: no trigonometry).
void BM_SampleLine(benchmark::State& state) {
  Stretch st;
  st.segments.push_back(make_segment({0, 0}, {1000, 300}, 0.0));
  st.feed_mm_per_s = {80.0};
  st.source_lines = {1};
  const auto tr = plan_stretch(st, PlannerOptions::thermal_gantry());
  sample_every_period(state, *tr);
}
BENCHMARK(BM_SampleLine);

}  // namespace

BENCHMARK_MAIN();
