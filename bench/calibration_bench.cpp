// Calibration fit speed: a 60 s session at 1 kHz, both axes, recorded on the simulated
// thermal gantry with its true factors off the nominal machine file.
// Run: build/bench/bench/calibration_bench. Results: bench/results/calibration.txt.
// Goal: one fit under 1 s.
#include <benchmark/benchmark.h>

#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/calibration/fit.h"
#include "solvers/calibration/record.h"

namespace {

using namespace machplan;

const cutting::MachineConfig& nominal() {
  static const auto m = cutting::load_machine(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
  return m;
}

const calibration::SessionLog& session_60s() {
  static const calibration::SessionLog log = [] {
    auto truth = nominal();
    for (auto& a : truth.axes) {
      a.plant.gain_factor = 0.66;
      a.plant.velocity_loop_time_constant_s = 0.014;
      a.plant.backlash_mm = 0.1;
      a.plant.encoder_mm_per_rev = 149.7;
    }
    calibration::RecordOptions o;
    o.stroke_hold_s = 1.2;
    // Repeat the program until it lasts at least 60 s.
    const long one = calibration::record_periods(o, truth.servo_period_s);
    o.repeats = static_cast<int>(60.0 / (one * truth.servo_period_s)) + 1;
    sim::SimBackend backend(truth, {});
    Termination never;
    return calibration::record_session(backend, nominal(), o, never).log;
  }();
  return log;
}

void BM_FitSession60s(benchmark::State& state) {
  const auto& log = session_60s();
  for (auto _ : state) {
    const auto fit = calibration::fit_session(log, nominal());
    benchmark::DoNotOptimize(fit.rms_residual_mm);
    state.counters["feed_x"] = fit.axes[0].feed_factor;
    state.counters["ok"] = fit.summary.done();
  }
  state.counters["session_s"] = log.samples.back().t_s;
  state.counters["rows"] = static_cast<double>(log.samples.size());
}
BENCHMARK(BM_FitSession60s)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
