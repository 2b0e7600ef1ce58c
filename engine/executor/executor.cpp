// The executor's tick: everything the real-time loop runs, one servo period at a time. Its
// rules (executor.h, "Time budget"): no allocation, no lock, no I/O, no logging, nothing that
// throws; the buffers it writes were sized and touched in Session::Impl::prepare (session.cpp),
// and the messages are composed after the run (report.cpp). tests/executor/realtime_test.cpp
// counts the allocations; bench/executor_bench.cpp measures the time per tick.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "engine/executor/session_impl.h"
#include "engine/motion/process_time.h"

namespace machplan::executor {

using motion::Step;
using FK = FaultKind;

// A second arc loss closer than this to the last one ends the job: the recovery does not hold.
constexpr double kRepeatedArcLossMm = 5.0;

void Session::Impl::raise(FK kind, int axis, double value) noexcept {
  Supervisor::Where w;
  w.t_s = t;
  w.step = step < job.steps.size() ? static_cast<int>(step) : -1;
  w.source_line = step < job.steps.size() ? job.steps[step].source_line : 0;
  if (phase == Phase::move && source->source_line() > 0) w.source_line = source->source_line();
  w.commanded_mm = sp_mm;
  sup.raise(kind, axis, value, w);
}

FaultKind Session::Impl::torch_fault(TorchSequencer::Failure f) noexcept {
  switch (f) {
    case TorchSequencer::Failure::arc_start_failed: return FK::arc_start_failed;
    case TorchSequencer::Failure::probe_miss: return FK::probe_miss;
    case TorchSequencer::Failure::switch_stuck: return FK::probe_switch_stuck;
    case TorchSequencer::Failure::none:
    case TorchSequencer::Failure::torch_height_timeout: break;
  }
  return FK::torch_height_timeout;
}

// The probes the torch sequencer finished, and the height over the plate each pierce fired at.
void Session::Impl::record_probes(bool was_firing) noexcept {
  TorchSequencer::Probe p;
  if (torch.take_probe(p)) {
    if (result.probes.size() < result.probes.capacity()) {
      ProbeReport& r = result.probes.emplace_back();
      r.t_s = t;
      r.step = step < job.steps.size() ? static_cast<int>(step) : -1;
      r.source_line = step < job.steps.size() ? job.steps[step].source_line : 0;
      r.position_mm = p.at_mm;
      r.sensor = p.sensor == TorchSequencer::Probe::Sensor::ohmic          ? "ohmic"
                 : p.sensor == TorchSequencer::Probe::Sensor::float_switch ? "float_switch"
                 : p.sensor == TorchSequencer::Probe::Sensor::offset_probe ? "offset_probe"
                                                                           : "";
      r.skipped = p.skipped;
      r.surface_mm = p.surface_mm;
      r.duration_s = p.duration_s;
      awaiting_pierce = true;
      if (!p.skipped) surface.add(p.at_mm, p.surface_mm);
    } else {
      ++result.probes_dropped;
    }
  }
  double gap = 0.0;
  if (awaiting_pierce && out.torch_fire && !was_firing) {
    awaiting_pierce = false;
    if (be.true_torch_gap(gap)) result.probes.back().pierce_height_error_mm = gap - torch.pierce_height_mm();
  }
  if (!torch.lighting() && !torch.probing_for_pierce()) awaiting_pierce = false;  // stopped before it fired
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
      use_material(st.material);
      cut_begin = step;
      // The operator's torch switch off: this cut runs dry.
      dry = pauses_along_path() && !in.op.torch_enabled;
      if (dry) {
        ++result.dry_pierces;
        next_step();
        break;
      }
      // A ramp pierce moves along the cut that follows (after the dwell, which is then its delay).
      const std::size_t cut = torch.ramp() ? motion::ramp_cut(job, step) : 0;
      const bool ramp = cut > 0;
      start_torch(programmed, false, !ramp ? -1.0 : programmed ? job.steps[step + 1].seconds : torch.ramp()->pierce_delay_s);
      ramp_cut_step = ramp ? cut : kNoRamp;
      phase = Phase::torch;
      break;
    }
    case Step::Kind::torch_off:
      dry = false;
      torch.end_cut(out, st.height_mm);
      resume_after_torch_off = false;
      phase = Phase::torch;
      break;
    case Step::Kind::dwell: phase = Phase::dwell; break;
    case Step::Kind::probe:
      torch.set_position(adapter.position_mm());
      torch.start_probe(out);
      if (torch.busy()) phase = Phase::torch;
      else next_step();  // no offset probe on this machine: the torch on probes as it can
      break;
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
  const double paused_mm = op.paused_motion_mm - prev_op.paused_motion_mm;
  const bool torch_disabled = !op.torch_enabled && prev_op.torch_enabled;
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
  // The torch switched off while it fires (or pierces): off now, and a hold; the resume goes on
  // dry.
  const bool firing = pauses_along_path() && (out.torch_fire || torch.lighting()) && (phase == Phase::move || phase == Phase::torch);
  if (!held && torch_disabled && firing) {
    begin_hold(false);
    if (phase == Phase::move) cut_torch_off();
    if (hold) hold->by_torch_disable = hold->in_cut = hold->torch_off = true;
  }
  if (!held && (hold_edge || zero_feed)) begin_hold(!hold_edge);
  if (held && (held_by_override ? feed_rate > 0.0 : start_edge)) resume_asked = true;
  // Paused motion: asked while a move is held; follow_hold hands it to the source once the
  // machine stands with its torch off.
  if (held && phase == Phase::move && pauses_along_path() && std::isfinite(paused_mm)) paused_pending_mm += paused_mm;
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
  cut_torch_off();
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
  thc.update(ti);
  follow_surface(ti.allowed);
  out.torch_height_target_mm = torch.surface_mm() + torch.cut_height_mm() + thc.correction_mm() + surface_ff;
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

// Feed-forward from the surface map, and the map's points from THC. While THC acts, every
// kSurfaceStepMm of the cut adds the surface under the torch to the map (its height less the
// cut height and the gap the voltage's error shows, where that error is within THC's
// threshold). Where THC may act but does not (before it
// arms after the pierce, under an anti-dive lock), the torch follows the change of the
// surface the map estimates since THC stopped acting (not over a kerf); when THC acts again it takes that change
// into its correction, so the height does not jump.
constexpr double kSurfaceStepMm = 5.0;

void Session::Impl::follow_surface(bool allowed) noexcept {
  SurfaceMap& map = surface;
  const Eigen::Vector2d xy = adapter.position_mm();
  if (thc.active()) {
    if (surface_ff != 0.0) thc.shift(surface_ff);
    surface_ff = 0.0;
    surface_following = false;
    // Only where the voltage is steady at its target: a rise over a kerf is not the surface.
    const double error_v = thc.filtered_v() - thc.target_v();
    if (thc.holding() && thc.target_v() > 0.0 && std::abs(error_v) <= ms.torch.thc.threshold_v &&
        (xy - surface_last_xy).norm() >= kSurfaceStepMm) {
      const double gap_error = error_v / ms.torch.volts_per_mm;
      map.add(xy, in.torch_height_mm - torch.cut_height_mm() - gap_error);
      surface_last_xy = xy;
    }
    return;
  }
  // Over a kerf (the void lock) the height holds: the crossing is short, and the surface there
  // is where the torch just was.
  double est = 0.0;
  if (!allowed || thc.void_locked() || !map.estimate(xy, est)) return;
  if (!surface_following) {
    surface_base = est - surface_ff;  // from the height the torch has now
    surface_following = true;
  }
  surface_ff = std::clamp(est - surface_base, -ms.torch.thc.max_correction_mm, ms.torch.thc.max_correction_mm);
}

// A new cut, or a cut pierced again: the feed-forward starts over from the surface found.
void Session::Impl::start_torch(bool programmed, bool preheated, double moving_delay_s) noexcept {
  surface_ff = 0.0;
  surface_following = false;
  ramp_cut_step = kNoRamp;
  ramp_on = pierce_moving = false;
  torch.set_position(adapter.position_mm());
  torch.start_on(programmed, out, preheated, moving_delay_s);
}

// A ramp pierce whose motion delay has passed: on to its cut's move (past the dwell that was
// its delay), the torch sequence running on beside the motion (sequence()).
void Session::Impl::start_ramp() noexcept {
  steps_completed += static_cast<int>(ramp_cut_step - step);
  step = ramp_cut_step;
  ramp_cut_step = kNoRamp;
  pierce_moving = ramp_on = true;
  ramp_mm = 0.0;
  ramp_last_mm = sp_mm;
  ++result.ramp_pierces;
  phase = Phase::dispatch;
}

// The ramp's speed cap on the cut's first millimetres, as a rate of the plan there: the gouge
// speed, then the creep speed, then none.
double Session::Impl::ramp_rate() const noexcept {
  const motion::CutParameters* r = torch.ramp();
  if (!ramp_on || !r || phase != Phase::move) return 1.0;
  const motion::Stretch& s = job.stretches[job.steps[step].stretch];
  const double feed = s.feed_mm_per_s[std::min(contour.segment(), s.feed_mm_per_s.size() - 1)];
  const double v = ramp_mm < r->gouge_distance_mm ? r->gouge_speed_mm_per_s : r->creep_speed_mm_per_s;
  return feed > 0.0 ? std::min(1.0, v / feed) : 1.0;
}

// How close to rest the torch goes off in a held cut, mm of travel left (follow_hold).
constexpr double kTorchOffBeforeRestMm = 0.2;

void Session::Impl::begin_hold(bool by_override) noexcept {
  held = true;
  held_by_override = by_override;
  resume_asked = false;
  paused_pending_mm = 0.0;
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
      cut_torch_off();
      if (hold) {
        hold->in_cut = hold->torch_off = true;
        hold->torch_off_before_rest = source->rate() > 0.0 || hold->speed_mm_per_s == 0.0;
      }
    }
  }
  if (torch_off_running) {
    const TorchSequencer::Tick st = torch.tick(in, out);
    if (st == TorchSequencer::Tick::failed) raise(FK::torch_height_timeout, -1, torch.failure_value());
    if (st != TorchSequencer::Tick::busy) torch_off_running = false;
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
      // braking, and the debounce before it was called lost), within the cut; the operator may
      // go further.
      if (hold->by_arc_loss) {
        source->pause_move(-(hold->distance_to_stop_mm + hold->speed_mm_per_s * ms.torch.arc_loss_debounce_s), true);
        paused_by_arc_loss = true;
      }
    }
  }
  last_sp = sp_mm;
  const bool ready = at_rest && !torch_off_running;
  if (ready && paused_pending_mm != 0.0) source->pause_move(paused_pending_mm, false);
  if (ready) paused_pending_mm = 0.0;
  const double jog = in.op.paused_motion_speed;
  source->pause_jog(ready && pauses_along_path() && std::isfinite(jog) ? jog : 0.0);
  follow_paused_motion();
  if (!resume_asked || !ready || source->pause_moving()) return;
  resume_asked = false;
  if (hold) hold->resumed_at_s = t;
  if (cut_off && !in.op.torch_enabled) {
    // The torch switched off: the cut goes on dry from here.
    dry = true;
    cut_off = false;
  }
  if (cut_off) {
    // Re-pierce where the cut stopped (an oxy-fuel preheat flame kept burning).
    start_torch(false, ms.torch.kind == TorchSetup::Kind::oxy_fuel);
    repiercing = true;
    phase = Phase::torch;
    return;
  }
  held = false;
  hold = nullptr;
}

// The torch off in a held cut, beside the braking (follow_hold runs its sequence); the resume
// pierces again (standing: a ramp pierce under way is abandoned).
void Session::Impl::cut_torch_off() noexcept {
  torch.start_off(out);
  torch_off_running = true;
  cut_off = true;
  pierce_moving = ramp_on = false;
}

// A ramp pierce under way in a move: its torch sequence (the descent to cut height), and the
// distance along the cut for its speeds.
void Session::Impl::follow_ramp() noexcept {
  if (pierce_moving) {
    switch (torch.tick(in, out)) {
      case TorchSequencer::Tick::done: pierce_moving = false; break;
      case TorchSequencer::Tick::failed: raise(torch_fault(torch.failure()), -1, torch.failure_value()); break;
      case TorchSequencer::Tick::idle: pierce_moving = false; break;  // turned off (a hold)
      case TorchSequencer::Tick::busy: break;
    }
  }
  if (!ramp_on) return;
  ramp_mm += (sp_mm - ramp_last_mm).norm();  // along the commanded path: smooth, unlike the encoders
  ramp_last_mm = sp_mm;
  const motion::CutParameters* r = torch.ramp();
  if (held || !r || ramp_mm >= r->gouge_distance_mm + r->creep_distance_mm) ramp_on = false;
}

// A paused motion: its record, and the step the machine is on as it crosses moves.
void Session::Impl::follow_paused_motion() noexcept {
  const bool moving = source->pause_moving();
  if (moving && !paused_moving) {
    paused = nullptr;
    if (result.paused_motions.size() < result.paused_motions.capacity()) {
      paused = &result.paused_motions.emplace_back();
      paused->t_s = t;
      paused->from_step = static_cast<int>(step);
      paused->from_line = source->source_line();
      paused->from_mm = sp_mm;
      paused->by_arc_loss = paused_by_arc_loss;
    } else {
      ++result.paused_motions_dropped;
    }
    paused_by_arc_loss = false;
  }
  const std::size_t j = source->move_step();
  if (j != step && j < job.steps.size()) enter_paused_step(j);
  if (!moving && paused_moving) {
    const double moved = source->take_paused_mm();
    if (hold) hold->recovered_mm += moved;
    if (paused) {
      paused->end_s = t;
      paused->to_step = static_cast<int>(step);
      paused->to_line = source->source_line();
      paused->to_mm = sp_mm;
      paused->moved_mm = moved;
    }
    paused = nullptr;
    // The contour's cursor only moves on: find where the machine now stands.
    contour.seek(job.steps[step].stretch, sp_mm);
  }
  paused_moving = moving;
}

// The paused motion reached the move of step j: a cut there is one whose torch is off (the
// resume pierces), in its own material.
void Session::Impl::enter_paused_step(std::size_t j) noexcept {
  step = j;
  const std::size_t k = job.steps[j].stretch;
  contour.begin(k);
  cut_off = job.stretches[k].cutting;
  if (!cut_off) return;
  std::size_t on = j;
  while (on > 0 && job.steps[on].kind != Step::Kind::torch_on) --on;
  if (job.steps[on].kind == Step::Kind::torch_on && on != cut_begin) {
    cut_begin = on;
    use_material(job.steps[on].material);
  }
  thc_acc[k].material = material;
}

void Session::Impl::use_material(int index) noexcept {
  material = index;
  const motion::CutParameters* m = material >= 0 ? &job.materials[static_cast<std::size_t>(material)] : nullptr;
  torch.use_material(m);
  thc.reset(m ? m->cut_volts : 0.0);
  out.chart_volts_v = m ? m->cut_volts : 0.0;
  out.chart_height_mm = m ? m->cut_height_mm : 0.0;
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
      follow_ramp();
      // (A paused motion crossing into the previous move stands at its end for a period.)
      if (source->move_done() && !source->pause_moving()) {
        const std::size_t k = job.steps[step].stretch;
        contour.complete(k);
        if (job.stretches[k].rapid) rapid_mm += stretch_len[k];
        next_step();
      }
      break;
    case Phase::torch:
      if (ramp_cut_step != kNoRamp && torch.motion_allowed()) {
        start_ramp();
        break;
      }
      switch (torch.tick(in, out)) {
        case TorchSequencer::Tick::done:
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
        case TorchSequencer::Tick::failed: raise(torch_fault(torch.failure()), -1, torch.failure_value()); break;
        case TorchSequencer::Tick::idle:
        case TorchSequencer::Tick::busy: break;
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
    out.torch_fire = out.laser_on = false;
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
  // A torch that met the plate: torch off in this period and a controlled stop, as for the
  // E-stop; the axes cannot drag it on through the sheet.
  if (in.torch_breakaway) raise(FK::torch_breakaway, -1, in.torch_height_mm);
  // The float switch closing while the torch fires: something pushed the torch up (a tipped
  // part, a dive into the plate); QtPlasmaC treats it as a breakaway.
  float_closed = ms.torch.probe.float_switch && out.torch_fire && in.float_switch ? float_closed + 1 : 0;
  if (float_closed >= ms.torch.probe.debounce_periods) raise(FK::torch_breakaway, 2, in.torch_height_mm);
  if (parts.termination && parts.termination->should_end()) raise(FK::stop_requested, -1, 0.0);
  if (sup.arc_lost(moving_cut() && ms.torch.kind == TorchSetup::Kind::plasma, in.arc_ok)) arc_lost();

  if (!sup.faulted() && !sup.stopping()) {
    if (moving_cut() && in.arc_ok)
      contour.account(job.steps[step].stretch, adapter.position_mm(), has_truth, true_mm);
    else
      contour.clear_last();
    const bool was_firing = out.torch_fire;
    sequence();
    record_probes(was_firing);
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
  // The plan ahead, for a backend that plays it when a command comes late: only where the
  // command is the source's own setpoint (not a stop's law, not a guard's correction).
  const bool own_setpoint = !sup.stopping() && sup.state() != Supervisor::State::disable && !parts.filter &&
                           demand.kind == Demand::Kind::track && adapter.position_commands();
  out.ahead_count = ahead_periods > 0 && own_setpoint ? source->plan_ahead(out.ahead_mm.data(), ahead_periods) : 0;
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
  // The laser pointer of a frame: on while its moves run.
  out.laser_on = job.laser_pointer && phase == Phase::move && !sup.faulted() && !sup.stopping();
  record_trace();
  publish_live();
  return true;
}

std::uint32_t Session::Impl::next_session_id() noexcept {
  static std::atomic<std::uint32_t> sessions{0};
  return sessions.fetch_add(1, std::memory_order_relaxed) + 1;
}

void Session::Impl::publish_live() noexcept {
  if (!parts.live) return;
  LiveState l;
  l.session = session_id;
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
  l.laser_on = out.laser_on;
  l.arc_ok = in.arc_ok;
  l.torch_height_mm = in.torch_height_mm;
  l.thc_active = thc_acting;
  l.arc_voltage_v = in.arc_voltage_v;
  l.progress = std::min(progress_s / expected_s, over ? 1.0 : 0.999);
  // What is left at the current overrides as the machine will take them (a feed override above
  // 100 % speeds up only the cruises its limits leave room in); a hold stops the clock, it
  // does not run it. A source that cannot say has the plan's time divided by the override.
  const double left = std::max(0.0, expected_s - progress_s);
  const double rate = std::max(feed_rate, 0.05);
  double feed_plan = 0.0, rapid_plan = 0.0, feed_s = 0.0, rapid_s = 0.0;
  l.feed_effective_pct = l.feed_override_pct;
  if (!source->supports_rate()) {
    l.feed_effective_pct = 100.0;  // the source runs at its one speed
    l.time_left_s = left;
  } else if (source->motion_left_s(1.0, 1.0, feed_plan, rapid_plan) &&
             source->motion_left_s(rate, rapid_rate, feed_s, rapid_s)) {
    if (feed_rate > 1.0) l.feed_effective_pct = feed_s > 0.0 ? 100.0 * feed_plan / feed_s : 100.0;
    l.time_left_s = held ? left : std::max(0.0, left - feed_plan - rapid_plan) + feed_s + rapid_s;
  } else {
    l.time_left_s = held ? left : left / rate;
  }
  l.fault = sup.faulted() ? static_cast<int>(sup.kind()) : -1;
  l.holds = static_cast<int>(result.holds.size());
  parts.live->publish(l);
}
}  // namespace machplan::executor
