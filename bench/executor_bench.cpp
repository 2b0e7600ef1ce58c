// Cost of the executor's servo tick and of the simulated plant.
//
//   BM_ExecutorTick      one planned-mode move on an ideal, nearly free backend (it only
//                        integrates the commanded speed into counters); time per tick covers
//                        exchange bookkeeping, counter decoding, fault checks, the setpoint
//                        samples, two servo updates, contour bookkeeping and the trace store.
//   BM_ExecutorTickNoTrace the same without recording the trace.
//   BM_ExecutorTickPosition the same move on an ideal position-command backend, without the
//                        trace; ...PlanAhead: a backend that plays the positions planned ahead
//                        (as HAL in position mode), so each tick also plans the next 100
//                        periods (Outputs::ahead_mm).
//   BM_AxisPlantStep     one axis plant, one 1 ms tick (10 substeps), gantry parameters.
//   BM_SimBackendExchange the whole simulated gantry (two plants, torch, height), one tick.
//   BM_TickPercentiles   the nested sheet (65 cuts, about 290 s of machine time) in planned mode
//                        on the simulated gantry, each tick (exchange with the simulator
//                        included) timed on the steady clock: 50th, 99th, 99.9th percentile
//                        and maximum, with the trace in memory (Trace), streamed to a CSV file
//                        (TraceStream) or off (NoTrace). The pages of the trace buffer are
//                        touched before the first tick, so that recording never faults a page
//                        inside the loop. Operated: the same with the operator at work (20
//                        holds and resumes, feed and rapid override steps) and the live state
//                        published each tick.
#include <algorithm>
#include <chrono>

#include <benchmark/benchmark.h>

#include <fmt/format.h>

#include "bench/tick_percentiles.h"
#include "engine/executor/executor.h"
#include "engine/hardware/operator_events.h"
#include "models/axis/plant.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/motion/run.h"
#include "tests/support/forwarding_backend.h"
#include "tests/support/ideal_backend.h"
#include "tests/support/test_trajectory.h"

namespace {

using namespace machplan;

machplan::cutting::MachineConfig gantry() {
  return cutting::load_machine(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
}

// One planned-mode move of 335 mm at 80 mm/s.
const Eigen::Vector2d kFrom(100, 100), kTo(400, 250);
struct LineMove {
  motion::Job job;
  executor::Trajectories tr;
  LineMove() {
    job.source = "bench";
    job.start_mm = kFrom;
    job.stretches.push_back(test::make_stretch(test::polyline_segments({kFrom, kTo}, false), 80, false));
    job.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
    tr.push_back(std::make_unique<test::LineTrajectory>(kFrom, kTo, 80, 500));
  }
};

// Times `run_once` (one whole run; returns its cycle time) each iteration: the time per tick
// of 1 ms (ns_per_tick) and the ticks of a run.
template <class Run>
void time_ticks(benchmark::State& state, Run&& run_once) {
  std::int64_t ticks = 0;
  for (auto _ : state) {
    const double cycle_s = run_once();
    ticks += static_cast<std::int64_t>(std::llround(cycle_s / 0.001));
    benchmark::DoNotOptimize(cycle_s);
  }
  state.counters["ns_per_tick"] =
      benchmark::Counter(static_cast<double>(ticks), benchmark::Counter::kIsRate | benchmark::Counter::kInvert,
                         benchmark::Counter::kIs1000);
  state.counters["ticks"] = static_cast<double>(ticks) / state.iterations();
}

void run_ticks(benchmark::State& state, bool trace) {
  const auto m = gantry();
  auto setup = m.setup();
  for (auto& g : setup.servo) g.following_error_limit_mm = 100;  // the ideal backend has no 0.7 drive
  // Nor the gantry's latencies: the setup must say what the backend does, or the run is refused.
  for (auto& sig : setup.signals) sig.command_latency_ticks = sig.reading_latency_ticks = 0;
  const Eigen::Vector2d a = kFrom;
  const LineMove move;
  const motion::Job& job = move.job;
  const executor::Trajectories& tr = move.tr;
  executor::ExecutorOptions o;
  o.record_trace = trace;
  time_ticks(state, [&] {
    test::IdealDacBackend be(m, a);
    executor::Executor ex(setup, o);
    return ex.run(job, tr, be).cycle_time_s;
  });
}
// The same move, position commands, the trace off; `ahead`: the backend plays positions
// planned ahead.
void run_position_ticks(benchmark::State& state, bool ahead) {
  const auto m = gantry();
  const Eigen::Vector2d a = kFrom;
  const LineMove move;
  const motion::Job& job = move.job;
  const executor::Trajectories& tr = move.tr;
  executor::ExecutorOptions o;
  o.record_trace = false;
  struct PlaysAhead final : test::ForwardingBackend {
    using ForwardingBackend::ForwardingBackend;
    int n = 0;
    int plays_ahead_periods() const override { return n; }
  };
  time_ticks(state, [&] {
    test::IdealPositionBackend inner(m, a);
    PlaysAhead be(inner);
    be.n = ahead ? hardware::Outputs::kMaxAhead : 0;
    executor::Executor ex(m.setup(), o);
    return ex.run(job, tr, be).cycle_time_s;
  });
}
void BM_ExecutorTick(benchmark::State& s) { run_ticks(s, true); }
void BM_ExecutorTickNoTrace(benchmark::State& s) { run_ticks(s, false); }
BENCHMARK(BM_ExecutorTick)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExecutorTickNoTrace)->Unit(benchmark::kMillisecond);
void BM_ExecutorTickPosition(benchmark::State& s) { run_position_ticks(s, false); }
void BM_ExecutorTickPositionPlanAhead(benchmark::State& s) { run_position_ticks(s, true); }
BENCHMARK(BM_ExecutorTickPosition)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExecutorTickPositionPlanAhead)->Unit(benchmark::kMillisecond);

enum class TraceKind { off, memory, stream };

// The operator at work: 20 holds (each released 0.6 s later), feed override steps 50 / 150 /
// 100 %, rapid override 50 %, and the live state published every tick.
std::vector<hardware::OperatorEvent> operator_at_work() {
  std::vector<std::pair<double, std::string>> rows;
  for (int i = 0; i < 20; ++i) {
    rows.emplace_back(10.0 + 15.0 * i, "hold,");
    rows.emplace_back(10.6 + 15.0 * i, "start,");
  }
  rows.emplace_back(50.2, "feed_override,50");
  rows.emplace_back(80.2, "feed_override,150");
  rows.emplace_back(110.2, "feed_override,100");
  rows.emplace_back(140.2, "rapid_override,50");
  std::sort(rows.begin(), rows.end());
  std::string csv = "t_s,event,value\n";
  for (const auto& [t, e] : rows) csv += fmt::format("{},{}\n", t, e);
  return hardware::parse_operator_events(csv, "bench").states;
}

void tick_percentiles(benchmark::State& state, TraceKind kind, bool operated = false) {
  motion::RunOptions o;
  o.session.machine = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml";
  o.session.executor.record_trace = false;
  const motion::RunOutcome prepared =
      motion::run_program(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/nested_sheet.ngc", o);
  std::vector<double> us;
  us.reserve(400000);
  double dropped = 0;
  for (auto _ : state) {
    us.clear();
    executor::ExecutorOptions eo;
    eo.record_trace = kind == TraceKind::memory;
    sim::SimOptions so;
    so.start_mm = prepared.job.start_mm;
    if (operated) so.operator_events = operator_at_work();
    sim::SimBackend sim(prepared.machine, so);
    // Claims real time, as a machine would: the stream then never waits for its writer (a
    // sample is dropped instead), which is the cost a real-time loop pays.
    struct AsIfRealTime final : test::ForwardingBackend {
      using ForwardingBackend::ForwardingBackend;
      bool realtime() const override { return true; }
    } be(sim);
    executor::Executor ex(prepared.machine.setup(), eo);
    std::unique_ptr<executor::TraceStream> stream;
    executor::RunParts parts;
    Latest<executor::LiveState> live;
    if (operated) parts.live = &live;
    if (kind == TraceKind::stream) {
      stream = std::make_unique<executor::TraceStream>("/tmp/machplan_bench_trace.csv");
      parts.trace_stream = stream.get();
    }
    executor::Session s(ex, prepared.job, prepared.trajectories, be, parts);
    for (bool more = true; more;) {
      const auto t0 = std::chrono::steady_clock::now();
      more = s.tick();
      const auto t1 = std::chrono::steady_clock::now();
      us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    }
    const executor::ExecutionResult r = s.finish();
    dropped = static_cast<double>(r.trace_stream_dropped);
    benchmark::DoNotOptimize(r.cycle_time_s);
  }
  bench::report_tick_percentiles(state, us);
  if (kind == TraceKind::stream) state.counters["dropped"] = dropped;
}
void BM_TickPercentilesTrace(benchmark::State& s) { tick_percentiles(s, TraceKind::memory); }
void BM_TickPercentilesTraceStream(benchmark::State& s) { tick_percentiles(s, TraceKind::stream); }
void BM_TickPercentilesNoTrace(benchmark::State& s) { tick_percentiles(s, TraceKind::off); }
void BM_TickPercentilesOperated(benchmark::State& s) { tick_percentiles(s, TraceKind::memory, true); }
BENCHMARK(BM_TickPercentilesTrace)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_TickPercentilesTraceStream)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_TickPercentilesNoTrace)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_TickPercentilesOperated)->Unit(benchmark::kMillisecond)->Iterations(3);

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
