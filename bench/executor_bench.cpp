// Cost of the executor's servo tick and of the simulated plant.
//
//   BM_ExecutorTick      one planned-mode move on an ideal, nearly free backend (it only
//                        integrates the commanded speed into counters); time per tick covers
//                        exchange bookkeeping, counter decoding, fault checks, the setpoint
//                        samples, two servo updates, contour bookkeeping and the trace store.
//   BM_ExecutorTickNoTrace the same without recording the trace.
//   BM_AxisPlantStep     one axis plant, one 1 ms tick (10 substeps), gantry parameters.
//   BM_SimBackendExchange the whole simulated gantry (two plants, torch, height), one tick.
#include <benchmark/benchmark.h>

#include "engine/executor/executor.h"
#include "models/axis/plant.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "tests/support/test_trajectory.h"

namespace {

using namespace machplan;

machplan::cutting::MachineConfig gantry() {
  return cutting::load_machine(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
}

// Moves exactly as commanded; counts like the real counter (down counter, direction bit).
class IdealBackend final : public hardware::Backend {
 public:
  explicit IdealBackend(const cutting::MachineConfig& m, Eigen::Vector2d start) : m_(m), pos_(start) {
    for (int i = 0; i < 2; ++i) count_pos_[i] = static_cast<std::int64_t>(std::floor(pos_[i] / q(i)));
  }
  double period_s() const override { return 0.001; }
  hardware::AxisSignals axis_signals(int a) const override {
    const auto& p = m_.axes[a].plant;
    return {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), 0, 0};
  }
  hardware::Inputs initial_inputs() override { return in_; }
  hardware::Health exchange(const hardware::Outputs& o, hardware::Inputs& in) noexcept override {
    for (int i = 0; i < 2; ++i) {
      const auto& p = m_.axes[i].plant;
      pos_[i] += o.dac_code[i] / double(p.dac_max_code() + 1) * p.dac_full_scale_mm_per_s() * 0.001;
      const auto c = static_cast<std::int64_t>(std::floor(pos_[i] / q(i)));
      const std::int64_t d = c - count_pos_[i];
      if (d != 0) {
        in_.counter[i] = static_cast<std::uint32_t>(in_.counter[i] - (d > 0 ? d : -d)) & 0xFFFFu;
        in_.counter_direction_negative[i] = d < 0;
        count_pos_[i] = c;
      }
    }
    in = in_;
    return hardware::Health::ok;
  }

 private:
  double q(int i) const { return m_.axes[i].plant.mm_per_count(); }
  const cutting::MachineConfig& m_;
  Eigen::Vector2d pos_;
  std::array<std::int64_t, 2> count_pos_{};
  hardware::Inputs in_{};
};

void run_ticks(benchmark::State& state, bool trace) {
  const auto m = gantry();
  auto setup = m.setup();
  for (auto& g : setup.servo) g.following_error_limit_mm = 100;  // the ideal backend has no 0.7 drive
  const Eigen::Vector2d a(100, 100), b(400, 250);
  motion::Job job;
  job.source = "bench";
  job.start_mm = a;
  job.stretches.push_back(test::make_stretch(test::polyline_segments({a, b}, false), 80, false));
  job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  executor::Trajectories tr;
  tr.push_back(std::make_unique<test::LineTrajectory>(a, b, 80, 500));
  executor::ExecutorOptions o;
  o.record_trace = trace;
  std::int64_t ticks = 0;
  for (auto _ : state) {
    IdealBackend be(m, a);
    executor::Executor ex(setup, o);
    const auto r = ex.run(job, tr, be);
    ticks += static_cast<std::int64_t>(std::llround(r.cycle_time_s / 0.001));
    benchmark::DoNotOptimize(r.cycle_time_s);
  }
  state.counters["ns_per_tick"] =
      benchmark::Counter(static_cast<double>(ticks), benchmark::Counter::kIsRate | benchmark::Counter::kInvert,
                         benchmark::Counter::kIs1000);
  state.counters["ticks"] = static_cast<double>(ticks) / state.iterations();
}
void BM_ExecutorTick(benchmark::State& s) { run_ticks(s, true); }
void BM_ExecutorTickNoTrace(benchmark::State& s) { run_ticks(s, false); }
BENCHMARK(BM_ExecutorTick)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExecutorTickNoTrace)->Unit(benchmark::kMillisecond);

void BM_AxisPlantStep(benchmark::State& state) {
  const auto m = gantry();
  axis::AxisPlant p(m.axes[0].plant, 0.0, 1000);
  std::mt19937_64 rng(1);
  int k = 0;
  for (auto _ : state) {
    p.step((k++ % 4000) < 2000 ? 1500 : -1500, true, 0.001, rng);
    benchmark::DoNotOptimize(p.read());
  }
}
BENCHMARK(BM_AxisPlantStep);

void BM_SimBackendExchange(benchmark::State& state) {
  const auto m = gantry();
  sim::SimBackend be(m, {});
  hardware::Outputs o;
  o.drives_enabled = true;
  hardware::Inputs in;
  int k = 0;
  for (auto _ : state) {
    const int c = (k++ % 4000) < 2000 ? 1500 : -1500;
    o.dac_code = {c, -c};
    benchmark::DoNotOptimize(be.exchange(o, in));
  }
}
BENCHMARK(BM_SimBackendExchange);

}  // namespace

BENCHMARK_MAIN();
