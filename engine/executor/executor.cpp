#include "engine/executor/executor.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>

#include "engine/common/error.h"
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

// `held`: the operator holds the job while no move runs (an interrupted torch-on step).
enum class Phase { dispatch, move, torch, dwell, end_hold, jog, held, done };

}  // namespace

struct Session::Impl {
  Impl(Executor& ex, const motion::Job& job, const Trajectories& trajs, hardware::Backend& be, const RunParts& parts)
      : ms(ex.setup_), opt(ex.options_), job(job), trajs(trajs), be(be), parts(parts),
        dt(be.period_s()) {}

  void prepare(double machine_period_s);
  bool tick() noexcept;
  ExecutionResult finish();

  // --- the real-time part -------------------------------------------------------------------
  void sequence() noexcept;
  void begin_step() noexcept;
  void next_step() noexcept;
  void torch_off_and_retract(bool resume, double height_mm = 0.0) noexcept;
  void raise(FK kind, int axis, double value) noexcept;
  bool moving_cut() const noexcept {
    return phase == Phase::move && !sup.stopping() && !cut_off && source->travelling() && step < job.steps.size() &&
           job.stretches[job.steps[step].stretch].cutting;
  }
  // The operator's buttons and overrides (feed hold, resume, stop).
  void operate() noexcept;
  void begin_hold(bool by_override) noexcept;
  void follow_hold() noexcept;
  // The arc went out in a cut: a fault, or (the machine's on_arc_loss: recover) a hold the
  // operator recovers from.
  void arc_lost() noexcept;
  // Torch height control in a cut, and its figures.
  void thc_tick() noexcept;
  bool move_is_rapid() const noexcept {
    return step < job.steps.size() && job.steps[step].kind == Step::Kind::move && job.stretches[job.steps[step].stretch].rapid;
  }
  double move_rate() const noexcept { return held ? 0.0 : move_is_rapid() ? rapid_rate : feed_rate; }
  void record_trace() noexcept;
  void publish_live() noexcept;

  // --- inputs -------------------------------------------------------------------------------
  const MachineSetup& ms;
  const ExecutorOptions& opt;
  const motion::Job& job;
  const Trajectories& trajs;
  hardware::Backend& be;
  RunParts parts;
  double expected_s = 1.0;  // the job's expected machine time, for RunParts::progress
  const double dt;

  // --- parts --------------------------------------------------------------------------------
  std::optional<PlannedSource> planned;
  std::optional<BluVectorSource> blu;
  std::optional<JogSource> jogger;
  SetpointSource* source = nullptr;
  control::PidFfController pid_ff;
  control::Controller* controller = nullptr;
  FeedbackAdapter adapter;
  Supervisor sup;
  TorchSequencer torch;
  ContourMonitor contour;
  ThcController thc;
  TraceRecorder recorder;
  std::vector<TraceSample>* trace_out = nullptr;
  ExecutionResult result;

  // --- state --------------------------------------------------------------------------------
  hardware::Outputs out{};
  hardware::Inputs in{};
  Demand demand{};
  control::ControllerOutput cout{};
  long ticks = 0;
  double t = 0.0;
  std::size_t step = 0;
  Phase phase = Phase::dispatch;
  double phase_t = 0.0;
  bool resume_after_torch_off = false;
  Eigen::Vector2d sp_mm = Eigen::Vector2d::Zero();  // the commanded point now
  Eigen::Vector2d true_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  bool has_truth = false;
  Eigen::Vector2d u = Eigen::Vector2d::Zero();  // commanded speed, mm/s (nominal drive units)
  bool clipped = false;
  double torch_on_s = 0.0;
  int steps_completed = 0;
  double rapid_mm = 0.0;
  std::vector<double> stretch_len;
  bool over = false;
  // The operator: feed hold, resume, overrides, stop.
  hardware::OperatorInputs prev_op{};
  double feed_rate = 1.0, rapid_rate = 1.0;  // the overrides as rates of the plan
  bool held = false;              // a hold is in force
  bool held_by_override = false;  // ... because the feed override is 0 %
  bool resume_asked = false;
  bool cut_off = false;           // the hold turned the torch off in a cut: the resume re-pierces
  bool torch_off_running = false; // that torch-off sequence runs beside the braking
  bool repiercing = false;
  bool restart_step = false;      // the hold interrupted a torch-on step: it runs again on resume
  HoldReport* hold = nullptr;     // the hold being recorded (in result.holds)
  Eigen::Vector2d last_sp = Eigen::Vector2d::Zero();
  double progress_s = 0.0;        // the job's expected time done: path time in moves, else machine time
  bool be_realtime = true;
  // The plasma process: the material of the cut under way, THC, cut recovery.
  int material = -1;              // index into job.materials (-1: the machine's settings)
  bool thc_fitted = false;        // plasma, a height axis and THC enabled
  struct ThcAcc {
    std::size_t n = 0, active = 0, velocity_locked = 0, void_locked = 0;
    double max = 0.0, sum2 = 0.0, target_v = 0.0, velocity_change = 0.0, void_change = 0.0;
    int material = -1;
  };
  std::vector<ThcAcc> thc_acc;    // per stretch
  bool velocity_locked = false, void_locked = false;
  bool thc_acting = false;        // THC moved the height this period
  double velocity_lock_h = 0.0, void_lock_h = 0.0;  // the height when the lock began
  Eigen::Vector2d last_loss_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
};

// A second arc loss closer than this to the last one ends the job: the recovery does not hold.
constexpr double kRepeatedArcLossMm = 5.0;

void Session::Impl::prepare(double machine_period_s) {
  check_backend(ms, machine_period_s, be);
  be_realtime = be.realtime();
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
    }
  }
  source->prepare(ctx, job.start_mm);
  // At most: every torch step waits out its timeouts (engine/motion/process_time.h).
  motion::TorchTimes longest;
  longest.torch_on_s = 2 * ts.height_timeout_s + ts.arc_ok_timeout_s + ts.preheat_s + 0.1;
  longest.pierce_s = ts.pierce_delay_s;
  longest.torch_off_s = ts.height_timeout_s;
  double est_s = 1.0 + motion::process_time_s(job, longest) + source->estimate_s();
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

void Session::Impl::raise(FK kind, int axis, double value) noexcept {
  Supervisor::Where w;
  w.t_s = t;
  w.step = step < job.steps.size() ? static_cast<int>(step) : -1;
  w.source_line = step < job.steps.size() ? job.steps[step].source_line : 0;
  if (phase == Phase::move && source->source_line() > 0) w.source_line = source->source_line();
  w.commanded_mm = sp_mm;
  sup.raise(kind, axis, value, w);
}

void Session::Impl::begin_step() noexcept {
  phase_t = 0.0;
  if (step >= job.steps.size()) {
    if (out.torch_fire || torch.lit()) {
      torch_off_and_retract(/*resume=*/true);
      return;
    }
    phase = Phase::end_hold;
    return;
  }
  const Step& st = job.steps[step];
  switch (st.kind) {
    case Step::Kind::move: {
      const motion::Stretch& s = job.stretches[st.stretch];
      if (!s.cutting && (out.torch_fire || torch.lit())) {
        // End of a cut not closed by a torch_off step: turn the torch off before moving on.
        torch_off_and_retract(/*resume=*/true);
        return;
      }
      phase = Phase::move;
      if (!s.cutting) cut_off = false;  // a held cut that ended while braking needs no re-pierce
      contour.begin(st.stretch);
      if (s.cutting) thc_acc[st.stretch].material = material;
      source->set_rate(move_rate());
      source->begin_move(step, adapter.position_mm());
      break;
    }
    case Step::Kind::torch_on: {
      // A dwell step right after torch_on is the programmed pierce delay (G4).
      const bool programmed = step + 1 < job.steps.size() && job.steps[step + 1].kind == Step::Kind::dwell;
      material = st.material;
      const motion::CutParameters* m = material >= 0 ? &job.materials[static_cast<std::size_t>(material)] : nullptr;
      torch.use_material(m);
      thc.reset(m ? m->cut_volts : 0.0);
      torch.start_on(programmed, out);
      phase = Phase::torch;
      break;
    }
    case Step::Kind::torch_off:
      torch.end_cut(out, st.height_mm);
      resume_after_torch_off = false;
      phase = Phase::torch;
      break;
    case Step::Kind::dwell: phase = Phase::dwell; break;
  }
}

void Session::Impl::torch_off_and_retract(bool resume, double height_mm) noexcept {
  torch.start_off(out, height_mm);
  resume_after_torch_off = resume;
  phase = Phase::torch;
}

// The operator's inputs of this period: the stop button, the overrides, feed hold and resume
// (buttons act on their rising edge). Runs first in every tick.
void Session::Impl::operate() noexcept {
  const hardware::OperatorInputs& op = in.op;
  const bool hold_edge = op.feed_hold && !prev_op.feed_hold;
  const bool start_edge = op.cycle_start && !prev_op.cycle_start;
  const bool stop_edge = op.stop && !prev_op.stop;
  const double recover_mm = op.recover_mm - prev_op.recover_mm;
  prev_op = op;
  if (stop_edge && phase != Phase::jog) {
    raise(FK::operator_stop, -1, 0.0);
    return;
  }
  feed_rate = std::isfinite(op.feed_override_pct) ? std::clamp(op.feed_override_pct, 0.0, 200.0) / 100.0 : 1.0;
  rapid_rate = std::isfinite(op.rapid_override_pct) ? std::clamp(op.rapid_override_pct, 1.0, 100.0) / 100.0 : 1.0;
  if (!source->supports_rate() || phase == Phase::jog || phase == Phase::end_hold || phase == Phase::done) return;
  // A 0 % feed override holds a feed move like the button, and lets go when it rises again.
  const bool zero_feed = feed_rate == 0.0 && phase == Phase::move && !move_is_rapid();
  if (!held && (hold_edge || zero_feed)) begin_hold(!hold_edge);
  if (held && (held_by_override ? feed_rate > 0.0 : start_edge)) resume_asked = true;
  // Cut recovery: along the path of a held cut whose torch is off.
  if (held && cut_off && phase == Phase::move && std::isfinite(recover_mm) && recover_mm != 0.0) source->recover(recover_mm);
}

void Session::Impl::arc_lost() noexcept {
  const bool repeated = (adapter.position_mm() - last_loss_mm).norm() < kRepeatedArcLossMm;
  if (!ms.torch.recover_on_arc_loss || !source->supports_rate() || held || repeated) {
    raise(FK::arc_lost, -1, sup.arc_low_s());
    return;
  }
  last_loss_mm = adapter.position_mm();
  begin_hold(false);
  // The arc is out: the torch goes off now, not just before rest; the resume re-pierces.
  torch.start_off(out);
  torch_off_running = true;
  cut_off = true;
  if (hold) hold->by_arc_loss = hold->in_cut = hold->torch_off = hold->torch_off_before_rest = true;
}

void Session::Impl::thc_tick() noexcept {
  const bool cutting = thc_fitted && !held && moving_cut() && torch.lit() && !torch.busy() && in.arc_ok;
  thc_acting = false;
  if (!cutting) {
    velocity_locked = void_locked = false;
    return;
  }
  const std::size_t k = job.steps[step].stretch;
  const motion::Stretch& s = job.stretches[k];
  const std::size_t seg = std::min(contour.segment(), s.segments.size() - 1);
  Eigen::Vector2d v, a;
  source->motion_now(v, a);
  const motion::CutParameters* m = material >= 0 ? &job.materials[static_cast<std::size_t>(material)] : nullptr;
  ThcController::Input ti;
  ti.voltage_v = in.arc_voltage_v;
  ti.speed_mm_per_s = v.norm();
  // The speed the cut should run at: its feed, as the override and the machine allow.
  ti.feed_mm_per_s = std::min(s.feed_mm_per_s[seg] * std::min(feed_rate, 1.0), ms.max_velocity_mm_per_s);
  ti.allowed = (!m || m->thc) && (s.thc_off.empty() || !s.thc_off[seg]) && in.op.thc_enabled;
  out.torch_height_target_mm = torch.cut_height_mm() + thc.update(ti);
  thc_acting = thc.active();

  // Figures, from the backend's truth.
  ThcAcc& acc = thc_acc[k];
  const double h = in.torch_height_mm;
  const bool vl = thc.holding() && thc.velocity_locked(), ol = thc.holding() && thc.void_locked();
  if (vl && !velocity_locked) velocity_lock_h = h;
  if (ol && !void_locked) void_lock_h = h;
  if (vl) {
    acc.velocity_change = std::max(acc.velocity_change, std::abs(h - velocity_lock_h));
    ++acc.velocity_locked;
  }
  if (ol) {
    acc.void_change = std::max(acc.void_change, std::abs(h - void_lock_h));
    ++acc.void_locked;
  }
  velocity_locked = vl;
  void_locked = ol;
  double gap = 0.0;
  if (thc.holding() && be.true_torch_gap(gap)) {
    const double e = std::abs(gap - torch.cut_height_mm());
    ++acc.n;
    acc.max = std::max(acc.max, e);
    acc.sum2 += e * e;
    if (thc.active()) ++acc.active;
    acc.target_v = thc.target_v();
  }
}

// How close to rest the torch goes off in a held cut, mm of travel left (follow_hold).
constexpr double kTorchOffBeforeRestMm = 0.2;

void Session::Impl::begin_hold(bool by_override) noexcept {
  held = true;
  held_by_override = by_override;
  resume_asked = false;
  const bool cutting = ms.torch.kind != TorchSetup::Kind::spindle && (out.torch_fire || torch.lit() || torch.lighting());
  if (result.holds.size() < result.holds.capacity()) {
    HoldReport& h = result.holds.emplace_back();
    h.t_s = t;
    h.step = step < job.steps.size() ? static_cast<int>(step) : -1;
    h.source_line = phase == Phase::move && source->source_line() > 0 ? source->source_line()
                    : step < job.steps.size()                        ? job.steps[step].source_line
                                                                     : 0;
    h.by_override = by_override;
    h.in_rapid = phase == Phase::move && move_is_rapid();
    h.in_cut = cutting;
    h.position_mm = sp_mm;
    Eigen::Vector2d v, a;  // the commanded motion at the input
    if (phase == Phase::move) source->motion_now(v, a);
    else v.setZero(), a.setZero();
    h.speed_mm_per_s = v.norm();
    // The stop's limits along the path: per axis, what the plan's own acceleration leaves.
    double at = std::numeric_limits<double>::infinity(), jt = at;
    for (int i = 0; i < hardware::kAxes; ++i) {
      if (h.speed_mm_per_s <= 0) break;
      const double u = std::abs(v[i]) / h.speed_mm_per_s;
      if (u < 1e-9) continue;
      at = std::min(at, std::max(0.0, ms.max_acceleration_mm_per_s2 - std::abs(a[i] - v[i] * a.dot(v) / (h.speed_mm_per_s * h.speed_mm_per_s))) / u);
      jt = std::min(jt, ms.max_jerk_mm_per_s3 / u);
    }
    // No more than the axes' own limits: the path may turn during the stop, and along an
    // axis the stop can use A and J and no more.
    // On a curve the direction turns during the stop: what the normal acceleration a_n leaves
    // is at least sqrt(A^2 - a_n^2) whatever the direction (the worst, at the angle where
    // sin = a_n / A).
    const double an = h.speed_mm_per_s > 0 ? (a - v * a.dot(v) / (h.speed_mm_per_s * h.speed_mm_per_s)).norm() : 0.0;
    const double A = ms.max_acceleration_mm_per_s2;
    h.stop_acceleration_mm_per_s2 = std::min({at, A, std::sqrt(std::max(0.0, A * A - an * an))});
    h.stop_jerk_mm_per_s3 = std::min(jt, ms.max_jerk_mm_per_s3);
    h.acceleration_mm_per_s2 = h.speed_mm_per_s > 0 ? a.dot(v) / h.speed_mm_per_s : 0.0;
    h.torch_off_before_rest = true;  // follow_hold turns a cutting torch off before rest (or at once, at rest)
    h.torch_off = false;
    hold = &h;
  } else {
    ++result.holds_dropped;
    hold = nullptr;
  }
  last_sp = sp_mm;
  // In a move the torch goes off in this same period (follow_hold), while the axes brake
  // along the path. A pierce under way goes off now and its step runs again on resume;
  // dwells and torch-off sequences run on, and the next move starts held.
  if (phase == Phase::torch && torch.lighting() && ms.torch.kind != TorchSetup::Kind::spindle) {
    torch.kill(out);
    restart_step = true;
    phase = Phase::held;
    if (hold) hold->stopped = true;
  }
}

// While a move is held: the torch-off beside the braking, the record of the stop, and the
// resume (re-pierce first when a cut was held).
void Session::Impl::follow_hold() noexcept {
  // A spindle keeps turning through a hold. A torch cuts on while the axes brake along the
  // path and goes off just before they stop, once what is left of the stop is under
  // kTorchOffBeforeRestMm (so the re-pierce where they stop leaves no gap in the cut); it is
  // off in the period the axes come to rest at the latest.
  if (held && !cut_off && !torch_off_running && ms.torch.kind != TorchSetup::Kind::spindle &&
      (out.torch_fire || torch.lit())) {
    const double u = Eigen::Vector2d(demand.track.v_ff_mm_per_s[0], demand.track.v_ff_mm_per_s[1]).norm();
    const double left_mm = u * u / (2.0 * ms.max_acceleration_mm_per_s2) + 0.5 * u * ms.max_acceleration_mm_per_s2 / ms.max_jerk_mm_per_s3;
    if (left_mm < kTorchOffBeforeRestMm || source->rate() == 0.0) {
      torch.start_off(out);
      torch_off_running = true;
      cut_off = true;
      if (hold) {
        hold->in_cut = hold->torch_off = true;
        hold->torch_off_before_rest = source->rate() > 0.0 || hold->speed_mm_per_s == 0.0;
      }
    }
  }
  if (torch_off_running) {
    const TorchSequencer::Status st = torch.tick(in, out);
    if (st == TorchSequencer::Status::failed) raise(FK::torch_height_timeout, -1, torch.failure_value());
    if (st != TorchSequencer::Status::busy) torch_off_running = false;
  }
  if (!held) return;
  const bool at_rest = source->rate() == 0.0;
  if (hold && !hold->stopped) {
    hold->distance_to_stop_mm += (sp_mm - last_sp).norm();
    hold->off_path_mm = std::max(hold->off_path_mm, source->path_distance_mm(sp_mm));
    hold->off_path_measured_mm = std::max(hold->off_path_measured_mm, source->path_distance_mm(adapter.position_mm()));
    if (at_rest) {
      hold->stopped = true;
      hold->stop_s = t - hold->t_s;
      hold->stop_mm = sp_mm;
      // After a lost arc the machine goes back along the path to where the arc went out (the
      // braking, and the debounce before it was called lost); the operator may go further.
      if (hold->by_arc_loss)
        source->recover(-(hold->distance_to_stop_mm + hold->speed_mm_per_s * ms.torch.arc_loss_debounce_s));
    }
  }
  last_sp = sp_mm;
  if (!resume_asked || !at_rest || torch_off_running || source->recovering()) return;
  resume_asked = false;
  const double recovered = source->take_recovered_mm();
  if (hold) {
    hold->resumed_at_s = t;
    hold->recovered_mm = recovered;
  }
  if (cut_off) {
    // Re-pierce where the cut stopped (an oxy-fuel preheat flame kept burning).
    torch.start_on(false, out, ms.torch.kind == TorchSetup::Kind::oxy_fuel);
    repiercing = true;
    phase = Phase::torch;
    return;
  }
  held = false;
  hold = nullptr;
}

void Session::Impl::next_step() noexcept {
  ++steps_completed;
  ++step;
  phase = Phase::dispatch;
}

void Session::Impl::sequence() noexcept {
  operate();
  if (sup.faulted()) return;
  // Dispatch may chain through zero-time steps, bounded by the number of steps.
  for (std::size_t guard = 0; phase == Phase::dispatch && guard <= job.steps.size() + 1; ++guard) begin_step();
  phase_t += dt;
  if (phase == Phase::move) source->set_rate(move_rate());
  source->advance(adapter.position_mm(), in.op);
  if (phase == Phase::move) follow_hold();
  switch (phase) {
    case Phase::dispatch:
    case Phase::done: break;
    case Phase::move:
      if (source->move_done()) {
        const std::size_t k = job.steps[step].stretch;
        contour.complete(k);
        if (job.stretches[k].rapid) rapid_mm += stretch_len[k];
        next_step();
      }
      break;
    case Phase::torch:
      switch (torch.tick(in, out)) {
        case TorchSequencer::Status::done:
          if (repiercing) {
            // The held cut goes on from where it stopped.
            repiercing = false;
            cut_off = false;
            held = false;
            if (hold) hold->repierce_s = t - hold->resumed_at_s;
            hold = nullptr;
            phase = Phase::move;
          } else if (resume_after_torch_off) {
            resume_after_torch_off = false;
            phase = Phase::dispatch;  // the same step again, now with the torch off
          } else {
            next_step();
          }
          break;
        case TorchSequencer::Status::failed:
          raise(torch.failure() == TorchSequencer::Failure::arc_start_failed ? FK::arc_start_failed
                                                                               : FK::torch_height_timeout,
                -1, torch.failure_value());
          break;
        case TorchSequencer::Status::idle:
        case TorchSequencer::Status::busy: break;
      }
      break;
    case Phase::dwell:
      if (phase_t >= job.steps[step].seconds - 1e-12) {
        // A programmed pierce dwell ends with the move to cut height.
        const bool after_torch_on = step > 0 && job.steps[step - 1].kind == Step::Kind::torch_on;
        if (after_torch_on && ms.torch.height_axis && torch.lit()) {
          torch.lower_to_cut_height(out);
          phase = Phase::torch;
        } else {
          next_step();
        }
      }
      break;
    case Phase::held:
      // The interrupted torch-on step runs again once the operator resumes.
      if (resume_asked) {
        resume_asked = held = restart_step = false;
        if (hold) hold->resumed_at_s = t;
        hold = nullptr;
        phase = Phase::dispatch;
      }
      break;
    case Phase::end_hold:
      // Let the servo settle on the end point, then zero the command and disable.
      if (phase_t >= opt.supervisor.rest_window_s) {
        u.setZero();
        sup.finish();
      }
      break;
    case Phase::jog:
      // The operator ends the manual session with cycle start: a controlled stop, no fault.
      if (in.op.cycle_start) sup.begin_stop(u, torch, out);
      break;
  }
  // A step that ended in this tick hands over at once (torch off, next move) rather than one
  // period later.
  for (std::size_t guard = 0; phase == Phase::dispatch && !sup.faulted() && guard <= job.steps.size() + 1; ++guard)
    begin_step();
}

void Session::Impl::record_trace() noexcept {
  if (!(opt.record_trace || parts.trace_stream) || ticks % opt.trace_every_ticks != 0) return;
  TraceSample s;
  s.t_s = t;
  s.step = step < job.steps.size() ? static_cast<int>(step) : -1;
  s.commanded_mm = sp_mm;
  s.measured_mm = adapter.position_mm();
  s.true_mm = true_mm;
  s.dac_x = out.dac_code[0];
  s.dac_y = out.dac_code[1];
  s.drives_enabled = out.drives_enabled;
  s.torch_fire = out.torch_fire;
  s.arc_ok = in.arc_ok;
  s.torch_height_mm = in.torch_height_mm;
  s.arc_voltage_v = in.arc_voltage_v;
  double gap = 0.0;
  if (be.true_torch_gap(gap)) s.torch_gap_mm = gap;
  if (opt.record_trace) recorder.record(s);
  if (parts.trace_stream) parts.trace_stream->push(s, !be_realtime);
}

// One servo period. Budget and rules: see executor.h.
bool Session::Impl::tick() noexcept {
  if (over) return false;
  const hardware::Health health = be.exchange(out, in);
  ++ticks;
  t += dt;
  progress_s += phase == Phase::move ? source->rate() * dt : (held ? 0.0 : dt);
  if (parts.progress) parts.progress->report(std::min(progress_s / expected_s, 0.999));
  if (parts.termination) parts.termination->charge(1, dt);
  if (health == hardware::Health::lost) {
    // Nothing more can be commanded; the backend's watchdog stops the machine.
    raise(FK::lost_backend, -1, 0.0);
    sup.set_not_at_rest();
    out.torch_fire = false;
    out.dac_code.fill(0);
    out.drives_enabled = false;
    phase = Phase::done;
    record_trace();
    over = true;
    return false;
  }
  if (sup.state() == Supervisor::State::disable && !out.drives_enabled) {
    phase = Phase::done;
    record_trace();
    over = true;
    return false;
  }
  has_truth = be.true_position(true_mm);
  if (out.torch_fire && in.arc_ok) torch_on_s += dt;

  // Feedback and the faults the inputs show.
  int bad_axis = -1;
  double jump = 0.0;
  const FeedbackAdapter::Verdict v = adapter.update(in, bad_axis, jump);
  if (v != FeedbackAdapter::Verdict::ok)
    raise(v == FeedbackAdapter::Verdict::counter_wrap_misread ? FK::counter_wrap_misread : FK::encoder_glitch, bad_axis, jump);
  else if (adapter.trusted())
    sup.note_trusted(adapter.position_mm());
  if (in.estop || in.op.estop) raise(FK::estop, -1, 0.0);  // the chain, or the operator's E-stop
  if (in.watchdog_tripped) raise(FK::watchdog, -1, be.watchdog_periods());
  if (parts.termination && parts.termination->should_end()) raise(FK::stop_requested, -1, 0.0);
  if (sup.arc_lost(moving_cut() && ms.torch.kind == TorchSetup::Kind::plasma, in.arc_ok)) arc_lost();

  if (!sup.faulted() && !sup.stopping()) {
    if (moving_cut() && in.arc_ok)
      contour.account(job.steps[step].stretch, adapter.position_mm(), has_truth, true_mm);
    else
      contour.clear_last();
    sequence();
    thc_tick();
  }
  if (sup.faulted() && !sup.stopping()) sup.begin_stop(u, torch, out);

  if (sup.stopping()) {
    u = sup.stop_tick(adapter.position_mm(), adapter.trusted());
  } else {
    source->demand(demand);
    if (parts.filter) parts.filter->filter(demand, adapter.position_mm(), adapter.velocity_mm_per_s());
    sp_mm = demand.commanded_mm;
    if (demand.kind == Demand::Kind::track) {
      for (int i = 0; i < hardware::kAxes; ++i) {
        demand.track.y_mm[i] = adapter.position_mm()[i];
        demand.track.y_dot_mm_per_s[i] = adapter.velocity_mm_per_s()[i];
      }
      controller->update(demand.track, cout);
      for (int i = 0; i < hardware::kAxes; ++i) u[i] = cout.u_mm_per_s[i];
      for (int i = 0; i < hardware::kAxes; ++i) {
        if (controller->following_error_exceeded(i)) {
          raise(FK::following_error, i, controller->following_error_mm(i));
          sup.begin_stop(u, torch, out);
          break;
        }
      }
    } else {
      u = demand.speed_mm_per_s;
    }
  }

  if (sup.state() == Supervisor::State::disable) {
    out.drives_enabled = false;  // goes out with the next exchange, which ends the run
    u.setZero();
  }
  clipped = adapter.write(u, sp_mm, sup.stopping(), out);
  if (!sup.stopping() && adapter.trusted()) {
    // Progress and saturation, under every source.
    // Under a tracking source the setpoint's own speed is what the axis is asked to do (the
    // controller's output may be saturated against a jam); open loop, the speed command is.
    const bool tracking = demand.kind == Demand::Kind::track;
    const Eigen::Vector2d asked =
        tracking ? Eigen::Vector2d(demand.track.v_ff_mm_per_s[0], demand.track.v_ff_mm_per_s[1]) : u;
    const int stalled = sup.stalled_axis(asked, adapter.position_mm(), tracking);
    bool saturated = clipped;
    for (int i = 0; i < hardware::kAxes; ++i) saturated = saturated || (demand.kind == Demand::Kind::track && controller->saturated(i));
    const bool sat_fault = sup.saturated_off_contour(moving_cut() && in.arc_ok, saturated, contour.last_mm());
    if (stalled >= 0) raise(FK::axis_stalled, stalled, asked[stalled]);
    else if (sat_fault) raise(FK::drive_saturated, -1, contour.last_mm());
    if (sup.faulted()) sup.begin_stop(u, torch, out);
  }
  if (sup.stopping()) out.torch_fire = false;
  record_trace();
  publish_live();
  return true;
}

void Session::Impl::publish_live() noexcept {
  if (!parts.live) return;
  LiveState l;
  l.run = sup.faulted() ? (sup.stopping() ? LiveState::Run::stopping : LiveState::Run::faulted)
          : held        ? LiveState::Run::held
          : over        ? LiveState::Run::done
                        : LiveState::Run::running;
  l.tick = static_cast<std::uint64_t>(ticks);
  l.t_s = t;
  l.step = step < job.steps.size() ? static_cast<int>(step) : -1;
  l.source_line = phase == Phase::move && source->source_line() > 0 ? source->source_line()
                  : step < job.steps.size()                        ? job.steps[step].source_line
                                                                   : 0;
  l.commanded_mm = sp_mm;
  l.measured_mm = adapter.position_mm();
  l.path_speed_mm_per_s = demand.kind == Demand::Kind::track
                              ? Eigen::Vector2d(demand.track.v_ff_mm_per_s[0], demand.track.v_ff_mm_per_s[1]).norm()
                              : demand.speed_mm_per_s.norm();
  l.rate = phase == Phase::move ? source->rate() : 0.0;
  l.feed_override_pct = 100.0 * feed_rate;
  l.rapid_override_pct = 100.0 * rapid_rate;
  l.drives_enabled = out.drives_enabled;
  l.torch_fire = out.torch_fire;
  l.arc_ok = in.arc_ok;
  l.torch_height_mm = in.torch_height_mm;
  l.thc_active = thc_acting;
  l.arc_voltage_v = in.arc_voltage_v;
  l.progress = std::min(progress_s / expected_s, over ? 1.0 : 0.999);
  // What is left at the current feed override; a hold stops the clock, it does not run it.
  const double left = std::max(0.0, expected_s - progress_s);
  l.time_left_s = held ? left : left / std::max(feed_rate, 0.05);
  l.fault = sup.faulted() ? static_cast<int>(sup.kind()) : -1;
  l.holds = static_cast<int>(result.holds.size());
  parts.live->publish(l);
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
    r.cuts.push_back(c);
  }
  if (sup.faulted()) {
    r.status = ExecutionResult::Status::faulted;
    FaultReport f;
    f.kind = sup.kind();
    f.time_s = sup.where().t_s;
    f.step = sup.where().step;
    f.source_line = sup.where().source_line;
    f.axis = sup.axis();
    f.last_known_mm = sup.last_known_mm();
    f.commanded_mm = sup.where().commanded_mm;
    f.value = sup.value();
    const std::string where = f.source_line > 0 ? fmt::format("{}:{}", job.source, f.source_line) : job.source;
    const std::string ax = f.axis == 0 ? "X" : (f.axis == 1 ? "Y" : "");
    switch (f.kind) {
      case FK::following_error:
        f.message = fmt::format("following error of {:.3f} mm on axis {} exceeds the limit of {} mm", f.value, ax,
                                ms.servo[f.axis].following_error_limit_mm);
        break;
      case FK::encoder_glitch:
        f.message = fmt::format("counter of axis {} jumped {} counts in one period (at most {} are possible); the "
                                "encoder signal is not trusted from here",
                                ax, static_cast<long long>(f.value), adapter.max_counts(f.axis));
        break;
      case FK::counter_wrap_misread:
        f.message = fmt::format("counter of axis {} read {} counts away, a whole number of 256-count carries: the counter "
                                "bytes were read across a carry; position not trusted from here",
                                ax, static_cast<long long>(f.value));
        break;
      case FK::estop: f.message = "E-stop input opened"; break;
      case FK::lost_backend:
        f.message = "the backend stopped answering; nothing more could be commanded (its watchdog must stop the machine)";
        break;
      case FK::watchdog:
        f.message = fmt::format("the backend's watchdog stopped the machine: no exchange for more than {} periods",
                                static_cast<int>(f.value));
        break;
      case FK::arc_start_failed: f.message = fmt::format("no arc OK within {} s of firing the torch", f.value); break;
      case FK::arc_lost: f.message = fmt::format("arc OK dropped for {:.3f} s while cutting", f.value); break;
      case FK::torch_height_timeout:
        f.message = fmt::format("the torch height axis did not reach its target within {} s", f.value);
        break;
      case FK::axis_stalled:
        f.message = fmt::format("axis {} does not move while commanded at {:.2f} mm/s: it covered less than {:.0f} % of "
                                "the commanded travel (jammed axis, or a drive that does not answer)",
                                ax, f.value, 100 * opt.supervisor.stall_min_fraction);
        break;
      case FK::drive_saturated:
        f.message = fmt::format("the drive command was clipped in most periods while the contour error reached {:.3f} mm "
                                "(limit {} mm): the loop cannot hold the path (gains too high, or a feed the drive "
                                "cannot give)",
                                f.value, ms.contour_error_limit_mm);
        break;
      case FK::operator_stop: f.message = "stopped by the operator"; break;
      case FK::stop_requested:
        f.message = parts.termination && parts.termination->ended() &&
                            parts.termination->reason() != Termination::Reason::stop_requested
                        ? parts.termination->describe()
                        : "stop requested";
        break;
    }
    f.message = fmt::format("{}: {} at t = {:.3f} s, step {}, last known position ({:.3f}, {:.3f}) mm", where, f.message,
                            f.time_s, f.step, f.last_known_mm.x(), f.last_known_mm.y());
    r.faults.push_back(std::move(f));
  }
  if (parts.trace_stream) {
    r.trace_stream_dropped = parts.trace_stream->dropped();
    parts.trace_stream->close();
    r.trace_streamed = parts.trace_stream->written();
  }
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

// ---------------------------------------------------------------------------------------------

double ExecutionResult::max_contour_error_mm() const {
  double m = 0;
  for (const CutError& c : cuts) m = std::max(m, c.max_mm);
  return m;
}

double ExecutionResult::max_true_contour_error_mm() const {
  double m = std::numeric_limits<double>::quiet_NaN();
  for (const CutError& c : cuts)
    if (!std::isnan(c.max_true_mm)) m = std::isnan(m) ? c.max_true_mm : std::max(m, c.max_true_mm);
  return m;
}

std::string ExecutionResult::report() const {
  std::string s = fmt::format("{} on {} ({} mode{}): {}\n", source.empty() ? "job" : source, machine, to_string(mode),
                              backend.empty() || backend == "sim" ? "" : ", backend " + backend,
                              status == Status::completed ? "completed" : "FAULTED");
  s += fmt::format("  cycle time {:.3f} s, torch on {:.3f} s, rapids {:.1f} mm, {} steps done\n", cycle_time_s, torch_on_s,
                   rapid_distance_mm, steps_completed);
  for (const CutError& c : cuts) {
    s += fmt::format("  cut (stretch {}, line {}): contour error max {:.4f} mm, rms {:.4f} mm", c.stretch, c.source_line,
                     c.max_mm, c.rms_mm);
    if (!std::isnan(c.max_true_mm)) s += fmt::format(" (true: max {:.4f}, rms {:.4f})", c.max_true_mm, c.rms_true_mm);
    s += c.complete ? "\n" : ", interrupted\n";
  }
  for (const FaultReport& f : faults) s += fmt::format("  fault {}: {}\n", to_string(f.kind), f.message);
  if (status == Status::faulted)
    s += fmt::format("  torch {} at the end; machine {}\n", torch_off_at_end ? "off" : "ON",
                     stopped_at_rest ? "stopped at rest" : "stop not confirmed (see fault)");
  if (trace_truncated) s += "  trace truncated (buffer full)\n";
  if (trace_stream_dropped > 0)
    s += fmt::format("  trace stream: {} samples dropped (the file could not be written fast enough)\n",
                     trace_stream_dropped);
  return s;
}

double HoldReport::jerk_limited_stop_mm() const {
  // From (v, a) along the path: the jerk -J brings the acceleration down to -A, -A holds, then
  // +J brings it back to 0 as the speed reaches 0 (the S-curve's time-optimal stop), integrated
  // in small steps of the exact piecewise-cubic motion.
  const double A = stop_acceleration_mm_per_s2, J = stop_jerk_mm_per_s3;
  if (!(speed_mm_per_s > 0) || !(A > 0) || !(J > 0)) return 0.0;
  double v = speed_mm_per_s, a = acceleration_mm_per_s2, s = 0.0;
  const double h = 1e-5;
  for (int n = 0; n < 100000000 && v > 0; ++n) {
    // Ramp the acceleration back up when the speed left is what the ramp from a to 0 takes.
    const double ramp_dv = a < 0 ? a * a / (2 * J) : 0.0;
    const double j = v <= ramp_dv ? J : (a > -A ? -J : 0.0);
    const double a1 = std::clamp(a + j * h, -A, std::max(a, 0.0) + J * h);
    s += v * h + a * h * h / 2;
    v += (a + a1) / 2 * h;
    a = a1;
  }
  return s;
}

void ExecutionResult::write_trace_csv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot open the trace file for writing");
  out << kTraceCsvHeader;
  char line[256];
  for (const TraceSample& s : trace) out.write(line, static_cast<std::streamsize>(format_trace_csv(s, line, sizeof line)));
  if (!out) throw InputError(path, 0, "writing the trace failed");
}

}  // namespace machplan::executor
