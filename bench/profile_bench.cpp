// DXF profile reading at scale: chaining many loose segments into one contour, and checking
// many separate contours against each other (overlaps and nesting). Both were quadratic
// once; they now go through an end-point grid and a sweep over bounding boxes.
// Run: build/release/bench/profile_bench. Results: bench/results/profile.txt.
#include <sys/resource.h>

#include <cmath>
#include <numbers>
#include <string>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "engine/programs/dxf.h"

namespace {

constexpr double kPi = std::numbers::pi;

std::string header() { return "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n"; }
std::string footer() { return "0\nENDSEC\n0\nEOF\n"; }

// An n-gon of radius 1000 mm as n LINE entities in scrambled order, every third reversed.
std::string scrambled_polygon(long n) {
  std::string s = header();
  for (long k = 0; k < n; ++k) {
    const long i = (k * 7919) % n;  // 7919 is prime and divides none of the sizes used
    const double a0 = 2 * kPi * static_cast<double>(i) / static_cast<double>(n);
    const double a1 = 2 * kPi * static_cast<double>(i + 1) / static_cast<double>(n);
    double x0 = 1000 * std::cos(a0), y0 = 1000 * std::sin(a0), x1 = 1000 * std::cos(a1), y1 = 1000 * std::sin(a1);
    if (i % 3 == 0) {
      std::swap(x0, x1);
      std::swap(y0, y1);
    }
    s += fmt::format("0\nLINE\n5\n{:X}\n10\n{:.9f}\n20\n{:.9f}\n11\n{:.9f}\n21\n{:.9f}\n", i + 16, x0, y0, x1, y1);
  }
  return s + footer();
}

// n circles of radius 4 on a square grid 10 mm apart: separate parts, none nested.
std::string circle_grid(long n) {
  const auto side = static_cast<long>(std::ceil(std::sqrt(static_cast<double>(n))));
  std::string s = header();
  for (long i = 0; i < n; ++i)
    s += fmt::format("0\nCIRCLE\n5\n{:X}\n10\n{}\n20\n{}\n40\n4\n", i + 16, 10 * (i % side), 10 * (i / side));
  return s + footer();
}

double max_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

void BM_ChainScrambledSegments(benchmark::State& state) {
  const std::string text = scrambled_polygon(state.range(0));
  for (auto _ : state) {
    const auto r = machplan::read_dxf_profile_text(text, "polygon.dxf");
    if (r.contours.size() != 1 || r.has_errors()) state.SkipWithError("the polygon did not close into one contour");
    benchmark::DoNotOptimize(r.contours.data());
  }
  state.counters["segments"] = static_cast<double>(state.range(0));
  state.counters["max_rss_MB"] = max_rss_mb();
}
BENCHMARK(BM_ChainScrambledSegments)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_SeparateCircles(benchmark::State& state) {
  const std::string text = circle_grid(state.range(0));
  for (auto _ : state) {
    const auto r = machplan::read_dxf_profile_text(text, "circles.dxf");
    if (r.contours.size() != static_cast<std::size_t>(state.range(0)) || r.has_errors())
      state.SkipWithError("the circles were not read as separate contours");
    benchmark::DoNotOptimize(r.contours.data());
  }
  state.counters["circles"] = static_cast<double>(state.range(0));
  state.counters["max_rss_MB"] = max_rss_mb();
}
BENCHMARK(BM_SeparateCircles)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
