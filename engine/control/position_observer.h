// Model-based position observer of one axis: the position between encoder counts, from the
// counts and the speed commands the controller sent.
//
// Why: the decoded encoder position is only known to within one count q (the adapter returns
// the middle of the count, engine/control/counter_decoder.h), and a loop that acts on it
// drives the tool about a uniform +-q/2 band on every axis. Once feed-forward and a contour
// loop have removed the dynamic errors (a few um on a 20 mm circle), that band is most of what
// is left. The drive's model says how far the axis went between two reads, to much better
// than a count, so a prediction from the commands narrows the band; the counts keep the
// prediction honest.
//
// Model (the first-order drive of models/axis/plant.h as a controller may know it: gain g,
// velocity-loop time constant tau, Coulomb friction Fc as speed, D = command latency + reading
// latency periods), per period T, the reading of period k showing the motion that the command
// sent D periods before the previous one, u[k - 1 - D], drove:
//
//     w      = g u[k - 1 - D] + d                   speed the drive aims at, mm/s
//     w_f    = w - Fc sgn(v)   (0 while the axis sticks: v = 0 and |w| <= Fc)
//     v+     = w_f + (v - w_f) a,                   a = exp(-T / tau)
//     m-     = m + w_f T + (v - w_f) tau (1 - a)    the motor: the exact integral over the period
//     x-     = clamp(x, m- - b/2, m- + b/2)         the table, across a backlash gap b
//
// Correction by the reading y (the middle of its count), with e = y - x-:
//
//     x = clamp(x- + alpha e,  y - q/2,  y + q/2),   m = m- + (x - x-)   (the model's drift
//     d = d + beta e / T                                                   moves both)
//
// with |d| held within the drive's speed range, so that a model the machine has left behind
// (an axis stuck or stopped by hand) cannot wind the disturbance, and with it the prediction,
// up without bound.
//
// alpha = 1 - p^2, beta = (1 - p)^2 with p = exp(-w_o T): the critically damped alpha-beta
// gains for an observer bandwidth w_o (rad/s). d, a speed disturbance, takes up what the
// model lacks (a gain error, viscous friction, the slow part of the speed noise). The clamp
// keeps the estimate inside the count the encoder shows: whatever the model's errors (a stop
// the controller did not command, a wrong tau, backlash, a collision), it is never further
// from the truth than the reading is plus half a count. Before the axis has crossed its first
// edge the reading is the reference itself and the clamp is taken about it too.
//
// What it buys: open loop on the XY table's axis, the RMS error of the position falls from the
// reading's q / sqrt(12) to about half of that under the table's speed noise and friction
// (tests/control/position_observer_test.cpp); its largest error does not fall, since a model
// that is wrong at a reversal (a gap it does not know, friction it misjudges) is only held
// off by the clamp.
//
// predict() carries the estimate on over the commands in flight, to the instant the next
// command acts; the controllers (pid_controller.h, observed_input) act on that prediction
// against the setpoint of the same instant, a Smith predictor.
//
// w_o = 0 turns the observer off: update() returns y. With tau unknown (0), the drive is taken
// as immediate (a = 0).
//
// Real time: update() and command() are O(1), allocate nothing and never throw.
#pragma once

#include <array>

namespace machplan::control {

struct ObserverModel {
  double period_s = 1e-3;
  double gain = 1.0;              // g
  double tau_s = 0.0;             // 0: unknown (immediate drive)
  double quantum_mm = 0.0;        // q; 0: no clamp
  double coulomb_mm_per_s = 0.0;  // Fc
  double backlash_mm = 0.0;       // b: the gap between motor and table
  double speed_limit_mm_per_s = 0.0;  // the drive's range: bounds |d| (0: unbounded)
  int delay_ticks = 0;            // D = command latency + reading latency
  static constexpr int kMaxDelayTicks = 31;
  // Throws InputError naming the field.
  void validate() const;
};

class PositionObserver {
 public:
  // `bandwidth_per_s` = w_o (0: off). Throws InputError for a bad model or w_o.
  void configure(const ObserverModel& model, double bandwidth_per_s);
  void reset() noexcept;
  bool enabled() const noexcept { return on_; }
  // This period's reading; returns the estimate of the position at the reading's instant.
  double update(double y_mm) noexcept;
  // The speed command sent this period (after the controller's limit).
  void command(double u_mm_per_s) noexcept;
  double disturbance_mm_per_s() const noexcept { return d_; }
  // The position D periods after the reading's instant, when the command about to be sent
  // starts to act: the estimate carried on by the model over the D commands in flight (sent,
  // not yet seen in a reading). With the observer off, the estimate itself.
  double predict() const noexcept;

 private:
  struct State {
    double x, motor, v;  // table (what the encoder reads), motor, motor speed
  };
  // One period of the model under command u, with the current disturbance.
  void model_step(double u, State& s) const noexcept;
  ObserverModel m_;
  bool on_ = false, started_ = false;
  double a_ = 0.0, alpha_ = 1.0, beta_ = 0.0;
  double x_ = 0.0, motor_ = 0.0, v_ = 0.0, d_ = 0.0;
  std::array<double, ObserverModel::kMaxDelayTicks + 1> u_{};  // u_[head_] = latest command
  int head_ = 0;
};

}  // namespace machplan::control
