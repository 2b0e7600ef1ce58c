#include "engine/executor/torch_sequencer.h"

#include <algorithm>
#include <cmath>

namespace machplan::executor {

using Kind = TorchSetup::Kind;

void TorchSequencer::start_on(bool programmed_pierce, hardware::Outputs& out, bool preheated, double moving_delay_s) noexcept {
  programmed_ = programmed_pierce && t_.kind != Kind::spindle;  // a spindle spins up whatever follows
  preheated_ = preheated;
  moving_ = moving_delay_s >= 0.0 && ramp_ && t_.kind == Kind::plasma && t_.height_axis;
  motion_ok_ = false;
  if (moving_) {
    programmed_ = false;  // the dwell's time is the ramp's pierce delay
    t_.pierce_delay_s = moving_delay_s;
  }
  if (t_.kind == Kind::spindle) {
    out.torch_fire = true;  // the spindle runs; the spin-up is its "pierce"
    enter(Phase::pierce);
  } else if (t_.height_axis && t_.probe.fitted() && offset_ready_) {
    offset_ready_ = false;  // the probe step before it found the surface here
    aim(out, t_.pierce_height_mm);
    enter(Phase::height_pierce);
  } else if (t_.height_axis && t_.probe.fitted()) {
    begin_probe(out, false);
  } else if (t_.height_axis) {
    aim(out, t_.pierce_height_mm);
    enter(Phase::height_pierce);
  } else {
    light(out);
  }
}

void TorchSequencer::light(hardware::Outputs& out) noexcept {
  if (t_.kind == Kind::oxy_fuel && !preheated_) {
    enter(Phase::preheat);
  } else if (t_.kind == Kind::oxy_fuel) {
    out.torch_fire = true;
    enter(Phase::pierce);
  } else {
    out.torch_fire = true;
    enter(Phase::wait_arc);
  }
}

void TorchSequencer::start_probe(hardware::Outputs& out) noexcept {
  offset_ready_ = false;
  if (!t_.height_axis || !t_.probe.offset()) {
    phase_ = Phase::idle;  // nothing to probe with: the torch on will say how it found the sheet
    return;
  }
  begin_probe(out, true);
}

void TorchSequencer::begin_probe(hardware::Outputs& out, bool offset_step) noexcept {
  const ProbeSetup& p = t_.probe;
  const Eigen::Vector2d where = offset_step ? Eigen::Vector2d(at_mm_.x() + p.offset_x_mm, at_mm_.y() + p.offset_y_mm) : at_mm_;
  probe_ = Probe{};
  probe_.at_mm = where;
  probe_t_ = 0.0;
  offset_step_ = offset_step;
  // The surface expected here: the map's estimate, within the probe's reach of the nominal
  // surface (an estimate far out is an extrapolation gone wrong, not the sheet).
  expected_mm_ = 0.0;
  map_.estimate(where, expected_mm_);
  expected_mm_ = std::clamp(expected_mm_, -p.max_depth_mm, p.max_depth_mm);
  // An offset probe probes in its own steps only: a torch on without one takes the estimate.
  const bool skip = probed_ && p.skip_distance_mm > 0 && (where - probed_at_mm_).cwiseAbs().maxCoeff() <= p.skip_distance_mm;
  if (!offset_step && (skip || p.offset())) {
    surface_mm_ = expected_mm_;
    probe_.skipped = true;
    probe_.surface_mm = surface_mm_;
    probe_ready_ = true;
    aim(out, t_.pierce_height_mm);
    enter(Phase::height_pierce);
    return;
  }
  ohmic_run_ = float_run_ = 0;
  if (offset_step) {
    out.offset_probe = true;  // deployed where the torch stands, then down
    enter(Phase::probe_deploy);
    return;
  }
  out.ohmic_enable = p.ohmic;
  out.torch_height_target_mm = expected_mm_ + p.probe_height_mm;
  enter(Phase::probe_fast);
}

bool TorchSequencer::sensed(const hardware::Inputs& in) noexcept {
  const ProbeSetup& p = t_.probe;
  const bool ohmic = p.ohmic && in.ohmic_sense, flt = p.float_switch && in.float_switch;
  if (ohmic && ohmic_run_++ == 0) ohmic_z_ = in.torch_height_mm;
  if (!ohmic) ohmic_run_ = 0;
  if (flt && float_run_++ == 0) float_z_ = in.torch_height_mm;
  if (!flt) float_run_ = 0;
  return ohmic_run_ >= p.debounce_periods || float_run_ >= p.debounce_periods;
}

void TorchSequencer::found(double surface_mm, Probe::Sensor s, hardware::Outputs& out) noexcept {
  out.ohmic_enable = false;
  surface_mm_ = surface_mm;
  probed_ = true;
  probed_at_mm_ = probe_.at_mm;
  map_.add(probe_.at_mm, surface_mm);
  probe_.sensor = offset_step_ ? Probe::Sensor::offset_probe : s;
  probe_.surface_mm = surface_mm;
  probe_.duration_s = probe_t_;
  probe_ready_ = true;
  if (offset_step_) {
    out.offset_probe = false;  // stowed on the way up, clear of the sheet before the torch moves
    aim(out, t_.probe.probe_height_mm);
    enter(Phase::probe_stow);
    return;
  }
  aim(out, t_.pierce_height_mm);  // up by the float's travel and on to pierce height
  enter(Phase::height_pierce);
}

TorchSequencer::Tick TorchSequencer::probe_tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept {
  const ProbeSetup& p = t_.probe;
  probe_t_ += dt_;
  const bool contact = sensed(in);
  switch (phase_) {
    case Phase::probe_deploy:
      // A contact as the probe comes down, the torch still up: stuck, or deployed onto something.
      if (contact) return fail_probe(Failure::switch_stuck, 1.0, out);
      if (pt_ >= p.offset_delay_s) {
        out.torch_height_target_mm = expected_mm_ + p.probe_height_mm;
        enter(Phase::probe_fast);
      }
      return Tick::busy;
    case Phase::probe_stow:
      if (pt_ >= p.offset_delay_s && at(in, p.probe_height_mm)) {
        offset_step_ = false;
        offset_ready_ = true;
        phase_ = Phase::idle;
        return Tick::done;
      }
      if (pt_ > std::max(t_.height_timeout_s, p.offset_delay_s)) return fail_probe(Failure::torch_height_timeout, t_.height_timeout_s, out);
      return Tick::busy;
    case Phase::probe_fast:
      // A sensor closed from the first period on (debounced by the probe's first periods),
      // with the torch still up: stuck or shorted.
      if (contact && pt_ <= (p.debounce_periods + 0.5) * dt_) return fail_probe(Failure::switch_stuck, in.float_switch ? 1.0 : 0.0, out);
      if (contact) {
        // The sheet stands higher than expected: back up over it and probe slowly from there.
        const double z = ohmic_run_ >= p.debounce_periods ? ohmic_z_ + p.ohmic_offset_mm : float_z_ + p.float_travel_mm;
        out.torch_height_target_mm = probe_target_mm_ = z + 1.0;
        enter(Phase::probe_back);
      } else if (std::abs(in.torch_height_mm - (expected_mm_ + p.probe_height_mm)) <= t_.height_tolerance_mm) {
        probe_target_mm_ = expected_mm_ + p.probe_height_mm;
        enter(Phase::probe_slow);
      } else if (pt_ > t_.height_timeout_s) {
        return fail_probe(Failure::torch_height_timeout, t_.height_timeout_s, out);
      }
      return Tick::busy;
    case Phase::probe_back:
      if (std::abs(in.torch_height_mm - probe_target_mm_) <= t_.height_tolerance_mm && !in.float_switch) {
        ohmic_run_ = float_run_ = 0;
        enter(Phase::probe_slow);
      } else if (pt_ > t_.height_timeout_s) {
        return fail_probe(Failure::torch_height_timeout, t_.height_timeout_s, out);
      }
      return Tick::busy;
    default: break;  // probe_slow
  }
  if (ohmic_run_ >= p.debounce_periods) {
    found(ohmic_z_ + p.ohmic_offset_mm, Probe::Sensor::ohmic, out);
  } else if (float_run_ >= p.debounce_periods) {
    found(float_z_ + p.float_travel_mm, Probe::Sensor::float_switch, out);
  } else {
    // At least max_depth_mm under the nominal surface, and under the expected one.
    const double floor = std::min(expected_mm_, 0.0) - p.max_depth_mm;
    probe_target_mm_ = std::max(floor, probe_target_mm_ - p.probe_speed_mm_per_s * dt_);
    out.torch_height_target_mm = probe_target_mm_;
    if (probe_target_mm_ <= floor && in.torch_height_mm <= floor + t_.height_tolerance_mm)
      return fail_probe(Failure::probe_miss, p.max_depth_mm, out);
  }
  return Tick::busy;
}

void TorchSequencer::start_off(hardware::Outputs& out, double height_mm) noexcept {
  kill(out);
  retract_mm_ = std::max(t_.retract_height_mm, height_mm);
  aim(out, retract_mm_);
  enter(Phase::off_retract);
}

void TorchSequencer::end_cut(hardware::Outputs& out, double height_mm) noexcept {
  if (!lit_ || pause_end_s_ <= 0.0 || t_.kind == Kind::spindle) {
    start_off(out, height_mm);
    return;
  }
  retract_mm_ = std::max(t_.retract_height_mm, height_mm);
  enter(Phase::pause_end);
}

void TorchSequencer::kill(hardware::Outputs& out) noexcept {
  moving_ = motion_ok_ = offset_step_ = offset_ready_ = false;
  out.torch_fire = false;
  out.ohmic_enable = out.offset_probe = false;
  aim(out, t_.retract_height_mm);
  lit_ = false;
  phase_ = Phase::idle;
}

void TorchSequencer::lower_to_cut_height(hardware::Outputs& out) noexcept {
  aim(out, t_.cut_height_mm);
  enter(Phase::height_cut);
}

// The pierce delay. A ramp pierce: from the motion delay on the axes may move, and the height
// goes from the pierce height to the end height by the end of the delay, then waits there the
// cut height delay (pierce_end).
TorchSequencer::Tick TorchSequencer::pierce_tick(const hardware::Inputs&, hardware::Outputs& out) noexcept {
  const double delay = t_.kind == Kind::spindle ? t_.spin_up_s : t_.pierce_delay_s;
  if (moving_) {
    const double t0 = delay * ramp_->pierce_motion_delay_pct / 100.0;
    const double end = ramp_->pierce_end_height_mm > 0.0 ? ramp_->pierce_end_height_mm : t_.cut_height_mm;
    motion_ok_ = pt_ >= t0;
    if (motion_ok_) aim(out, t_.pierce_height_mm + (end - t_.pierce_height_mm) * std::min(1.0, (pt_ - t0) / std::max(delay - t0, dt_)));
    if (pt_ >= delay) {
      lit_ = true;
      enter(Phase::pierce_end);
    }
    return Tick::busy;
  }
  if (!programmed_ && pt_ < delay) return Tick::busy;
  lit_ = true;
  if (t_.height_axis && !programmed_ && puddle_mm_ > 0.0) {
    aim(out, puddle_mm_);
    enter(Phase::puddle_jump);
    return Tick::busy;
  }
  if (t_.height_axis && !programmed_) {
    lower_to_cut_height(out);
    return Tick::busy;
  }
  phase_ = Phase::idle;
  return Tick::done;
}

TorchSequencer::Tick TorchSequencer::tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept {
  pt_ += dt_;
  switch (phase_) {
    case Phase::idle: return Tick::idle;
    case Phase::probe_deploy:
    case Phase::probe_fast:
    case Phase::probe_back:
    case Phase::probe_slow:
    case Phase::probe_stow: return probe_tick(in, out);
    case Phase::height_pierce:
      if (at(in, t_.pierce_height_mm)) {
        light(out);
      } else if (pt_ > t_.height_timeout_s) {
        return fail(Failure::torch_height_timeout, t_.height_timeout_s);
      }
      return Tick::busy;
    case Phase::preheat:
      if (pt_ >= t_.preheat_s) {
        out.torch_fire = true;
        enter(Phase::pierce);
      }
      return Tick::busy;
    case Phase::wait_arc:
      if (in.arc_ok) {
        enter(Phase::pierce);
      } else if (pt_ > t_.arc_ok_timeout_s) {
        return fail(Failure::arc_start_failed, t_.arc_ok_timeout_s);
      }
      return Tick::busy;
    case Phase::pierce: return pierce_tick(in, out);
    case Phase::pierce_end:
      if (pt_ >= ramp_->cut_height_delay_s) lower_to_cut_height(out);
      return Tick::busy;
    case Phase::puddle_jump:
      if (at(in, puddle_mm_)) enter(Phase::puddle_wait);
      else if (pt_ > t_.height_timeout_s) return fail(Failure::torch_height_timeout, t_.height_timeout_s);
      return Tick::busy;
    case Phase::puddle_wait:
      if (pt_ >= puddle_s_) lower_to_cut_height(out);
      return Tick::busy;
    case Phase::pause_end:
      if (pt_ >= pause_end_s_) {
        const double h = retract_mm_;
        kill(out);
        retract_mm_ = h;
        aim(out, h);
        enter(Phase::off_retract);
      }
      return Tick::busy;
    case Phase::height_cut:
      if (at(in, t_.cut_height_mm)) {
        phase_ = Phase::idle;
        moving_ = motion_ok_ = false;
        return Tick::done;
      }
      if (pt_ > t_.height_timeout_s) return fail(Failure::torch_height_timeout, t_.height_timeout_s);
      return Tick::busy;
    case Phase::off_retract:
      if (t_.kind == Kind::spindle && pt_ < t_.spin_down_s) return Tick::busy;  // running down
      if (!t_.height_axis || at(in, retract_mm_)) {
        phase_ = Phase::idle;
        return Tick::done;
      }
      if (pt_ > t_.height_timeout_s) return fail(Failure::torch_height_timeout, t_.height_timeout_s);
      return Tick::busy;
  }
  return Tick::idle;
}

}  // namespace machplan::executor
