#include "engine/executor/torch_sequencer.h"

#include <algorithm>
#include <cmath>

namespace machplan::executor {

using Kind = TorchSetup::Kind;

void TorchSequencer::start_on(bool programmed_pierce, hardware::Outputs& out, bool preheated) noexcept {
  programmed_ = programmed_pierce && t_.kind != Kind::spindle;  // a spindle spins up whatever follows
  preheated_ = preheated;
  if (t_.kind == Kind::spindle) {
    out.torch_fire = true;  // the spindle runs; the spin-up is its "pierce"
    enter(Phase::pierce);
  } else if (t_.height_axis) {
    out.torch_height_target_mm = t_.pierce_height_mm;
    enter(Phase::height_pierce);
  } else if (t_.kind == Kind::oxy_fuel && !preheated_) {
    enter(Phase::preheat);
  } else if (t_.kind == Kind::oxy_fuel) {
    out.torch_fire = true;
    enter(Phase::pierce);
  } else {
    out.torch_fire = true;
    enter(Phase::wait_arc);
  }
}

void TorchSequencer::start_off(hardware::Outputs& out, double height_mm) noexcept {
  kill(out);
  retract_mm_ = std::max(t_.retract_height_mm, height_mm);
  out.torch_height_target_mm = retract_mm_;
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
  out.torch_fire = false;
  out.torch_height_target_mm = t_.retract_height_mm;
  lit_ = false;
  phase_ = Phase::idle;
}

void TorchSequencer::lower_to_cut_height(hardware::Outputs& out) noexcept {
  out.torch_height_target_mm = t_.cut_height_mm;
  enter(Phase::height_cut);
}

TorchSequencer::Tick TorchSequencer::tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept {
  pt_ += dt_;
  switch (phase_) {
    case Phase::idle: return Tick::idle;
    case Phase::height_pierce:
      if (at(in, t_.pierce_height_mm)) {
        if (t_.kind == Kind::oxy_fuel && !preheated_) {
          enter(Phase::preheat);
        } else if (t_.kind == Kind::oxy_fuel) {
          out.torch_fire = true;
          enter(Phase::pierce);
        } else {
          out.torch_fire = true;
          enter(Phase::wait_arc);
        }
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
    case Phase::pierce:
      if (programmed_ || pt_ >= (t_.kind == Kind::spindle ? t_.spin_up_s : t_.pierce_delay_s)) {
        lit_ = true;
        if (t_.height_axis && !programmed_ && puddle_mm_ > 0.0) {
          out.torch_height_target_mm = puddle_mm_;
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
        out.torch_height_target_mm = h;
        enter(Phase::off_retract);
      }
      return Tick::busy;
    case Phase::height_cut:
      if (at(in, t_.cut_height_mm)) {
        phase_ = Phase::idle;
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
