// Ordering a job's cuts (solvers/motion/cut_order.h): time and travel.
// Run: build/bench/bench/cut_order_bench (a Release build with -DMACHPLAN_BENCH=ON).
// Results are saved in bench/results/cut_order.txt with the machine they ran on.
//
//   Sheet/N      a sheet of N/5 plates (120 x 80 mm, four holes of 10 to 18 mm, every cut with
//                a lead-in), written in a scrambled order with each plate's outline before its
//                holes, as a naive job would: order_cuts with `optimise` (its time is the
//                figure: 1,000 contours must order in under a second). Counters: cuts, travel
//                as programmed, by nearest neighbour and optimised, the lower bound, mm.
//   NestedSheet  datasets/parts/nested_sheet.ngc in each order (0 program, 1 nearest,
//                2 optimise): the same counters.
#include <benchmark/benchmark.h>

#include <random>
#include <string>

#include <fmt/format.h>

#include "engine/programs/gcode.h"
#include "solvers/motion/cut_order.h"

namespace {

using machplan::motion::CutOrder;
using machplan::motion::CutOrderOptions;
using machplan::motion::order_cuts;

// G-code for `contours` / 5 plates in rows on a 3 m sheet.
std::string sheet(int contours) {
  const int plates = contours / 5;
  std::vector<int> order(static_cast<std::size_t>(plates));
  for (int k = 0; k < plates; ++k) order[static_cast<std::size_t>(k)] = k;
  std::mt19937 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  std::uniform_real_distribution<double> u(0, 1);
  std::string g = "G21 G90 G17 G94\n";
  for (int k : order) {
    const double x = 20 + 135.0 * (k % 20), y = 20 + 95.0 * (k / 20);
    // The outline, clockwise, pierced 6 mm left of its left edge.
    g += fmt::format("G0 X{:.3f} Y{:.3f}\nM3 S1\nG4 P0.5\nG1 X{:.3f} Y{:.3f} F4800\n", x - 6, y + 40, x, y + 40);
    g += fmt::format("G1 X{:.3f} Y{:.3f}\nG1 X{:.3f} Y{:.3f}\nG1 X{:.3f} Y{:.3f}\nG1 X{:.3f} Y{:.3f}\nG1 X{:.3f} Y{:.3f}\nM5\n",
                     x, y + 80, x + 120, y + 80, x + 120, y, x, y, x, y + 40);
    for (int h = 0; h < 4; ++h) {
      const double cx = x + 20 + 27 * h, cy = y + 25 + 30 * u(rng), r = 5 + 4 * u(rng);
      g += fmt::format("G0 X{:.3f} Y{:.3f}\nM3 S1\nG4 P0.5\nG1 X{:.3f} Y{:.3f} F2400\nG3 X{:.3f} Y{:.3f} I{:.3f} J0\nM5\n",
                       cx, cy, cx + r, cy, cx + r, cy, -r);
    }
  }
  return g + "G0 X0 Y0\nM2\n";
}

void counters(benchmark::State& state, const machplan::motion::CutOrderReport& r) {
  state.counters["cuts"] = static_cast<double>(r.cuts);
  state.counters["programmed_mm"] = r.programmed_travel_mm;
  state.counters["nearest_mm"] = r.nearest_travel_mm;
  state.counters["travel_mm"] = r.travel_mm;
  state.counters["bound_mm"] = r.lower_bound_mm;
  state.counters["moved"] = static_cast<double>(r.moved_pierces);
}

void BM_Sheet(benchmark::State& state) {
  const machplan::Program p = machplan::read_gcode(sheet(static_cast<int>(state.range(0))), "sheet.ngc");
  machplan::motion::OrderedProgram o;
  for (auto _ : state) {
    o = order_cuts(p, CutOrderOptions{});
    benchmark::DoNotOptimize(o.program.moves.data());
  }
  if (!o.report.reordered) state.SkipWithError("not reordered");
  counters(state, o.report);
}
BENCHMARK(BM_Sheet)->Arg(65)->Arg(250)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);

void BM_NestedSheet(benchmark::State& state) {
  const machplan::Program p = machplan::read_gcode_file(MACHPLAN_SOURCE_DIR "/datasets/parts/nested_sheet.ngc");
  CutOrderOptions o;
  o.order = state.range(0) == 0 ? CutOrder::program : state.range(0) == 1 ? CutOrder::nearest : CutOrder::optimise;
  machplan::motion::OrderedProgram r;
  for (auto _ : state) {
    r = order_cuts(p, o);
    benchmark::DoNotOptimize(r.program.moves.data());
  }
  counters(state, r.report);
}
BENCHMARK(BM_NestedSheet)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
