// Before the first tick and after the last: the checks and buffers of a run, and its result.
// The tick itself is in executor.cpp.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/executor/session_impl.h"
#include "engine/motion/process_time.h"

namespace machplan::executor {

using motion::Step;
using FK = FaultKind;

namespace {
constexpr Spelling kModeNames[] = {{"planned"}, {"paper-open", "paper_open"}, {"paper-closed", "paper_closed"}, {"jog"}};
}  // namespace

const char* to_string(Mode m) { return kModeNames[static_cast<std::size_t>(m)].name.data(); }

Parsed<Mode> parse_mode(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kModeNames, text, "mode", "mode");
  return {static_cast<Mode>(p.value), p.note};
}

void ExecutorOptions::validate() const {
  require_field(std::isfinite(blu_mm) && blu_mm >= 0.01 && blu_mm <= 1000, "blu_mm", blu_mm,
                "is out of range: must be in [0.01, 1000] mm");
  require_field(std::isfinite(calibration_factor) && calibration_factor > 0.1 && calibration_factor <= 10,
                "calibration_factor", calibration_factor, "is out of range: must be in (0.1, 10]");
  require_field(std::isfinite(paper_compute_s) && paper_compute_s >= 0 && paper_compute_s <= 10, "paper_compute_s",
                paper_compute_s, "is out of range: must be in [0, 10] s");
  require_field(std::isfinite(paper_settle_s) && paper_settle_s >= 0 && paper_settle_s <= 60, "paper_settle_s",
                paper_settle_s, "is out of range: must be in [0, 60] s");
  require_field(trace_every_ticks >= 1, "trace_every_ticks", trace_every_ticks, "must be >= 1");
  validate_member("supervisor", supervisor);
  validate_member("jog", jog);
}

// ---------------------------------------------------------------------------------------------

namespace {

double stretch_length(const motion::Stretch& s) {
  double L = 0;
  for (const Segment& seg : s.segments) L += length(seg);
  return L;
}

bool same(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)}); }

// The backend must be the machine the machine file describes.
void check_backend(const MachineSetup& m, double machine_period_s, hardware::Backend& be) {
  const auto fail = [&](const std::string& what) {
    throw InputError(fmt::format("machine '{}'", m.name), 0,
                     fmt::format("backend '{}' disagrees with the machine file: {}", be.name(), what));
  };
  if (!(std::isfinite(be.period_s()) && be.period_s() > 0)) fail(fmt::format("its period {} s is not positive", be.period_s()));
  if (machine_period_s > 0 && !same(be.period_s(), machine_period_s))
    fail(fmt::format("its servo period is {} s, the machine file's {} s", be.period_s(), machine_period_s));
  if (be.watchdog_periods() < 1) fail(fmt::format("its watchdog is {} periods (must be >= 1)", be.watchdog_periods()));
  if (be.command_kind() != hardware::CommandKind::speed_dac) return;  // position backends: no raw signals to agree on
  for (int i = 0; i < hardware::kAxes; ++i) {
    const hardware::AxisSignals b = be.axis_signals(i), f = m.signals[i];
    const char* ax = i == 0 ? "X" : "Y";
    auto num = [&](const char* field, double vb, double vf) {
      if (!same(vb, vf)) fail(fmt::format("axis {} {} is {} on the backend, {} in the machine file", ax, field, vb, vf));
    };
    num("mm_per_count", b.mm_per_count, f.mm_per_count);
    num("counter_bits", b.counter_bits, f.counter_bits);
    num("dac_bits", b.dac_bits, f.dac_bits);
    num("dac_full_scale_mm_per_s", b.dac_full_scale_mm_per_s, f.dac_full_scale_mm_per_s);
    num("command_latency_ticks", b.command_latency_ticks, f.command_latency_ticks);
    num("reading_latency_ticks", b.reading_latency_ticks, f.reading_latency_ticks);
  }
}

}  // namespace

void Session::Impl::prepare(double machine_period_s) {
  check_backend(ms, machine_period_s, be);
  be_realtime = be.realtime();
  ahead_periods = std::clamp(be.plays_ahead_periods(), 0, hardware::Outputs::kMaxAhead);
  const auto fail = [&](int line, const std::string& what) { throw InputError(job.source, line, what); };

  // The source.
  const SourceContext ctx{&job, &trajs, &ms, dt};
  source = parts.source;
  if (!source) {
    switch (opt.mode) {
      case Mode::planned: source = &planned.emplace(); break;
      case Mode::paper_open:
      case Mode::paper_closed:
        source = &blu.emplace(BluVectorOptions{opt.mode == Mode::paper_closed, opt.blu_mm, opt.calibration_factor,
                                               opt.paper_compute_s, opt.paper_zero_first, opt.paper_settle_s});
        break;
      case Mode::jog: source = &jogger.emplace(opt.jog); break;
    }
  }
  if (!source->runs_job() && !job.steps.empty())
    fail(job.steps.front().source_line, fmt::format("the {} source runs no job, but the job has {} steps", source->name(),
                                                     job.steps.size()));

  // The job, independent of the source.
  Eigen::Vector2d at = job.start_mm;
  bool torch_on = false;
  std::size_t probe_steps = 0;
  const TorchSetup& ts = ms.torch;
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const Step& st = job.steps[i];
    switch (st.kind) {
      case Step::Kind::move: {
        if (st.stretch >= job.stretches.size())
          fail(st.source_line, fmt::format("step {} names stretch {} of {}", i, st.stretch, job.stretches.size()));
        const motion::Stretch& s = job.stretches[st.stretch];
        if (s.segments.empty()) fail(st.source_line, fmt::format("stretch {} has no segments", st.stretch));
        if (s.feed_mm_per_s.size() != s.segments.size() || s.source_lines.size() != s.segments.size())
          fail(st.source_line, fmt::format("stretch {}: per-segment feeds and lines must match its segments", st.stretch));
        for (double f : s.feed_mm_per_s)
          if (!(std::isfinite(f) && f > 0)) fail(st.source_line, fmt::format("stretch {}: feed {} is not positive", st.stretch, f));
        if ((s.segments.front().start - at).norm() > 1e-3)
          fail(st.source_line, fmt::format("stretch {} starts at ({:.4f}, {:.4f}) but the tool is at ({:.4f}, {:.4f})",
                                           st.stretch, s.segments.front().start.x(), s.segments.front().start.y(), at.x(),
                                           at.y()));
        if (s.cutting && !torch_on) fail(st.source_line, "cutting move with the torch off (no torch_on step before it)");
        if (!s.cutting) torch_on = false;  // the executor turns the torch off before a non-cutting move
        at = s.segments.back().end;
        break;
      }
      case Step::Kind::torch_on:
        if (ts.kind == TorchSetup::Kind::none)
          fail(st.source_line, fmt::format("torch or spindle on, but machine '{}' has neither", ms.name));
        if (st.material < -1 || st.material >= static_cast<int>(job.materials.size()))
          fail(st.source_line, fmt::format("torch on with material {} of {}", st.material, job.materials.size()));
        torch_on = true;
        break;
      case Step::Kind::torch_off:
        if (ts.kind == TorchSetup::Kind::none)
          fail(st.source_line, fmt::format("torch or spindle off, but machine '{}' has neither", ms.name));
        torch_on = false;
        break;
      case Step::Kind::dwell:
        if (!(std::isfinite(st.seconds) && st.seconds >= 0 && st.seconds <= 3600))
          fail(st.source_line, fmt::format("dwell of {} s (must be 0 .. 3600)", st.seconds));
        break;
      case Step::Kind::probe:
        if (!ts.height_axis || !ts.probe.offset())
          fail(st.source_line, fmt::format("a probe step, but machine '{}' has no offset probe", ms.name));
        if (torch_on) fail(st.source_line, "a probe step with the torch on (no torch_off step before it)");
        ++probe_steps;
        break;
    }
  }
  source->prepare(ctx, job.start_mm);
  // At most: every torch step waits out its timeouts (engine/motion/process_time.h).
  motion::TorchTimes longest;
  longest.torch_on_s = 2 * ts.height_timeout_s + ts.arc_ok_timeout_s + ts.preheat_s + 0.1;
  if (ts.probe.fitted())
    longest.torch_on_s += 2 * ts.height_timeout_s + (ts.probe.probe_height_mm + ts.probe.max_depth_mm) / ts.probe.probe_speed_mm_per_s;
  longest.pierce_s = ts.pierce_delay_s;
  longest.torch_off_s = ts.height_timeout_s;
  double est_s = 1.0 + motion::process_time_s(job, longest) + source->estimate_s();
  if (probe_steps > 0)
    est_s += static_cast<double>(probe_steps) * (2 * ts.probe.offset_delay_s + 2 * ts.height_timeout_s +
                                                 (ts.probe.probe_height_mm + ts.probe.max_depth_mm) / ts.probe.probe_speed_mm_per_s);
  expected_s = std::max(parts.expected_s > 0 ? parts.expected_s : est_s, dt);
  // Stop: ramp from the top speed, settle, margins.
  double vmax = 0;
  for (int i = 0; i < hardware::kAxes; ++i) vmax = std::max(vmax, ms.signals[i].dac_full_scale_mm_per_s);
  est_s += vmax / ms.max_acceleration_mm_per_s2 + 4 * opt.supervisor.stop_settle_s + ts.height_timeout_s + 1.0;

  // Buffers, all touched now.
  contour.prepare(job);
  thc_acc.assign(job.stretches.size(), ThcAcc{});
  thc_fitted = ts.kind == TorchSetup::Kind::plasma && ts.height_axis && ts.thc.enabled;
  thc.configure(ts.thc, dt);
  stretch_len.resize(job.stretches.size());
  for (std::size_t k = 0; k < job.stretches.size(); ++k) stretch_len[k] = stretch_length(job.stretches[k]);
  trace_out = &result.trace;
  result.holds.reserve(kMaxHolds);
  result.probes.reserve(kMaxProbes);
  result.paused_motions.reserve(kMaxPausedMotions);
  if (opt.record_trace) {
    const double samples = source->runs_job() ? est_s / dt / opt.trace_every_ticks * 1.1 + 1000 : 1e9;
    recorder.prepare(result.trace, static_cast<std::size_t>(std::min(samples, 1e12)));
  }

  // Controller, adapter, supervisor, torch.
  std::array<double, hardware::kAxes> limits{};
  for (int i = 0; i < hardware::kAxes; ++i) limits[i] = ms.signals[i].dac_full_scale_mm_per_s;
  pid_ff.configure(ms.servo, limits, dt);
  controller = parts.controller ? parts.controller : &pid_ff;
  controller->reset();
  in = be.initial_inputs();
  adapter.configure(ms, be.command_kind(), dt);
  adapter.reset(in, job.start_mm);
  sup.configure(ms, opt.supervisor, dt, adapter.quantum_mm());
  sup.reset(job.start_mm);
  torch.configure(ms.torch, dt);
  if (parts.filter) parts.filter->reset(job.start_mm);
  sp_mm = job.start_mm;
  has_truth = be.true_position(true_mm);
  phase = source->runs_job() ? Phase::dispatch : Phase::jog;
  out.drives_enabled = true;  // the first exchange enables the drives with a zero command
  out.dac_code.fill(0);
  for (int i = 0; i < hardware::kAxes; ++i) out.position_command_mm[i] = job.start_mm[i];
  out.torch_fire = false;
  out.torch_height_target_mm = ms.torch.retract_height_mm;
}
ExecutionResult Session::Impl::finish() {
  // ---- after the loop: allocation and formatting are allowed again ----
  ExecutionResult& r = result;
  if (parts.progress) parts.progress->finish();
  if (opt.record_trace) recorder.finish();
  r.machine = ms.name;
  r.source = job.source;
  r.backend = be.name();
  r.backend_notes = be.notes();
  r.mode = opt.mode;
  r.cycle_time_s = t;
  r.torch_on_s = torch_on_s;
  r.rapid_distance_mm = rapid_mm;
  r.steps_completed = steps_completed;
  r.trace_truncated = recorder.truncated();
  r.torch_off_at_end = !out.torch_fire;
  r.stopped_at_rest = sup.stopped_at_rest();
  r.truth_available = has_truth;
  const auto& acc = contour.accumulators();
  for (std::size_t k = 0; k < acc.size(); ++k) {
    const motion::Stretch& s = job.stretches[k];
    if (!s.cutting || !acc[k].touched) continue;
    CutError c;
    c.stretch = k;
    c.source_line = s.source_lines.empty() ? 0 : s.source_lines.front();
    c.samples = acc[k].n;
    c.complete = acc[k].complete;
    if (acc[k].n > 0) {
      c.max_mm = acc[k].max;
      c.rms_mm = std::sqrt(acc[k].sum2 / acc[k].n);
    }
    if (acc[k].n_true > 0) {
      c.max_true_mm = acc[k].max_true;
      c.rms_true_mm = std::sqrt(acc[k].sum2_true / acc[k].n_true);
    }
    const ThcAcc& h = thc_acc[k];
    c.material = h.material;
    if (h.n > 0) {
      c.thc.samples = h.n;
      c.thc.max_mm = h.max;
      c.thc.rms_mm = std::sqrt(h.sum2 / static_cast<double>(h.n));
      c.thc.active_share = static_cast<double>(h.active) / static_cast<double>(h.n);
      c.thc.target_v = h.target_v;
      c.thc.velocity_lock_change_mm = h.velocity_change;
      c.thc.void_lock_change_mm = h.void_change;
      c.thc.velocity_locked_s = static_cast<double>(h.velocity_locked) * dt;
      c.thc.void_locked_s = static_cast<double>(h.void_locked) * dt;
    }
    if (c.complete) r.cut_distance_mm += stretch_len[c.stretch];
    r.cuts.push_back(c);
  }
  if (sup.faulted()) {
    FaultReport f;
    f.kind = sup.kind();
    f.time_s = sup.where().t_s;
    f.step = sup.where().step;
    f.source_line = sup.where().source_line;
    f.axis = sup.axis();
    f.last_known_mm = sup.last_known_mm();
    f.commanded_mm = sup.where().commanded_mm;
    f.value = sup.value();
    f.message = fault_message(f);
    // The operator's stop and a stop request end the run as asked: cancelled (or the deadline
    // or budget that ended its Termination), not a fault of the machine.
    const Termination* term = parts.termination;
    r.summary.status = f.kind == FK::operator_stop ? Status::cancelled
                       : f.kind == FK::stop_requested
                           ? (term && term->ended() ? status_of(term->reason()) : Status::cancelled)
                           : Status::faulted;
    r.summary.message = f.message;
    r.faults.push_back(std::move(f));
  }
  if (parts.trace_stream) {
    r.trace_stream_dropped = parts.trace_stream->dropped();
    parts.trace_stream->close();
    r.trace_streamed = parts.trace_stream->written();
  }
  r.summary.full = r.report();
  r.summary.brief = r.summary.full.substr(0, r.summary.full.find('\n'));
  return std::move(r);
}

Session::Session(Executor& ex, const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend,
                 const RunParts& parts)
    : impl_(std::make_unique<Impl>(ex, job, trajectories, backend, parts)) {
  impl_->prepare(ex.setup_.servo_period_s);
}

Session::~Session() = default;
bool Session::tick() noexcept { return impl_->tick(); }
ExecutionResult Session::finish() { return impl_->finish(); }

// ---------------------------------------------------------------------------------------------

Executor::Executor(MachineSetup setup, ExecutorOptions options) : setup_(std::move(setup)), options_(options) {
  setup_.validate();
  options_.validate();
}

ExecutionResult Executor::run(const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend,
                              const RunParts& parts) {
  Session s(*this, job, trajectories, backend, parts);
  while (s.tick()) {
  }
  return s.finish();
}
}  // namespace machplan::executor
