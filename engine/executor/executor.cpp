#include "engine/executor/executor.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/control/counter_decoder.h"
#include "engine/control/servo.h"

namespace machplan::executor {

using motion::Step;
using FK = FaultReport::Kind;

const char* to_string(Mode m) {
  switch (m) {
    case Mode::planned: return "planned";
    case Mode::paper_open: return "paper_open";
    case Mode::paper_closed: return "paper_closed";
  }
  return "?";
}

Mode mode_from_string(const std::string& s) {
  if (s == "planned") return Mode::planned;
  if (s == "paper_open") return Mode::paper_open;
  if (s == "paper_closed") return Mode::paper_closed;
  throw InputError("--mode", 0, fmt::format("unknown mode '{}' (known: planned, paper_open, paper_closed)", s));
}

const char* to_string(FaultReport::Kind k) {
  switch (k) {
    case FK::following_error: return "following_error";
    case FK::encoder_glitch: return "encoder_glitch";
    case FK::counter_wrap_misread: return "counter_wrap_misread";
    case FK::estop: return "estop";
    case FK::lost_backend: return "lost_backend";
    case FK::arc_start_failed: return "arc_start_failed";
    case FK::arc_lost: return "arc_lost";
    case FK::torch_height_timeout: return "torch_height_timeout";
    case FK::stop_requested: return "stop_requested";
  }
  return "?";
}

void ExecutorOptions::validate() const {
  auto fail = [](const char* field, double v, const char* rule) {
    throw std::invalid_argument(fmt::format("ExecutorOptions::{} = {}: {}", field, v, rule));
  };
  if (!(std::isfinite(blu_mm) && blu_mm >= 0.01 && blu_mm <= 1000)) fail("blu_mm", blu_mm, "must be in [0.01, 1000] mm");
  if (!(std::isfinite(calibration_factor) && calibration_factor > 0.1 && calibration_factor <= 10))
    fail("calibration_factor", calibration_factor, "must be in (0.1, 10]");
  if (!(std::isfinite(paper_compute_s) && paper_compute_s >= 0 && paper_compute_s <= 10))
    fail("paper_compute_s", paper_compute_s, "must be in [0, 10] s");
  if (!(std::isfinite(paper_settle_s) && paper_settle_s >= 0 && paper_settle_s <= 60))
    fail("paper_settle_s", paper_settle_s, "must be in [0, 60] s");
  if (!(std::isfinite(rest_window_s) && rest_window_s > 0 && rest_window_s <= 10))
    fail("rest_window_s", rest_window_s, "must be in (0, 10] s");
  if (!(std::isfinite(stop_settle_s) && stop_settle_s > 0 && stop_settle_s <= 60))
    fail("stop_settle_s", stop_settle_s, "must be in (0, 60] s");
  if (trace_every_ticks < 1) fail("trace_every_ticks", trace_every_ticks, "must be >= 1");
}

// ---------------------------------------------------------------------------------------------

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

enum class Phase {
  dispatch,
  move,
  paper_settle,
  torch_height_pierce,
  torch_preheat,
  torch_wait_arc,
  torch_pierce,
  torch_height_cut,
  torch_off_retract,
  dwell,
  end_hold,
  stop_ramp,
  stop_settle,
  stop_disable,
  done
};

struct ErrorAcc {
  std::size_t n = 0, n_true = 0;
  double max = 0, sum2 = 0, max_true = 0, sum2_true = 0;
  bool complete = false, touched = false;
};

// Everything one run needs; built before the first tick.
class Runner {
 public:
  Runner(const MachineSetup& ms, const ExecutorOptions& opt, const motion::Job& job, const Trajectories& trajs,
         hardware::Backend& be, std::atomic<bool>& stop_flag)
      : ms_(ms), opt_(opt), job_(job), trajs_(trajs), be_(be), stop_flag_(stop_flag), dt_(be.period_s()) {}

  void validate_and_prepare(ExecutionResult& r);
  void run(ExecutionResult& r);

 private:
  // --- the real-time part -------------------------------------------------------------------
  bool tick();  // false when the run is over
  void sequence();
  void paper_move_tick();
  void start_paper_vector(std::size_t k, const Eigen::Vector2d& origin);
  void begin_step();
  void next_step();
  void lower_to_cut_height();  // after the pierce: torch down to cutting height, then the cut
  // Torch off in this tick and up to the retract height; with `resume`, the same step runs
  // again once the torch is up (a step that found the torch still burning).
  void torch_off_and_retract(bool resume);
  void raise(FK kind, int axis, double value);
  void enter_stop();
  void account_contour_error();
  void record_trace();
  std::int32_t to_dac(int axis, double u_mm_per_s) const;
  bool moving_cut() const;

  // --- inputs -------------------------------------------------------------------------------
  const MachineSetup& ms_;
  const ExecutorOptions& opt_;
  const motion::Job& job_;
  const Trajectories& trajs_;
  hardware::Backend& be_;
  std::atomic<bool>& stop_flag_;
  const double dt_;

  // --- state --------------------------------------------------------------------------------
  std::array<control::CounterDecoder, 2> dec_{};
  std::array<control::AxisServo, 2> servo_{};
  hardware::Outputs out_{};
  hardware::Inputs in_{};
  long tick_ = 0;
  double t_ = 0.0;
  std::size_t step_ = 0;
  Phase phase_ = Phase::dispatch;
  double phase_t_ = 0.0;
  bool resume_after_torch_off_ = false;
  motion::Setpoint sp_{};
  const motion::Trajectory* cur_traj_ = nullptr;  // the move being (or last) executed, planned mode
  double move_t_ = 0.0;
  Eigen::Vector2d hold_mm_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d meas_mm_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d true_mm_ = Eigen::Vector2d::Constant(kNaN);
  bool has_truth_ = false;
  bool trusted_ = true;
  Eigen::Vector2d u_ = Eigen::Vector2d::Zero();  // commanded speed, mm/s (nominal drive units)
  bool torch_lit_ = false;   // the torch-on sequence completed and the torch has not been turned off
  double arc_low_s_ = 0.0;
  double torch_on_s_ = 0.0;
  bool faulted_ = false;
  FaultReport fault_{};
  Eigen::Vector2d stop_u0_ = Eigen::Vector2d::Zero();
  double stop_t_ = 0.0;
  std::array<std::int64_t, 2> rest_counts_{};
  double rest_s_ = 0.0;
  bool stopped_at_rest_ = true;
  int steps_completed_ = 0;
  double rapid_mm_ = 0.0;
  // Contour error: per stretch accumulators and the nearest-segment cursor of the current cut.
  std::vector<ErrorAcc> acc_;
  std::size_t cursor_ = 0;
  // Paper modes: all vector end points, flat, with the feed and line of the vector ending there.
  std::vector<Eigen::Vector2d> pts_;
  std::vector<double> pt_feed_;
  std::vector<int> pt_line_;
  std::vector<std::size_t> step_first_pt_;  // per step: index of its first point (the stretch start)
  std::vector<std::size_t> step_last_pt_;
  std::size_t pk_ = 0;             // current vector: from pts_[pk_] to pts_[pk_ + 1]
  double pv_left_s_ = 0.0, pv_T_s_ = 0.0, pv_compute_left_s_ = 0.0;
  bool pv_zero_pending_ = false, pv_start_pending_ = false, pv_computing_ = false;
  Eigen::Vector2d pv_origin_ = Eigen::Vector2d::Zero(), pv_latched_ = Eigen::Vector2d::Zero();
  std::vector<double> stretch_length_;
  std::vector<TraceSample>* trace_ = nullptr;
  bool trace_truncated_ = false;
};

double stretch_length(const motion::Stretch& s) {
  double L = 0;
  for (const Segment& seg : s.segments) L += length(seg);
  return L;
}

void Runner::validate_and_prepare(ExecutionResult& r) {
  const auto fail = [&](int line, const std::string& what) { throw InputError(job_.source, line, what); };
  const bool planned = opt_.mode == Mode::planned;
  if (planned && trajs_.size() != job_.steps.size())
    fail(0, fmt::format("{} trajectories for {} steps: planned mode needs one per step", trajs_.size(), job_.steps.size()));
  Eigen::Vector2d at = job_.start_mm;
  bool torch = false;
  double est_s = 1.0;
  const TorchSetup& ts = ms_.torch;
  const double torch_seq_s = 2 * ts.height_timeout_s + ts.arc_ok_timeout_s + ts.preheat_s + ts.pierce_delay_s + 0.1;
  std::size_t n_vectors = 0;
  for (std::size_t i = 0; i < job_.steps.size(); ++i) {
    const Step& st = job_.steps[i];
    switch (st.kind) {
      case Step::Kind::move: {
        if (st.stretch >= job_.stretches.size())
          fail(st.source_line, fmt::format("step {} names stretch {} of {}", i, st.stretch, job_.stretches.size()));
        const motion::Stretch& s = job_.stretches[st.stretch];
        if (s.segments.empty()) fail(st.source_line, fmt::format("stretch {} has no segments", st.stretch));
        if (s.feed_mm_per_s.size() != s.segments.size() || s.source_lines.size() != s.segments.size())
          fail(st.source_line, fmt::format("stretch {}: per-segment feeds and lines must match its segments", st.stretch));
        for (double f : s.feed_mm_per_s)
          if (!(std::isfinite(f) && f > 0)) fail(st.source_line, fmt::format("stretch {}: feed {} is not positive", st.stretch, f));
        if ((s.segments.front().start - at).norm() > 1e-3)
          fail(st.source_line, fmt::format("stretch {} starts at ({:.4f}, {:.4f}) but the tool is at ({:.4f}, {:.4f})",
                                           st.stretch, s.segments.front().start.x(), s.segments.front().start.y(), at.x(),
                                           at.y()));
        if (s.cutting && !torch) fail(st.source_line, "cutting move with the torch off (no torch_on step before it)");
        if (!s.cutting) torch = false;  // the executor turns the torch off before a non-cutting move
        const Eigen::Vector2d end = s.segments.back().end;
        const double L = stretch_length(s);
        double fmin = std::numeric_limits<double>::infinity();
        for (double f : s.feed_mm_per_s) fmin = std::min(fmin, f);
        if (planned) {
          const motion::Trajectory* tr = trajs_[i].get();
          if (!tr) fail(st.source_line, fmt::format("move step {} has no trajectory", i));
          motion::Setpoint a, b;
          tr->sample(0.0, a);
          tr->sample(tr->duration_s(), b);
          if (!(std::isfinite(tr->duration_s()) && tr->duration_s() >= 0))
            fail(st.source_line, fmt::format("trajectory of step {} has duration {}", i, tr->duration_s()));
          if ((a.position_mm - at).norm() > 1e-3 || (b.position_mm - end).norm() > 1e-3)
            fail(st.source_line, fmt::format("trajectory of step {} runs ({:.4f}, {:.4f}) -> ({:.4f}, {:.4f}) but its "
                                             "stretch runs ({:.4f}, {:.4f}) -> ({:.4f}, {:.4f})",
                                             i, a.position_mm.x(), a.position_mm.y(), b.position_mm.x(), b.position_mm.y(),
                                             at.x(), at.y(), end.x(), end.y()));
          est_s += tr->duration_s() + 0.01;
        } else {
          for (const Segment& seg : s.segments) n_vectors += static_cast<std::size_t>(std::ceil(length(seg) / opt_.blu_mm)) + 1;
          est_s += L / (fmin * std::min(1.0, opt_.calibration_factor * 0.5)) + opt_.paper_settle_s + 0.01;
        }
        at = end;
        break;
      }
      case Step::Kind::torch_on:
        if (ts.kind == TorchSetup::Kind::none) fail(st.source_line, fmt::format("torch on, but machine '{}' has no torch", ms_.name));
        torch = true;
        est_s += torch_seq_s;
        break;
      case Step::Kind::torch_off:
        if (ts.kind == TorchSetup::Kind::none) fail(st.source_line, fmt::format("torch off, but machine '{}' has no torch", ms_.name));
        torch = false;
        est_s += ts.height_timeout_s;
        break;
      case Step::Kind::dwell:
        if (!(std::isfinite(st.seconds) && st.seconds >= 0 && st.seconds <= 3600))
          fail(st.source_line, fmt::format("dwell of {} s (must be 0 .. 3600)", st.seconds));
        est_s += st.seconds;
        break;
    }
  }
  if (!planned) est_s += static_cast<double>(n_vectors) * (opt_.paper_compute_s + 2 * dt_);
  // Stop: ramp from the top speed, settle, margins.
  double vmax = 0;
  for (int i = 0; i < 2; ++i) vmax = std::max(vmax, ms_.signals[i].dac_full_scale_mm_per_s);
  est_s += vmax / ms_.max_acceleration_mm_per_s2 + 4 * opt_.stop_settle_s + ts.height_timeout_s + 1.0;

  // Buffers.
  acc_.assign(job_.stretches.size(), ErrorAcc{});
  stretch_length_.resize(job_.stretches.size());
  for (std::size_t k = 0; k < job_.stretches.size(); ++k) stretch_length_[k] = stretch_length(job_.stretches[k]);
  if (!planned) {
    pts_.reserve(n_vectors + job_.steps.size() + 1);
    step_first_pt_.assign(job_.steps.size(), 0);
    step_last_pt_.assign(job_.steps.size(), 0);
    for (std::size_t i = 0; i < job_.steps.size(); ++i) {
      const Step& st = job_.steps[i];
      if (st.kind != Step::Kind::move) continue;
      const motion::Stretch& s = job_.stretches[st.stretch];
      step_first_pt_[i] = pts_.size();
      pts_.push_back(s.segments.front().start);
      pt_feed_.push_back(s.feed_mm_per_s.front());
      pt_line_.push_back(s.source_lines.front());
      for (std::size_t g = 0; g < s.segments.size(); ++g) {
        const Segment& seg = s.segments[g];
        // Equal vectors of at most blu_mm along the segment (chords for arcs).
        const int n = std::max(1, static_cast<int>(std::ceil(length(seg) / opt_.blu_mm - 1e-9)));
        for (int j = 1; j <= n; ++j) {
          pts_.push_back(j == n ? seg.end : point_at(seg, static_cast<double>(j) / n));
          pt_feed_.push_back(s.feed_mm_per_s[g]);
          pt_line_.push_back(s.source_lines[g]);
        }
      }
      step_last_pt_[i] = pts_.size() - 1;
    }
  }
  const double trace_ticks = est_s / dt_ / opt_.trace_every_ticks;
  if (opt_.record_trace) r.trace.reserve(static_cast<std::size_t>(std::min(trace_ticks * 1.1 + 1000, 5e7)));
  trace_ = &r.trace;

  // Controllers and decoders.
  in_ = be_.initial_inputs();
  for (int i = 0; i < 2; ++i) {
    const hardware::AxisSignals& sig = ms_.signals[i];
    const auto max_counts =
        static_cast<std::int64_t>(std::ceil(1.5 * ms_.max_speed_mm_per_s[i] * dt_ / sig.mm_per_count)) + 2;
    dec_[i].configure(sig.mm_per_count, sig.counter_bits, max_counts);
    dec_[i].reset(in_.counter[i], job_.start_mm[i]);
    servo_[i].configure(ms_.servo[i], sig.dac_full_scale_mm_per_s, dt_);
  }
  meas_mm_ = job_.start_mm;
  fault_.last_known_mm = meas_mm_;
  sp_.position_mm = hold_mm_ = job_.start_mm;
  has_truth_ = be_.true_position(true_mm_);
  out_.drives_enabled = true;  // the first exchange enables the drives with a zero command
  out_.dac_code = {0, 0};
  out_.torch_fire = false;
  out_.torch_height_target_mm = ms_.torch.retract_height_mm;
}

std::int32_t Runner::to_dac(int axis, double u) const {
  const hardware::AxisSignals& s = ms_.signals[axis];
  const double full = static_cast<double>(std::int64_t{1} << (s.dac_bits - 1));
  const double code = std::round(u / s.dac_full_scale_mm_per_s * full);
  return static_cast<std::int32_t>(std::clamp(code, -full, full - 1));
}

bool Runner::moving_cut() const {
  return phase_ == Phase::move && step_ < job_.steps.size() && job_.stretches[job_.steps[step_].stretch].cutting;
}

void Runner::raise(FK kind, int axis, double value) {
  if (faulted_) return;
  faulted_ = true;
  fault_.kind = kind;
  fault_.time_s = t_;
  fault_.step = step_ < job_.steps.size() ? static_cast<int>(step_) : -1;
  fault_.source_line = step_ < job_.steps.size() ? job_.steps[step_].source_line : 0;
  if (phase_ == Phase::move && opt_.mode != Mode::planned && pk_ + 1 < pt_line_.size()) fault_.source_line = pt_line_[pk_ + 1];
  fault_.axis = axis;
  fault_.value = value;
  fault_.commanded_mm = sp_.position_mm;
  // last_known_mm is kept up to date while the feedback is trusted.
}

void Runner::enter_stop() {
  // Torch off in this very tick, height to retract.
  out_.torch_fire = false;
  torch_lit_ = false;
  out_.torch_height_target_mm = ms_.torch.retract_height_mm;
  stop_u0_ = u_;
  stop_t_ = 0.0;
  phase_ = Phase::stop_ramp;
  phase_t_ = 0.0;
}

void Runner::begin_step() {
  phase_t_ = 0.0;
  if (step_ >= job_.steps.size()) {
    if (out_.torch_fire || torch_lit_) {
      torch_off_and_retract(/*resume=*/true);
      return;
    }
    phase_ = Phase::end_hold;
    return;
  }
  const Step& st = job_.steps[step_];
  switch (st.kind) {
    case Step::Kind::move: {
      const motion::Stretch& s = job_.stretches[st.stretch];
      if (!s.cutting && (out_.torch_fire || torch_lit_)) {
        // End of a cut not closed by a torch_off step: turn the torch off before moving on.
        torch_off_and_retract(/*resume=*/true);
        return;
      }
      phase_ = Phase::move;
      cursor_ = 0;
      if (opt_.mode == Mode::planned) {
        cur_traj_ = trajs_[step_].get();
        move_t_ = 0.0;
      }
      acc_[st.stretch].touched = true;
      if (opt_.mode != Mode::planned) {
        pk_ = step_first_pt_[step_];
        u_.setZero();
        pv_zero_pending_ = opt_.paper_zero_first;
        pv_start_pending_ = !opt_.paper_zero_first;
        pv_computing_ = false;
        pv_T_s_ = pv_left_s_ = 0.0;
        pv_origin_ = pts_[pk_];
      }
      break;
    }
    case Step::Kind::torch_on:
      phase_ = ms_.torch.height_axis ? Phase::torch_height_pierce
                                     : (ms_.torch.kind == TorchSetup::Kind::oxy_fuel ? Phase::torch_preheat : Phase::torch_wait_arc);
      if (ms_.torch.height_axis) out_.torch_height_target_mm = ms_.torch.pierce_height_mm;
      if (phase_ == Phase::torch_wait_arc) out_.torch_fire = true;
      break;
    case Step::Kind::torch_off:
      torch_off_and_retract(/*resume=*/false);
      break;
    case Step::Kind::dwell: phase_ = Phase::dwell; break;
  }
}

void Runner::torch_off_and_retract(bool resume) {
  out_.torch_fire = false;
  torch_lit_ = false;
  out_.torch_height_target_mm = ms_.torch.retract_height_mm;
  resume_after_torch_off_ = resume;
  phase_ = Phase::torch_off_retract;
}

void Runner::lower_to_cut_height() {
  out_.torch_height_target_mm = ms_.torch.cut_height_mm;
  phase_ = Phase::torch_height_cut;
  phase_t_ = 0.0;
}

void Runner::next_step() {
  ++steps_completed_;
  ++step_;
  phase_ = Phase::dispatch;
}

void Runner::start_paper_vector(std::size_t k, const Eigen::Vector2d& origin) {
  pk_ = k;
  pv_origin_ = origin;
  const Eigen::Vector2d d = pts_[k + 1] - origin;
  const double L = d.norm();
  const double F = pt_feed_[k + 1];
  if (L < 1e-9) {
    pv_T_s_ = pv_left_s_ = 0.0;
    return;
  }
  u_ = opt_.calibration_factor * F * d / L;
  pv_T_s_ = L / F;
  pv_left_s_ += pv_T_s_;  // open loop carries the remainder of the previous vector's time
}

void Runner::paper_move_tick() {
  if (pv_zero_pending_) {
    // The paper's start-shock cure: one period of zero speed before the first vector.
    u_.setZero();
    pv_zero_pending_ = false;
    pv_start_pending_ = true;
    return;
  }
  if (pv_start_pending_) {
    pv_start_pending_ = false;
    pv_left_s_ = 0.0;
    start_paper_vector(pk_, opt_.mode == Mode::paper_closed ? meas_mm_ : pts_[pk_]);
    return;
  }
  if (pv_computing_) {
    pv_compute_left_s_ -= dt_;
    if (pv_compute_left_s_ <= 1e-12) {
      pv_computing_ = false;
      pv_left_s_ = 0.0;
      start_paper_vector(pk_, pv_latched_);
    }
    return;
  }
  pv_left_s_ -= dt_;
  if (pv_left_s_ > 1e-12) return;
  const std::size_t last = step_last_pt_[step_];
  if (pk_ + 1 >= last) {
    u_.setZero();
    phase_ = Phase::paper_settle;
    phase_t_ = 0.0;
    return;
  }
  if (opt_.mode == Mode::paper_open) {
    start_paper_vector(pk_ + 1, pts_[pk_ + 1]);
  } else {
    // Read the counters now; the re-aimed command goes out after the computation time.
    pv_latched_ = meas_mm_;
    pk_ = pk_ + 1;
    if (opt_.paper_compute_s > 0) {
      pv_computing_ = true;
      pv_compute_left_s_ = opt_.paper_compute_s;
    } else {
      pv_left_s_ = 0.0;
      start_paper_vector(pk_, pv_latched_);
    }
  }
}

void Runner::sequence() {
  // Dispatch may chain through zero-time steps, bounded by the number of steps.
  for (std::size_t guard = 0; phase_ == Phase::dispatch && guard <= job_.steps.size() + 1; ++guard) begin_step();
  const TorchSetup& ts = ms_.torch;
  phase_t_ += dt_;
  move_t_ += dt_;
  switch (phase_) {
    case Phase::dispatch: break;
    case Phase::move: {
      const Step& st = job_.steps[step_];
      if (opt_.mode == Mode::planned) {
        const motion::Trajectory& tr = *trajs_[step_];
        const double T = tr.duration_s();
        tr.sample(std::min(phase_t_, T), sp_);
        // The move's last period: the servo keeps sampling it (clamped) until the next move.
        if (phase_t_ >= T) {
          sp_.velocity_mm_per_s.setZero();
          sp_.acceleration_mm_per_s2.setZero();
          hold_mm_ = sp_.position_mm;
          const motion::Stretch& s = job_.stretches[st.stretch];
          acc_[st.stretch].complete = true;
          if (s.rapid) rapid_mm_ += stretch_length_[st.stretch];
          next_step();
        }
      } else {
        paper_move_tick();
        // The commanded point of the vector in progress, for traces.
        const double f = pv_T_s_ > 0 ? std::clamp(1.0 - pv_left_s_ / pv_T_s_, 0.0, 1.0) : 1.0;
        sp_.position_mm = pv_origin_ + f * (pts_[pk_ + 1] - pv_origin_);
      }
      break;
    }
    case Phase::paper_settle:
      u_.setZero();
      if (phase_t_ >= opt_.paper_settle_s) {
        const Step& st = job_.steps[step_];
        acc_[st.stretch].complete = true;
        if (job_.stretches[st.stretch].rapid) rapid_mm_ += stretch_length_[st.stretch];
        sp_.position_mm = hold_mm_ = pts_[step_last_pt_[step_]];
        next_step();
      }
      break;
    case Phase::torch_height_pierce:
      if (std::abs(in_.torch_height_mm - ts.pierce_height_mm) <= ts.height_tolerance_mm) {
        phase_t_ = 0.0;
        if (ts.kind == TorchSetup::Kind::oxy_fuel) {
          phase_ = Phase::torch_preheat;
        } else {
          phase_ = Phase::torch_wait_arc;
          out_.torch_fire = true;
        }
      } else if (phase_t_ > ts.height_timeout_s) {
        raise(FK::torch_height_timeout, -1, ts.height_timeout_s);
      }
      break;
    case Phase::torch_preheat:
      if (phase_t_ >= ts.preheat_s) {
        out_.torch_fire = true;
        phase_ = Phase::torch_pierce;
        phase_t_ = 0.0;
      }
      break;
    case Phase::torch_wait_arc:
      if (in_.arc_ok) {
        phase_ = Phase::torch_pierce;
        phase_t_ = 0.0;
      } else if (phase_t_ > ts.arc_ok_timeout_s) {
        raise(FK::arc_start_failed, -1, ts.arc_ok_timeout_s);
      }
      break;
    case Phase::torch_pierce: {
      // A dwell step right after torch_on is the programmed pierce delay (G4).
      const bool programmed = step_ + 1 < job_.steps.size() && job_.steps[step_ + 1].kind == Step::Kind::dwell;
      if (programmed || phase_t_ >= ts.pierce_delay_s) {
        torch_lit_ = true;
        if (ts.height_axis && !programmed)
          lower_to_cut_height();
        else
          next_step();
      }
      break;
    }
    case Phase::torch_height_cut:
      if (std::abs(in_.torch_height_mm - ts.cut_height_mm) <= ts.height_tolerance_mm) {
        next_step();
      } else if (phase_t_ > ts.height_timeout_s) {
        raise(FK::torch_height_timeout, -1, ts.height_timeout_s);
      }
      break;
    case Phase::torch_off_retract:
      if (!ts.height_axis || std::abs(in_.torch_height_mm - ts.retract_height_mm) <= ts.height_tolerance_mm) {
        if (resume_after_torch_off_) {
          resume_after_torch_off_ = false;
          phase_ = Phase::dispatch;  // the same step again, now with the torch off
        } else {
          next_step();
        }
      } else if (phase_t_ > ts.height_timeout_s) {
        raise(FK::torch_height_timeout, -1, ts.height_timeout_s);
      }
      break;
    case Phase::dwell:
      if (phase_t_ >= job_.steps[step_].seconds - 1e-12) {
        // A programmed pierce dwell ends with the move to cut height.
        const bool after_torch_on = step_ > 0 && job_.steps[step_ - 1].kind == Step::Kind::torch_on;
        if (after_torch_on && ts.height_axis && torch_lit_)
          lower_to_cut_height();
        else
          next_step();
      }
      break;
    case Phase::end_hold:
      // Let the servo settle on the end point, then zero the command and disable.
      if (phase_t_ >= opt_.rest_window_s) {
        u_.setZero();
        phase_ = Phase::stop_disable;
      }
      break;
    case Phase::stop_ramp:
    case Phase::stop_settle:
    case Phase::stop_disable:
    case Phase::done: break;
  }
  // A step that ended in this tick hands over at once (torch off, next move) rather than one
  // period later.
  for (std::size_t guard = 0; phase_ == Phase::dispatch && !faulted_ && guard <= job_.steps.size() + 1; ++guard)
    begin_step();
}

void Runner::account_contour_error() {
  if (!moving_cut() || !in_.arc_ok) return;
  const std::size_t k = job_.steps[step_].stretch;
  const std::vector<Segment>& segs = job_.stretches[k].segments;
  // Nearest segment within a short window around the cursor: bounded work per tick. The tool
  // moves far less than one segment per tick, so the window always holds the nearest piece.
  const std::size_t lo = cursor_ > 0 ? cursor_ - 1 : 0;
  const std::size_t hi = std::min(segs.size(), cursor_ + 9);
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_i = cursor_;
  for (std::size_t i = lo; i < hi; ++i) {
    const double d = (closest_point(segs[i], meas_mm_) - meas_mm_).norm();
    if (d < best) best = d, best_i = i;
  }
  // Advance the cursor only over segments the tool can have passed: never jump over a long
  // segment (a closed contour ends where it starts, and a tool wobbling behind its start is
  // nearest to the END of the contour, not there yet).
  if (best_i > cursor_) {
    double skipped = 0.0;
    for (std::size_t i = cursor_ + 1; i < best_i; ++i) skipped += length(segs[i]);
    if (skipped <= 2.0) cursor_ = best_i;
  } else {
    cursor_ = best_i;
  }
  ErrorAcc& a = acc_[k];
  ++a.n;
  a.max = std::max(a.max, best);
  a.sum2 += best * best;
  if (has_truth_) {
    double bt = std::numeric_limits<double>::infinity();
    for (std::size_t i = lo; i < hi; ++i) bt = std::min(bt, (closest_point(segs[i], true_mm_) - true_mm_).norm());
    ++a.n_true;
    a.max_true = std::max(a.max_true, bt);
    a.sum2_true += bt * bt;
  }
}

void Runner::record_trace() {
  if (!opt_.record_trace || tick_ % opt_.trace_every_ticks != 0) return;
  if (trace_->size() >= trace_->capacity()) {  // never reallocate inside the loop
    trace_truncated_ = true;
    return;
  }
  TraceSample s;
  s.t_s = t_;
  s.step = step_ < job_.steps.size() ? static_cast<int>(step_) : -1;
  s.commanded_mm = sp_.position_mm;
  s.measured_mm = meas_mm_;
  s.true_mm = true_mm_;
  s.dac_x = out_.dac_code[0];
  s.dac_y = out_.dac_code[1];
  s.drives_enabled = out_.drives_enabled;
  s.torch_fire = out_.torch_fire;
  s.arc_ok = in_.arc_ok;
  trace_->push_back(s);
}

// One servo period. Budget and rules: see executor.h.
bool Runner::tick() {
  const hardware::Health health = be_.exchange(out_, in_);
  ++tick_;
  t_ += dt_;
  if (health == hardware::Health::lost) {
    // Nothing more can be commanded; the backend's watchdog stops the machine.
    raise(FK::lost_backend, -1, 0.0);
    stopped_at_rest_ = false;
    out_.torch_fire = false;
    out_.dac_code = {0, 0};
    out_.drives_enabled = false;
    phase_ = Phase::done;
    record_trace();
    return false;
  }
  if (phase_ == Phase::stop_disable && !out_.drives_enabled) {
    phase_ = Phase::done;
    record_trace();
    return false;
  }
  has_truth_ = be_.true_position(true_mm_);
  if (out_.torch_fire && in_.arc_ok) torch_on_s_ += dt_;

  // Feedback.
  if (trusted_) {
    for (int i = 0; i < 2; ++i) {
      const auto v = dec_[i].update(in_.counter[i], in_.counter_direction_negative[i]);
      if (v != control::CounterDecoder::Verdict::ok) {
        trusted_ = false;
        raise(v == control::CounterDecoder::Verdict::byte_carry_misread ? FK::counter_wrap_misread : FK::encoder_glitch, i,
              static_cast<double>(dec_[i].last_jump_counts()));
      }
    }
    if (trusted_) {
      meas_mm_ = {dec_[0].position_mm(), dec_[1].position_mm()};
      fault_.last_known_mm = meas_mm_;
    }
  }
  if (in_.estop) raise(FK::estop, -1, 0.0);
  if (stop_flag_.load(std::memory_order_relaxed)) raise(FK::stop_requested, -1, 0.0);
  if (moving_cut() && ms_.torch.kind == TorchSetup::Kind::plasma) {
    arc_low_s_ = in_.arc_ok ? 0.0 : arc_low_s_ + dt_;
    if (arc_low_s_ > ms_.torch.arc_loss_debounce_s) raise(FK::arc_lost, -1, arc_low_s_);
  }

  if (!faulted_) {
    account_contour_error();
    sequence();
  }
  if (faulted_ && !(phase_ == Phase::stop_ramp || phase_ == Phase::stop_settle || phase_ == Phase::stop_disable))
    enter_stop();

  switch (phase_) {
    case Phase::stop_ramp: {
      stop_t_ += dt_;
      const double s0 = stop_u0_.norm();
      const double s = std::max(0.0, s0 - ms_.max_acceleration_mm_per_s2 * stop_t_);
      u_ = s0 > 0 ? Eigen::Vector2d(stop_u0_ * (s / s0)) : Eigen::Vector2d::Zero();
      if (s <= 0.0) {
        u_.setZero();
        phase_ = Phase::stop_settle;
        phase_t_ = 0.0;
        rest_s_ = 0.0;
        rest_counts_ = {dec_[0].counts(), dec_[1].counts()};
      }
      break;
    }
    case Phase::stop_settle: {
      u_.setZero();
      phase_t_ += dt_;
      bool rest = false;
      if (trusted_) {
        const bool still = std::abs(dec_[0].counts() - rest_counts_[0]) <= 1 && std::abs(dec_[1].counts() - rest_counts_[1]) <= 1;
        rest_s_ = still ? rest_s_ + dt_ : 0.0;
        if (!still) rest_counts_ = {dec_[0].counts(), dec_[1].counts()};
        rest = rest_s_ >= opt_.rest_window_s;
        if (!rest && phase_t_ > 4 * opt_.stop_settle_s) {
          stopped_at_rest_ = false;
          rest = true;
        }
      } else {
        rest = phase_t_ >= opt_.stop_settle_s;
      }
      if (rest) phase_ = Phase::stop_disable;
      break;
    }
    case Phase::stop_disable:
      u_.setZero();
      break;
    default:
      if (opt_.mode == Mode::planned) {
        // The measurement is reading_latency periods old: compare it with the setpoint of that
        // instant. The command acts command_latency + 1 periods from now: feed forward the
        // setpoint of then. Both are samples of the same rest-to-rest trajectory (clamped at
        // its ends), so they are exact across step boundaries too.
        motion::Setpoint fb = sp_, ff = sp_;
        if (cur_traj_) {
          for (int i = 0; i < 2; ++i) {
            cur_traj_->sample(move_t_ - ms_.signals[i].reading_latency_ticks * dt_, fb);
            cur_traj_->sample(move_t_ + (ms_.signals[i].command_latency_ticks + 1) * dt_, ff);
            u_[i] = servo_[i].update(fb.position_mm[i], ff.velocity_mm_per_s[i], ff.acceleration_mm_per_s2[i], meas_mm_[i]);
          }
        } else {
          for (int i = 0; i < 2; ++i) u_[i] = servo_[i].update(sp_.position_mm[i], 0.0, 0.0, meas_mm_[i]);
        }
        if (!faulted_) {
          for (int i = 0; i < 2; ++i) {
            if (servo_[i].following_error_exceeded()) {
              raise(FK::following_error, i, servo_[i].last_error_mm());
              u_ = {servo_[0].last_output_mm_per_s(), servo_[1].last_output_mm_per_s()};
              enter_stop();
              break;
            }
          }
        }
      }
      break;
  }

  if (phase_ == Phase::stop_disable) {
    out_.drives_enabled = false;  // goes out with the next exchange, which ends the run
    u_.setZero();
  }
  out_.dac_code = {to_dac(0, u_[0]), to_dac(1, u_[1])};
  if (phase_ == Phase::stop_ramp || phase_ == Phase::stop_settle || phase_ == Phase::stop_disable) out_.torch_fire = false;
  record_trace();
  return true;
}

void Runner::run(ExecutionResult& r) {
  while (tick()) {
  }
  // ---- after the loop: allocation and formatting are allowed again ----
  r.cycle_time_s = t_;
  r.torch_on_s = torch_on_s_;
  r.rapid_distance_mm = rapid_mm_;
  r.steps_completed = steps_completed_;
  r.trace_truncated = trace_truncated_;
  r.torch_off_at_end = !out_.torch_fire;
  r.stopped_at_rest = stopped_at_rest_;
  for (std::size_t k = 0; k < acc_.size(); ++k) {
    const motion::Stretch& s = job_.stretches[k];
    if (!s.cutting || !acc_[k].touched) continue;
    CutError c;
    c.stretch = k;
    c.source_line = s.source_lines.empty() ? 0 : s.source_lines.front();
    c.samples = acc_[k].n;
    c.complete = acc_[k].complete;
    if (acc_[k].n > 0) {
      c.max_mm = acc_[k].max;
      c.rms_mm = std::sqrt(acc_[k].sum2 / acc_[k].n);
    }
    if (acc_[k].n_true > 0) {
      c.max_true_mm = acc_[k].max_true;
      c.rms_true_mm = std::sqrt(acc_[k].sum2_true / acc_[k].n_true);
    }
    r.cuts.push_back(c);
  }
  if (faulted_) {
    r.status = ExecutionResult::Status::faulted;
    FaultReport f = fault_;
    const std::string where = f.source_line > 0 ? fmt::format("{}:{}", job_.source, f.source_line) : job_.source;
    const std::string ax = f.axis == 0 ? "X" : (f.axis == 1 ? "Y" : "");
    switch (f.kind) {
      case FK::following_error:
        f.message = fmt::format("following error of {:.3f} mm on axis {} exceeds the limit of {} mm", f.value, ax,
                                ms_.servo[f.axis].following_error_limit_mm);
        break;
      case FK::encoder_glitch:
        f.message = fmt::format("counter of axis {} jumped {} counts in one period (at most {:.0f} are possible); the "
                                "encoder signal is not trusted from here",
                                ax, static_cast<long long>(f.value),
                                std::ceil(1.5 * ms_.max_speed_mm_per_s[f.axis] * dt_ / ms_.signals[f.axis].mm_per_count) + 2);
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
      case FK::arc_start_failed: f.message = fmt::format("no arc OK within {} s of firing the torch", f.value); break;
      case FK::arc_lost: f.message = fmt::format("arc OK dropped for {:.3f} s while cutting", f.value); break;
      case FK::torch_height_timeout:
        f.message = fmt::format("the torch height axis did not reach its target within {} s", f.value);
        break;
      case FK::stop_requested: f.message = "stop requested"; break;
    }
    f.message = fmt::format("{}: {} at t = {:.3f} s, step {}, last known position ({:.3f}, {:.3f}) mm", where, f.message,
                            f.time_s, f.step, f.last_known_mm.x(), f.last_known_mm.y());
    r.faults.push_back(std::move(f));
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Executor::Executor(MachineSetup setup, ExecutorOptions options) : setup_(std::move(setup)), options_(options) {
  setup_.validate();
  options_.validate();
}

ExecutionResult Executor::run(const motion::Job& job, const Trajectories& trajectories, hardware::Backend& backend) {
  stop_requested_.store(false);
  if (!(std::isfinite(backend.period_s()) && backend.period_s() > 0))
    throw std::invalid_argument(fmt::format("backend period {} s is not positive", backend.period_s()));
  ExecutionResult r;
  r.machine = setup_.name;
  r.source = job.source;
  r.mode = options_.mode;
  Runner runner(setup_, options_, job, trajectories, backend, stop_requested_);
  runner.validate_and_prepare(r);
  runner.run(r);
  return r;
}

// ---------------------------------------------------------------------------------------------

double ExecutionResult::max_contour_error_mm() const {
  double m = 0;
  for (const CutError& c : cuts) m = std::max(m, c.max_mm);
  return m;
}

double ExecutionResult::max_true_contour_error_mm() const {
  double m = kNaN;
  for (const CutError& c : cuts)
    if (!std::isnan(c.max_true_mm)) m = std::isnan(m) ? c.max_true_mm : std::max(m, c.max_true_mm);
  return m;
}

std::string ExecutionResult::report() const {
  std::string s = fmt::format("{} on {} ({} mode): {}\n", source.empty() ? "job" : source, machine, to_string(mode),
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
  return s;
}

nlohmann::json ExecutionResult::to_json(bool include_trace) const {
  using nlohmann::json;
  json j;
  j["source"] = source;
  j["machine"] = machine;
  j["mode"] = to_string(mode);
  j["status"] = status == Status::completed ? "completed" : "faulted";
  j["cycle_time_s"] = cycle_time_s;
  j["torch_on_s"] = torch_on_s;
  j["rapid_distance_mm"] = rapid_distance_mm;
  j["steps_completed"] = steps_completed;
  j["stopped_at_rest"] = stopped_at_rest;
  j["torch_off_at_end"] = torch_off_at_end;
  auto num = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
  j["cuts"] = json::array();
  for (const CutError& c : cuts)
    j["cuts"].push_back({{"stretch", c.stretch},
                         {"source_line", c.source_line},
                         {"samples", c.samples},
                         {"complete", c.complete},
                         {"max_contour_error_mm", c.max_mm},
                         {"rms_contour_error_mm", c.rms_mm},
                         {"max_true_contour_error_mm", num(c.max_true_mm)},
                         {"rms_true_contour_error_mm", num(c.rms_true_mm)}});
  j["faults"] = json::array();
  for (const FaultReport& f : faults)
    j["faults"].push_back({{"kind", to_string(f.kind)},
                           {"time_s", f.time_s},
                           {"step", f.step},
                           {"source_line", f.source_line},
                           {"axis", f.axis < 0 ? json(nullptr) : json(f.axis == 0 ? "x" : "y")},
                           {"last_known_mm", {f.last_known_mm.x(), f.last_known_mm.y()}},
                           {"commanded_mm", {f.commanded_mm.x(), f.commanded_mm.y()}},
                           {"value", f.value},
                           {"message", f.message}});
  if (include_trace) {
    json t = json::array();
    for (const TraceSample& s : trace)
      t.push_back({s.t_s, s.step, s.commanded_mm.x(), s.commanded_mm.y(), s.measured_mm.x(), s.measured_mm.y(),
                   num(s.true_mm.x()), num(s.true_mm.y()), s.dac_x, s.dac_y, s.drives_enabled, s.torch_fire, s.arc_ok});
    j["trace_columns"] = {"t_s",       "step",      "cmd_x_mm", "cmd_y_mm", "meas_x_mm", "meas_y_mm", "true_x_mm",
                          "true_y_mm", "dac_x",     "dac_y",    "enabled",  "torch_fire", "arc_ok"};
    j["trace"] = std::move(t);
  }
  return j;
}

void ExecutionResult::write_trace_csv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot open the trace file for writing");
  out << "t_s,step,cmd_x_mm,cmd_y_mm,meas_x_mm,meas_y_mm,true_x_mm,true_y_mm,dac_x,dac_y,enabled,torch_fire,arc_ok\n";
  for (const TraceSample& s : trace)
    out << fmt::format("{:.4f},{},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{},{},{:d},{:d},{:d}\n", s.t_s, s.step,
                       s.commanded_mm.x(), s.commanded_mm.y(), s.measured_mm.x(), s.measured_mm.y(), s.true_mm.x(),
                       s.true_mm.y(), s.dac_x, s.dac_y, s.drives_enabled, s.torch_fire, s.arc_ok);
  if (!out) throw InputError(path, 0, "writing the trace failed");
}

}  // namespace machplan::executor
