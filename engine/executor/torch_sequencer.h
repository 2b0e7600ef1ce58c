// The torch's part of a job: pierce, arc OK, height and retract. The executor's step machine
// starts a sequence (a torch_on or torch_off step, or the lowering to cut height after a
// programmed pierce dwell) and calls tick() every period until it is done or fails; while a
// sequence runs the axes hold still.
//
//   torch on (plasma, height axis):  [probe] -> height to pierce height -> fire -> wait for
//       arc OK (at most arc_ok_timeout_s) -> pierce delay -> height to cut height
//   probe (TorchSetup::probe fitted):  sensors open? (closed before the torch moved: switch
//       stuck) -> down at the axis' speed to the probe height over the expected surface (a
//       contact on the way: back up 1 mm over it) -> down at the probe speed until the ohmic
//       contact or the float switch has read closed debounce_periods in a row (none by
//       max_depth_mm under the expected surface and the nominal one: probe miss) -> the surface is where it first
//       read closed (+ the float's travel for the float switch). The expected surface is the
//       one the earlier probes' surface map (engine/executor/surface_map.h) estimates there
//       (the nominal 0 before any). A pierce within skip_distance_mm of the last probed point
//       does not probe: its surface is the map's estimate.
//   probe step (an offset probe, ProbeSetup::offset_x_mm): deploy the probe (offset_probe on,
//       offset_delay_s) -> the probe above, under the probe's position (where the torch stands
//       plus the offset), its contact read on the float-switch input -> stow (offset_probe off)
//       and up to the probe height over the surface found, at least offset_delay_s. The next
//       torch on pierces over that surface without probing; a torch on that no probe step
//       prepared (a re-pierce after a hold) takes the map's estimate, as a skipped probe does.
//   torch on (oxy-fuel):  [height to pierce height] -> preheat -> cutting oxygen -> pierce delay
//       -> [height to cut height]
//   a dwell step right after the torch_on IS the pierce delay (G4): the sequence then ends at
//       the pierce, and lower_to_cut_height() follows the dwell
//   torch off:  stop firing, height to retract height (or the step's higher travel height)
//
// Heights: the torch heights (pierce, cut, retract, puddle jump) are over the surface the last
// probe found; the outputs add that surface (0 until a probe: the sheet's nominal surface).
//
// Every wait on the height axis fails after height_timeout_s (torch_height_timeout); a missing
// arc OK fails the start (arc_start_failed); a probe fails as probe_miss or switch_stuck. kill() turns the torch off and retracts in the
// same period, whatever runs: the supervisor calls it on every fault.
//
// Real time: tick() is O(1), allocates nothing and never throws.
#pragma once

#include <Eigen/Core>

#include "engine/executor/machine_setup.h"
#include "engine/executor/surface_map.h"
#include "engine/hardware/backend.h"
#include "engine/motion/job.h"

namespace machplan::executor {

class TorchSequencer {
 public:
  // What one period of the sequence did: nothing to do, still stepping, finished, or failed
  // (failure_value() says how). How the run ended is the run's Summary, not this.
  enum class Tick { idle, busy, done, failed };
  enum class Failure { none, arc_start_failed, torch_height_timeout, probe_miss, switch_stuck };

  // One probe, or one skipped by the skip rule.
  struct Probe {
    enum class Sensor { none, ohmic, float_switch, offset_probe };
    Eigen::Vector2d at_mm = Eigen::Vector2d::Zero();  // where the surface was found (the torch, or the offset probe)
    Sensor sensor = Sensor::none;                      // the sensor that found the surface (none: skipped)
    bool skipped = false;
    double surface_mm = 0.0;     // the surface found (or kept), height frame
    double duration_s = 0.0;     // from the start of the torch-on to the surface found
  };

  void configure(const TorchSetup& t, double period_s) {
    t_ = base_ = t;
    dt_ = period_s;
    phase_ = Phase::idle;
    lit_ = false;
    surface_mm_ = 0.0;
    probed_ = probe_ready_ = offset_step_ = offset_ready_ = false;
    map_.clear();
  }

  // Where the torch stands for the next start_on(): the skip rule's distance and the probe's
  // record. Real time.
  void set_position(const Eigen::Vector2d& at_mm) noexcept { at_mm_ = at_mm; }

  // A torch_on step; `programmed_pierce` when a dwell step follows it. `preheated`: an
  // oxy-fuel torch whose preheat flame kept burning (a re-pierce after a hold) goes straight
  // to the cutting oxygen. `moving_delay_s` >= 0: a ramp pierce of that delay when the
  // material has one (plasma with a height axis): motion_allowed() from its motion delay on.
  void start_on(bool programmed_pierce, hardware::Outputs& out, bool preheated = false, double moving_delay_s = -1.0) noexcept;
  // A probe step: the offset probe finds the surface under it (see the file comment).
  void start_probe(hardware::Outputs& out) noexcept;
  // A probe step ran or runs whose surface the next start_on() pierces over.
  bool probing_for_pierce() const noexcept { return offset_step_ || offset_ready_; }
  // A ramp pierce may move along the cut now: the arc is on and the material's motion delay
  // has passed; the sequence goes on (the descent to the pierce end height, cut height) while
  // the axes move. tick() it until done.
  bool motion_allowed() const noexcept { return moving_ && motion_ok_; }
  // The material's ramp pierce (null: none).
  const motion::CutParameters* ramp() const noexcept { return ramp_; }
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
    ramp_ = m && m->ramp_pierce ? m : nullptr;
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
  double pierce_height_mm() const noexcept { return t_.pierce_height_mm; }
  // The surface the heights are measured from, height frame (0: not probed).
  double surface_mm() const noexcept { return surface_mm_; }
  // The probes of this run as a surface (the estimates of skipped probes are not in it).
  const SurfaceMap& probe_map() const noexcept { return map_; }
  // A probe finished (or was skipped) since the last call: copies it to `p` once.
  bool take_probe(Probe& p) noexcept {
    if (!probe_ready_) return false;
    probe_ready_ = false;
    p = probe_;
    return true;
  }
  // Torch off and retract now (faults, stops); the sequence in progress is abandoned.
  void kill(hardware::Outputs& out) noexcept;

  Tick tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept;

  bool busy() const noexcept { return phase_ != Phase::idle; }
  // A torch-on sequence is under way (not the retract).
  bool lighting() const noexcept { return busy() && phase_ != Phase::off_retract && !offset_step_; }
  // The torch-on sequence completed and the torch has not been turned off since.
  bool lit() const noexcept { return lit_; }
  Failure failure() const noexcept { return failure_; }
  double failure_value() const noexcept { return failure_value_; }

 private:
  enum class Phase {
    idle, probe_deploy, probe_fast, probe_back, probe_slow, probe_stow, height_pierce, preheat, wait_arc, pierce, puddle_jump, puddle_wait, pierce_end,
    height_cut, pause_end, off_retract
  };
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
  // A probe's failure: ohmic sensing off with it.
  Tick fail_probe(Failure f, double v, hardware::Outputs& out) noexcept {
    out.ohmic_enable = out.offset_probe = false;
    offset_step_ = false;
    return fail(f, v);
  }
  // At height `h` over the surface.
  bool at(const hardware::Inputs& in, double h) const noexcept {
    return std::abs(in.torch_height_mm - (surface_mm_ + h)) <= t_.height_tolerance_mm;
  }
  void aim(hardware::Outputs& out, double h) const noexcept { out.torch_height_target_mm = surface_mm_ + h; }
  // The start of a torch-on once the torch is at pierce height (or without a height axis).
  void light(hardware::Outputs& out) noexcept;
  // A probe under the torch (a torch on) or under the offset probe (`offset_step`).
  void begin_probe(hardware::Outputs& out, bool offset_step) noexcept;
  // Debounced sensors this period; true when one has read closed debounce_periods in a row.
  bool sensed(const hardware::Inputs& in) noexcept;
  Tick probe_tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept;
  Tick pierce_tick(const hardware::Inputs& in, hardware::Outputs& out) noexcept;
  void found(double surface_mm, Probe::Sensor s, hardware::Outputs& out) noexcept;

  TorchSetup t_, base_;  // the cuts' settings now, and the machine's
  double puddle_mm_ = 0.0, puddle_s_ = 0.0, pause_end_s_ = 0.0;  // the material's (0: none)
  double dt_ = 0.001;
  Phase phase_ = Phase::idle;
  double pt_ = 0.0;  // time in the phase
  bool programmed_ = false, lit_ = false, preheated_ = false;
  const motion::CutParameters* ramp_ = nullptr;  // the material's ramp pierce
  bool moving_ = false, motion_ok_ = false;      // this pierce is a ramp; the axes may move
  double retract_mm_ = 0.0;  // the height of the retract in progress
  Failure failure_ = Failure::none;
  double failure_value_ = 0.0;
  // Probing.
  Eigen::Vector2d at_mm_ = Eigen::Vector2d::Zero();
  double surface_mm_ = 0.0;              // the surface the heights are over
  bool probed_ = false;                  // a probe found a surface in this run
  Eigen::Vector2d probed_at_mm_ = Eigen::Vector2d::Zero();
  Probe probe_;                          // the one under way or last finished
  bool probe_ready_ = false;
  bool offset_step_ = false;             // the probe under way is a probe step's
  bool offset_ready_ = false;            // a probe step found the surface the next pierce takes
  double probe_t_ = 0.0;                 // since the probe began
  double probe_target_mm_ = 0.0;         // the slow probe's moving target
  double expected_mm_ = 0.0;             // the surface expected under the probe
  SurfaceMap map_{200.0};  // probes lie tens of mm apart: a wide reach
  int ohmic_run_ = 0, float_run_ = 0;    // consecutive closed reads
  double ohmic_z_ = 0.0, float_z_ = 0.0; // the height at the first read of each run
};

}  // namespace machplan::executor
