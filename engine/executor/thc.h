// Torch height control (THC) from the arc voltage, as QtPlasmaC's plasmac component does it.
//
// A plasma arc's voltage grows with its length: about volts_per_mm per millimetre of torch-to-
// plate distance (0.1 mm per volt). On a warped sheet the cut height set by the initial height
// sense at the pierce drifts as the torch moves; THC moves the height axis to hold the voltage,
// and so the distance, where the cut began.
//
// Where THC may not act, the executor moves the height by the sheet's surface map instead
// (engine/executor/surface_map.h; Session::Impl::follow_surface) and hands the change over with
// shift() when THC acts again.
//
// The law, per servo period T, while THC acts (armed, not locked, allowed):
//
//     e = V - V*                                   (V: the arc voltage, V*: the target)
//     dz/dt = 0                                    when |e| <= threshold_v
//     dz/dt = -clamp(k e, -z'max, z'max)           otherwise (k: speed_mm_per_s_per_v)
//     z = clamp(z + T dz/dt, -max_correction_mm, +max_correction_mm)
//
// and the height target is the cut height + z (a long arc, V high: down; a short one: up).
//
//   target      the material's cut volts, or the mean voltage over the first sample_s of the
//               cut, where the height sense has just set the height (on a warped sheet a
//               sample taken later would hold whatever height the warp had drifted to)
//   arming      the cut has run at (99 % of) its programmed feed for delay_s
//   holding     from the first period after arming with |e| <= threshold_v to the end of the
//               cut: the height THC holds (the figures of a cut are taken over these periods)
//   velocity    anti-dive: locked (z held) while the commanded speed is below
//               velocity_anti_dive_pct of the segment's feed: corners and small holes slow
//               the torch, the arc lengthens behind it and the voltage lies
//   void        anti-dive: locked when the voltage rises faster than void_anti_dive_v_per_s
//               (filtered over 10 ms), until it is back within threshold_v of where it was
//               before the rise, and 50 ms after: the arc over a kerf cut earlier or a hole
//               stretches into it, and following it would dive into the plate
//   allowed     the material's THC, the program's M62-M65 P2 (Stretch::thc_off) and the
//               operator's switch (OperatorInputs::thc_enabled)
//
// Real time: update() is O(1), allocates nothing and never throws.
#pragma once

namespace machplan::executor {

struct ThcSettings {
  bool enabled = true;          // the machine's THC (plasma with a height axis); false: fixed cut height
  double delay_s = 0.5;
  double sample_s = 0.1;
  double threshold_v = 1.0;
  double speed_mm_per_s_per_v = 10.0;
  double max_speed_mm_per_s = 20.0;
  double velocity_anti_dive_pct = 90.0;
  double void_anti_dive_v_per_s = 200.0;
  double max_correction_mm = 5.0;
  // Throws InputError::field naming the field, its value and the rule.
  void validate() const;
};

class ThcController {
 public:
  void configure(const ThcSettings& s, double period_s) noexcept {
    s_ = s;
    dt_ = period_s;
    reset(0.0);
  }
  // A new cut: disarmed, no correction; `target_v` the material's cut volts (0: sample it).
  void reset(double target_v) noexcept;

  struct Input {
    double voltage_v = 0.0;
    double speed_mm_per_s = 0.0;  // commanded path speed now
    double feed_mm_per_s = 0.0;   // the programmed feed of the segment
    bool allowed = true;          // material, program and operator all let THC act
  };
  // One period of a cut; returns the correction z to add to the cut height, mm.
  double update(const Input& in) noexcept;

  double correction_mm() const noexcept { return z_; }
  // Moves the correction by `dz` (clamped as the law clamps it): the executor's feed-forward
  // hands over the height it reached while THC could not act. Real time.
  void shift(double dz) noexcept;
  // The arc voltage filtered over about 10 ms.
  double filtered_v() const noexcept { return v_filtered_; }
  double target_v() const noexcept { return target_v_; }
  bool armed() const noexcept { return armed_; }
  bool holding() const noexcept { return holding_; }
  // Acting this period: armed, the target known, allowed and not locked.
  bool active() const noexcept { return active_; }
  bool velocity_locked() const noexcept { return velocity_lock_; }
  bool void_locked() const noexcept { return void_lock_s_ > 0.0; }

 private:
  ThcSettings s_;
  double dt_ = 0.001;
  double z_ = 0.0, target_v_ = 0.0, given_v_ = 0.0;
  double at_feed_s_ = 0.0, sampled_s_ = 0.0, sum_v_ = 0.0;
  double v_filtered_ = 0.0, dv_filtered_ = 0.0, void_lock_s_ = 0.0;
  double void_from_v_ = 0.0;  // the voltage before the rise that locked
  bool void_rising_ = false;  // the rise has not come back yet
  long samples_ = 0;
  bool armed_ = false, active_ = false, velocity_lock_ = false, primed_ = false, holding_ = false;
};

}  // namespace machplan::executor
