// Geometry of the hybrid guard: invasion checks and building the prohibited region.
//
// Queries: the paper's three invasion checks (point matrix, angle sum, x interval + point to
// segment distance; engine/geometry/invasion.h) against ProhibitedRegion::query() (a BVH over
// the boundary spans), on profiles of 10, 1 000 and 100 000 segments, one thread. Two sets of
// query points, 4096 each, made outside the timing and cycled: "near", within 20 mm of the
// boundary (where a guard works: it only needs exact answers close to the part), and "box",
// uniform over the profile's bounding box grown by 10 % (most points hundreds of mm away);
// "near" and "box" jump across the whole profile at every query, so at 100 000 segments most
// of each query's tree walk misses the caches. "path" is what a guard asks: 4096 consecutive
// tool-centre points of one stroke 0.02 mm apart (1 kHz at 20 mm/s) weaving within 20 mm of
// the boundary.
// items_per_second is queries per second on one core.
//
// Build: ProhibitedRegion::build (checks, offset, merge, index) of the 100 000-segment profile
// with either offset method, and offset_contour alone (the O(n^2) offset this replaced took
// minutes at this size).
//
// Run: build/release/bench/guard_geometry_bench. Results: bench/results/guard_geometry.txt.
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "engine/geometry/invasion.h"
#include "engine/geometry/offset.h"
#include "engine/geometry/region.h"

namespace {

using Eigen::Vector2d;
using machplan::Contour;
constexpr double kPi = std::numbers::pi;
constexpr double kToolRadiusMm = 5.0;

// A wavy closed polygon of n vertices about the origin, radius about 1000 mm: concave and
// convex corners, counter-clockwise.
Contour wavy(long n) {
  std::vector<Vector2d> v;
  for (long k = 0; k < n; ++k) {
    const double t = 2 * kPi * static_cast<double>(k) / static_cast<double>(n);
    const double r = 1000.0 * (1.0 + 0.15 * std::sin(5 * t) + 0.04 * std::sin(17 * t));
    v.emplace_back(r * std::cos(t), r * std::sin(t));
  }
  return Contour(v, std::vector<double>(v.size(), 0.0));
}

machplan::RegionOptions options(machplan::OffsetMethod m = machplan::OffsetMethod::robust) {
  machplan::RegionOptions o;
  o.side = machplan::MachiningSide::outside;
  o.tool_radius_mm = kToolRadiusMm;
  o.method = m;
  return o;
}

struct Fixture {
  machplan::ProhibitedRegion region;
  std::vector<Vector2d> near, box, path;
};

// Built once per size and reused by every method.
const Fixture& fixture(long n) {
  static std::map<long, std::unique_ptr<Fixture>> cache;
  auto& f = cache[n];
  if (f) return *f;
  f = std::make_unique<Fixture>();
  const Contour c = wavy(n);
  f->region = machplan::ProhibitedRegion::build({c}, options());
  std::mt19937 rng(42);
  const auto bb = machplan::bounding_box(c);
  const Vector2d grow = 0.1 * bb.sizes();
  std::uniform_real_distribution<double> ux(bb.min().x() - grow.x(), bb.max().x() + grow.x());
  std::uniform_real_distribution<double> uy(bb.min().y() - grow.y(), bb.max().y() + grow.y());
  std::uniform_real_distribution<double> off(-20.0, 20.0), along(0.0, machplan::perimeter(c));
  for (int i = 0; i < 4096; ++i) {
    f->box.emplace_back(ux(rng), uy(rng));
    const double s = along(rng), ds = 1e-3;
    const Vector2d p = machplan::point_at_length(c, s), q = machplan::point_at_length(c, s + ds);
    const Vector2d t = (q - p).normalized();
    f->near.push_back(p + off(rng) * Vector2d(t.y(), -t.x()));
  }
  // One stroke: 4096 consecutive samples 0.02 mm apart along the boundary (a guard ticking at
  // 1 kHz while the table moves at 20 mm/s), weaving between 20 mm outside and 20 mm inside.
  const double s0 = along(rng);
  for (int i = 0; i < 4096; ++i) {
    const double s = s0 + 0.02 * i, ds = 1e-3;
    const Vector2d p = machplan::point_at_length(c, s), q = machplan::point_at_length(c, s + ds);
    const Vector2d t = (q - p).normalized();
    f->path.push_back(p + 20.0 * std::sin(2 * kPi * i / 1024.0) * Vector2d(t.y(), -t.x()));
  }
  return *f;
}

template <class Check>
void run(benchmark::State& state, const Check& check, const std::vector<Vector2d>& pts) {
  std::size_t i = 0, bad = 0;
  for (auto _ : state) {
    const auto a = check(pts[i]);
    benchmark::DoNotOptimize(a);
    bad += a;
    i = (i + 1) & 4095;
  }
  benchmark::DoNotOptimize(bad);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["segments"] = static_cast<double>(state.range(0));
}

const std::vector<Vector2d>& points(const Fixture& f, benchmark::State& state) {
  return state.range(1) == 0 ? f.near : state.range(1) == 1 ? f.box : f.path;
}
void label(benchmark::State& state) {
  state.SetLabel(state.range(1) == 0 ? "near" : state.range(1) == 1 ? "box" : "path");
}

void BM_Query_Ours(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  label(state);
  run(state, [&](const Vector2d& p) { return f.region.query(p).signed_distance_mm < 0; }, points(f, state));
}
void BM_Query_IntervalDistance(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  const machplan::IntervalDistanceCheck check(f.region);
  label(state);
  run(state, [&](const Vector2d& p) { return check.check(p).prohibited; }, points(f, state));
}
void BM_Query_AngleSum(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  const machplan::AngleSumCheck check(f.region);
  label(state);
  run(state, [&](const Vector2d& p) { return check.check(p).prohibited; }, points(f, state));
}
void BM_Query_PointMatrix(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  const machplan::PointMatrixCheck check(f.region, 1.0);  // E = 1 mm
  label(state);
  state.counters["samples"] = static_cast<double>(check.samples());
  run(state, [&](const Vector2d& p) { return check.check(p).prohibited; }, points(f, state));
}

void query_args(benchmark::internal::Benchmark* b) {
  for (long n : {10L, 1000L, 100000L})
    for (long set : {0L, 1L, 2L}) b->Args({n, set});
}
BENCHMARK(BM_Query_Ours)->Apply(query_args);
BENCHMARK(BM_Query_IntervalDistance)->Apply(query_args);
BENCHMARK(BM_Query_AngleSum)->Apply(query_args);
BENCHMARK(BM_Query_PointMatrix)->Apply(query_args);

void BM_RegionBuild(benchmark::State& state) {
  const Contour c = wavy(state.range(0));
  const auto m = state.range(1) == 0 ? machplan::OffsetMethod::robust : machplan::OffsetMethod::paper;
  state.SetLabel(machplan::to_string(m));
  for (auto _ : state) {
    const auto r = machplan::ProhibitedRegion::build({c}, options(m));
    benchmark::DoNotOptimize(r.boundary().data());
  }
  state.counters["segments"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_RegionBuild)->Args({1000, 0})->Args({100000, 0})->Args({100000, 1})->Unit(benchmark::kMillisecond);

void BM_OffsetContour(benchmark::State& state) {
  const Contour c = wavy(state.range(0));
  for (auto _ : state) {
    const auto r = machplan::offset_contour(c, kToolRadiusMm);
    benchmark::DoNotOptimize(r.contours.data());
  }
  state.counters["segments"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_OffsetContour)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
