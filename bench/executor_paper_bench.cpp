// The thermal-cutting paper's results beside ours, on the bundled rebuilds of its shapes, and
// the cost of a whole `machplan run`.
//
// Part 1 (printed before the benchmarks): a reproduction report.
//   * Paper modes (paper-open, paper-closed) at the paper's 4 mm/s with x1 encoder decoding:
//     the 45-degree triangle and the contour of lines and arcs, run two ways: the cut alone,
//     from the torch set on its pierce point (as the paper's operator set the work reference
//     point), and the whole program from the machine's home, rapids included (what
//     `machplan run --feed 4` does). Open loop uncalibrated, with the paper's "+30 %", and
//     with a stopwatch calibration measured on the same simulated machine; closed loop over
//     a range of BLU.
//   * Planned mode (ours) at 80 mm/s on the three bundled parts: contour error, cycle time
//     against its lower bound.
// Part 2: Google Benchmark timings of run_program on each bundled part (read, plan, simulate).
//
// Every figure comes from the simulation with seed 1; the run is deterministic.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>

#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "solvers/motion/run.h"

namespace {

using namespace machplan;
using motion::Job;
using motion::RunOptions;
using motion::RunOutcome;
using executor::Mode;

std::string part(const std::string& name) { return std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/" + name; }

Job whole_program(const std::string& name) {
  motion::JobOptions jo;
  jo.rapid_feed_mm_per_s = 80.0;  // the gantry's rapid (datasets/machines/thermal_gantry.yaml)
  return motion::make_job(read_gcode_file(part(name)), jo);
}

// The program's first cut alone: torch on, pierce dwell, the cut, torch off, from its pierce point.
Job cut_only(const std::string& name) {
  const Job all = whole_program(name);
  Job j;
  j.source = all.source;
  for (std::size_t i = 0; i < all.steps.size(); ++i) {
    const motion::Step& s = all.steps[i];
    if (s.kind == motion::Step::Kind::torch_on) {
      for (std::size_t k = i; k < all.steps.size(); ++k) {
        motion::Step t = all.steps[k];
        if (t.kind == motion::Step::Kind::move) {
          j.stretches.push_back(all.stretches[t.stretch]);
          t.stretch = j.stretches.size() - 1;
        }
        j.steps.push_back(t);
        if (t.kind == motion::Step::Kind::torch_off) break;
      }
      break;
    }
  }
  j.start_mm = j.stretches.front().segments.front().start;
  return j;
}

RunOutcome paper(const Job& job, Mode mode, double blu, double factor) {
  RunOptions o;
  o.session.executor.mode = mode;
  o.session.executor.blu_mm = blu;
  o.session.executor.calibration_factor = factor;
  o.session.executor.record_trace = false;
  o.feed_override_mm_per_s = 4.0;
  return motion::run_job(job, o);
}

// The paper's calibration: 100 mm along X at the feed, open loop; factor = programmed / travelled.
double stopwatch_factor() {
  Job j;
  j.source = "calibration";
  j.start_mm = {100, 100};
  motion::Stretch s;
  s.segments = {make_segment({100, 100}, {200, 100}, 0.0)};
  s.feed_mm_per_s = {4.0};
  s.source_lines = {1};
  j.stretches.push_back(s);
  j.steps.push_back({motion::Step::Kind::move, 1, 0, 0.0});
  RunOptions o;
  o.session.executor.mode = Mode::paper_open;
  const RunOutcome r = motion::run_job(j, o);
  return 100.0 / (r.result.trace.back().true_mm.x() - 100.0);
}

void row(const char* shape, const char* how, const char* mode, double blu, double factor, const RunOutcome& r) {
  std::printf("  %-9s %-14s %-13s %5.1f  %6.3f  %8.3f  %8.3f  %7.3f  %s\n", shape, how, mode, blu, factor,
              r.result.max_true_contour_error_mm(), r.result.max_contour_error_mm(), r.rms_true_contour_error_mm,
              r.faulted() ? "FAULTED" : "");
}

void reproduction_report() {
  const double k = stopwatch_factor();
  std::printf("== The paper's modes at 4 mm/s, x1 decoding (0.0995 mm per count), seed 1\n");
  std::printf("  stopwatch calibration factor (100 mm at 4 mm/s, open loop): %.4f  (1 / 0.7 = %.4f)\n\n", k, 1 / 0.7);
  std::printf("  %-9s %-14s %-13s %5s  %6s  %8s  %8s  %7s\n", "shape", "run", "mode", "BLU", "factor", "max true",
              "max enc", "rms true");
  for (const char* name : {"triangle_45.ngc", "contour_lines_arcs.ngc"}) {
    const char* shape = std::string(name) == "triangle_45.ngc" ? "triangle" : "contour";
    for (int whole = 0; whole < 2; ++whole) {
      const Job job = whole ? whole_program(name) : cut_only(name);
      const char* how = whole ? "whole program" : "cut alone";
      for (double f : {1.0, 1.3, k}) row(shape, how, "paper-open", 3.0, f, paper(job, Mode::paper_open, 3.0, f));
      row(shape, how, "paper-open", 20.0, k, paper(job, Mode::paper_open, 20.0, k));
      for (double f : {1.0, k})
        for (double blu : {0.3, 1.0, 3.0, 5.0, 20.0})
          row(shape, how, "paper-closed", blu, f, paper(job, Mode::paper_closed, blu, f));
    }
  }
  std::printf("\n== Planned mode (ours) at 80 mm/s, x4 decoding, every plant effect on, seed 1\n");
  std::printf("  %-24s %5s  %8s  %8s  %8s  %9s  %9s  %7s  %7s\n", "part", "cuts", "max enc", "max true", "rms enc",
              "cycle s", "bound s", "ratio", "motion");
  for (const char* name : {"triangle_45.ngc", "contour_lines_arcs.ngc", "nested_sheet.ngc"}) {
    RunOptions o;
    o.session.executor.record_trace = false;
    const RunOutcome r = motion::run_program(part(name), o);
    std::printf("  %-24s %5zu  %8.4f  %8.4f  %8.4f  %9.2f  %9.2f  %7.4f  %7.4f  %s\n", name, r.result.cuts.size(),
                r.result.max_contour_error_mm(), r.result.max_true_contour_error_mm(), r.rms_contour_error_mm,
                r.result.cycle_time_s, r.lower_bound_s, r.cycle_ratio, r.motion_ratio, r.faulted() ? "FAULTED" : "");
  }
  std::printf("\n");
  std::fflush(stdout);
}

void BM_RunProgram(benchmark::State& state, const char* name) {
  RunOptions o;
  o.session.executor.record_trace = false;
  double simulated = 0;
  for (auto _ : state) {
    const RunOutcome r = motion::run_program(part(name), o);
    simulated = r.result.cycle_time_s;
    benchmark::DoNotOptimize(r.result.cuts.data());
  }
  state.counters["simulated_s"] = simulated;
  state.counters["sim_s_per_wall_s"] = benchmark::Counter(simulated * state.iterations(), benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK_CAPTURE(BM_RunProgram, triangle_45, "triangle_45.ngc")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RunProgram, contour_lines_arcs, "contour_lines_arcs.ngc")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_RunProgram, nested_sheet, "nested_sheet.ngc")->Unit(benchmark::kMillisecond);

int main(int argc, char** argv) {
  // Listing the benchmarks (the test build's check that they start) skips the report.
  bool listing = false;
  for (int i = 1; i < argc; ++i) listing = listing || std::string(argv[i]).starts_with("--benchmark_list_tests");
  if (!listing) reproduction_report();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
