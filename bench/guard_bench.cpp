// Cost of the hybrid guard's tick (engine/executor/guard.h), which runs inside the executor's
// 1 ms servo period with at most ten region queries.
//
//   BM_GuardTick/strategy/profile  one Guard::filter() call while an operator pushes the table
//                                  (ideal plant: the table is where the setpoint was a period
//                                  ago) at 100 mm/s into the part and along it, over and over:
//                                  far from the boundary, braking, sliding, held. Profiles: the
//                                  paper's triangle (3 spans) and heptagon (7), from outside.
//
// Results: bench/results/guard.txt.
#include <benchmark/benchmark.h>

#include "engine/executor/guard.h"
#include "engine/programs/dxf.h"
#include "models/cutting/machine_config.h"

namespace {

using namespace machplan;
using namespace machplan::executor;

void BM_GuardTick(benchmark::State& state, GuardStrategy strategy, const char* profile) {
  const auto pr = read_dxf_profile(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/profiles/" + profile + ".dxf");
  std::vector<Contour> contours;
  for (const auto& c : pr.contours) contours.push_back(c.contour);
  RegionOptions ro;
  ro.tool_radius_mm = 5;
  const ProhibitedRegion region = ProhibitedRegion::build(contours, ro);
  const MachineSetup setup =
      cutting::load_machine(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/xy_table.yaml").setup();
  GuardOptions go;
  go.strategy = strategy;
  go.tolerance_mm = 0.5;
  Guard g(region, go, setup, 0.001);
  Eigen::AlignedBox2d box;
  for (const Contour& c : region.boundary()) box.extend(bounding_box(c));
  const Eigen::Vector2d start(box.center().x(), box.min().y() - 30.0);
  g.reset(start);
  Eigen::Vector2d at = start, prev = start;
  long k = 0;
  for (auto _ : state) {
    // 2 s pushing up into the part at an angle (approach, brake, slide), then 1 s back.
    const long phase = k++ % 3000;
    Demand d;
    d.kind = Demand::Kind::track;
    d.track.v_ff_mm_per_s[0] = phase < 2000 ? 30.0 : -30.0;
    d.track.v_ff_mm_per_s[1] = phase < 2000 ? 95.0 : -95.0;
    g.filter(d, at, Eigen::Vector2d::Zero());
    at = prev;
    prev = d.commanded_mm;
    benchmark::DoNotOptimize(d);
  }
  state.counters["failsafe_ticks"] = static_cast<double>(g.counters().failsafe_ticks);
}

BENCHMARK_CAPTURE(BM_GuardTick, paper / triangle, GuardStrategy::paper, "paper_triangle");
BENCHMARK_CAPTURE(BM_GuardTick, predictive / triangle, GuardStrategy::predictive, "paper_triangle");
BENCHMARK_CAPTURE(BM_GuardTick, predictive / heptagon, GuardStrategy::predictive, "paper_heptagon");
BENCHMARK_CAPTURE(BM_GuardTick, predictive / arc_profile, GuardStrategy::predictive, "arc_profile");

}  // namespace

BENCHMARK_MAIN();
