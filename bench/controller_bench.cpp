// Cost of one controller update (engine/control), per kind, on a circle at Koren's 0.96 m/min
// with the path segment and the preview given as the planned source gives them. The inputs are
// precomputed, so the time is the controller's alone; the executor's budget per tick is 50 us
// (engine/executor/executor.h).
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "engine/control/controller_factory.h"

namespace {

using namespace machplan;
using namespace machplan::control;

void BM_ControllerUpdate(benchmark::State& state, const char* kind) {
  ControllerPlant plant;
  for (int i = 0; i < kAxes; ++i) {
    plant.servo[i].kp_per_s = 150;
    plant.servo[i].ki_per_s2 = 3000;
    plant.output_limit_mm_per_s[i] = 1200;
    plant.drive_time_constant_s[i] = 0.004;
    plant.command_latency_ticks[i] = plant.reading_latency_ticks[i] = 1;
  }
  auto c = make_controller(kind, {}, plant);
  static const Segment arc = make_segment({20, 0}, {-20, 0}, 1.0);
  std::vector<ControllerInput> in(4096);
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double t = k * 0.001, w = 0.8;
    in[k].r_mm = {20 * std::cos(w * t), 20 * std::sin(w * t)};
    in[k].v_ff_mm_per_s = {-16 * std::sin(w * t), 16 * std::cos(w * t)};
    in[k].a_ff_mm_per_s2 = {-12.8 * std::cos(w * t), -12.8 * std::sin(w * t)};
    in[k].y_mm = {in[k].r_mm[0] * 1.0001, in[k].r_mm[1] * 0.9999};
    in[k].path = &arc;
    in[k].preview_ticks = ControllerInput::kMaxPreviewTicks;
    for (int j = 0; j < in[k].preview_ticks; ++j)
      in[k].r_preview_mm[j] = {20 * std::cos(w * (t + (j + 1) * 0.001)), 20 * std::sin(w * (t + (j + 1) * 0.001))};
  }
  ControllerOutput out;
  std::size_t k = 0;
  for (auto _ : state) {
    c->update(in[k], out);
    benchmark::DoNotOptimize(out);
    k = (k + 1) & (in.size() - 1);
  }
}
BENCHMARK_CAPTURE(BM_ControllerUpdate, p, "p");
BENCHMARK_CAPTURE(BM_ControllerUpdate, pid, "pid");
BENCHMARK_CAPTURE(BM_ControllerUpdate, pid_ff, "pid_ff");
BENCHMARK_CAPTURE(BM_ControllerUpdate, zpetc, "zpetc");
BENCHMARK_CAPTURE(BM_ControllerUpdate, ccc, "ccc");
BENCHMARK_CAPTURE(BM_ControllerUpdate, flc, "flc");

}  // namespace

BENCHMARK_MAIN();
