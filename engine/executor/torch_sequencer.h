// The torch's part of a job: pierce, arc OK, height and retract. The executor's step machine
// starts a sequence (a torch_on or torch_off step, or the lowering to cut height after a
// programmed pierce dwell) and calls tick() every period until it is done or fails; while a
// sequence runs the axes hold still.
//
//   torch on (plasma, height axis):  height to pierce height -> fire -> wait for arc OK (at
//       most arc_ok_timeout_s) -> pierce delay -> height to cut height
//   torch on (oxy-fuel):  [height to pierce height] -> preheat -> cutting oxygen -> pierce delay
//       -> [height to cut height]
//   a dwell step right after the torch_on IS the pierce delay (G4): the sequence then ends at
//       the pierce, and lower_to_cut_height() follows the dwell
//   torch off:  stop firing, height to retract height (or the step's higher travel height)
//
// Every wait on the height axis fails after height_timeout_s (torch_height_timeout); a missing
// arc OK fails the start (arc_start_failed). kill() turns the torch off and retracts in the
// same period, whatever runs: the supervisor calls it on every fault.
//
// Real time: tick() is O(1), allocates nothing and never throws.
#pragma once

#include "engine/executor/machine_setup.h"
#include "engine/hardware/backend.h"
#include "engine/motion/job.h"

namespace machplan::executor {

class TorchSequencer {
 public:
  // What one period of the sequence did: nothing to do, still stepping, finished, or failed
  // (failure_value() says how). How the run ended is the run's Summary, not this.
  enum class Tick { idle, busy, done, failed };
  enum class Failure { none, arc_start_failed, torch_height_timeout };

  void configure(const TorchSetup& t, double period_s) {
    t_ = base_ = t;
    dt_ = period_s;
    phase_ = Phase::idle;
    lit_ = false;
  }

  // A torch_on step; `programmed_pierce` when a dwell step follows it. `preheated`: an
  // oxy-fuel torch whose preheat flame kept burning (a re-pierce after a hold) goes straight
  // to the cutting oxygen.
  void start_on(bool programmed_pierce, hardware::Outputs& out, bool preheated = false) noexcept;
  // A torch_off step: the torch retracts to the retract height, or to `height_mm` when that
  // is higher (a rapid over parts already cut follows).
  void start_off(hardware::Outputs& out, double height_mm = 0.0) noexcept;
  // The torch_off step that ends a cut: the material's pause at the end first.
  void end_cut(hardware::Outputs& out, double height_mm) noexcept;
  void lower_to_cut_height(hardware::Outputs& out) noexcept;
  // The cuts from the next start_on() on take their pierce height, pierce delay and cut height
  // from `m` (a material of the job), or from the machine's setup when null. Real time.
  // With a material also its puddle jump (after the pierce: up or down to a share of the
  // pierce height, a wait there, then cut height; not after a programmed pierce dwell) and its
  // pause at the end of each cut (the torch burns on at rest before a torch_off step).
  void use_material(const motion::CutParameters* m) noexcept {
    t_ = base_;
    puddle_mm_ = puddle_s_ = pause_end_s_ = 0.0;
    if (!m) return;
    t_.pierce_height_mm = m->pierce_height_mm;
    t_.pierce_delay_s = m->pierce_delay_s;
    t_.cut_height_mm = m->cut_height_mm;
    if (m->puddle_jump_height_pct > 0.0) {
      puddle_mm_ = m->pierce_height_mm * m->puddle_jump_height_pct / 100.0;
      puddle_s_ = m->puddle_jump_delay_s;
    }
    pause_end_s_ = m->pause_at_end_s;
  }
  double cut_height_mm() const noexcept { return t_.cut_height_mm; }
  // Torch off and retract now (faults, stops); the sequence in progress is abandoned.
  void kill(hardware::Outputs& out) noexcept;

  Tick tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept;

  bool busy() const noexcept { return phase_ != Phase::idle; }
  // A torch-on sequence is under way (not the retract).
  bool lighting() const noexcept { return busy() && phase_ != Phase::off_retract; }
  // The torch-on sequence completed and the torch has not been turned off since.
  bool lit() const noexcept { return lit_; }
  Failure failure() const noexcept { return failure_; }
  double failure_value() const noexcept { return failure_value_; }

 private:
  enum class Phase { idle, height_pierce, preheat, wait_arc, pierce, puddle_jump, puddle_wait, height_cut, pause_end, off_retract };
  void enter(Phase p) noexcept {
    phase_ = p;
    pt_ = 0.0;
  }
  Tick fail(Failure f, double v) noexcept {
    failure_ = f;
    failure_value_ = v;
    phase_ = Phase::idle;
    return Tick::failed;
  }
  bool at(const hardware::Inputs& in, double h) const noexcept {
    return std::abs(in.torch_height_mm - h) <= t_.height_tolerance_mm;
  }

  TorchSetup t_, base_;  // the cuts' settings now, and the machine's
  double puddle_mm_ = 0.0, puddle_s_ = 0.0, pause_end_s_ = 0.0;  // the material's (0: none)
  double dt_ = 0.001;
  Phase phase_ = Phase::idle;
  double pt_ = 0.0;  // time in the phase
  bool programmed_ = false, lit_ = false, preheated_ = false;
  double retract_mm_ = 0.0;  // the height of the retract in progress
  Failure failure_ = Failure::none;
  double failure_value_ = 0.0;
};

}  // namespace machplan::executor
