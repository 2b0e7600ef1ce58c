// Feed hold, resume and live overrides on a planned trajectory, by scaling its time.
//
// The planner (engine/motion/feed_planner.h) plans each move once, rest to rest, at the
// programmed feeds. The executor samples it at the path time tau; running tau at a rate
// k = dtau/dt instead of 1 keeps the tool exactly on the planned path (corner blends
// included: a hold never leaves the path) while changing how fast it goes along it:
//
//     p = p(tau)        v = p'(tau) k        a = p''(tau) k^2 + p'(tau) k'
//     j = p'''(tau) k^3 + 3 p''(tau) k k' + p'(tau) k''
//
// k = 1 is the plan as planned (bit for bit: the same samples), k = 0.5 a feed override of
// 50 %, k = 0 at rest on the path (a hold), k = 1.5 an override of 150 % where the machine
// allows it. The governor moves k toward its target each period with k'' bounded so that the
// axes' jerk stays within J and k' bounded so that their acceleration stays within A, from
// the plan's own p' and p'' at tau:
//
//     |p'_i k''| <= J_margin - |3 p''_i k k'|            (the jerk the change adds)
//     |p''_i k^2 + p'_i k'| <= A_i  for every axis i     (the acceleration with the change)
//
// and a jerk-limited approach to the target (the discrete time-optimal rule of LinuxCNC's
// limit3 component, applied to k): k' runs toward sign(e) sqrt(2 k''max |e|), e = target - k,
// so k arrives at its target with k' = 0.
//
// A hold (target 0) is planned in path speed instead, so that it is the shortest stop the
// limits allow: the tool's path speed u = |p'| k and tangential acceleration u' follow the
// time-optimal jerk-limited stop (jerk -J_t down to -A_t, hold, +J_t back to 0 as u reaches
// 0), with A_t and J_t the largest the axes give along the path direction (per axis, what the
// normal acceleration leaves, over the axis' share of the direction), recomputed each period;
// k = u / |p'(tau)|, never above its value (when the plan brakes harder by itself, the tool
// follows the plan).
//
// Above 100 %: the plan uses the whole acceleration A when it speeds up or slows down, so the
// time may only run faster while the plan cruises (p'' = 0): k is capped by the axes' speed
// limits (k <= V_i / |p'_i|) and by the time left in the cruise (the trajectory says it:
// Trajectory::cruise_left_s), from which k must still come back to 1 at the rates above
// before the plan's next speed change.
//
// Real time: step() is O(1), allocates nothing and never throws.
#pragma once

#include <Eigen/Core>

#include "engine/motion/job.h"

namespace machplan::executor {

struct TimeScaleLimits {
  Eigen::Vector2d max_velocity_mm_per_s = Eigen::Vector2d::Constant(80.0);
  Eigen::Vector2d max_acceleration_mm_per_s2 = Eigen::Vector2d::Constant(500.0);
  double max_jerk_mm_per_s3 = 20000.0;
  double period_s = 0.001;
  // Share of the limits a change of k may use on top of the plan (the rest is numerical
  // margin: the plan's own jerk p''' is not known to the governor), and of the axes' speeds
  // above 100 % (the drives need room to correct at their top speed).
  double margin = 0.95;
};

class TimeScale {
 public:
  void configure(const TimeScaleLimits& limits) noexcept { lim_ = limits; }
  // A new move begins (the plan at rest): k jumps to `k0` at no cost, k' = 0.
  void reset(double k0) noexcept {
    k_ = k0;
    kd_ = 0.0;
    stopping_ = false;
  }

  // One period of `plan` at path time `tau`, `target` the scale asked for (0 .. 2). Returns the
  // path time to advance.
  double step(double target, const motion::Trajectory& plan, double tau) noexcept;

  // The highest rate the axes allow at `at` (a sample of the plan at rate 1) while it cruises:
  // their speeds, and on an arc the normal acceleration, which grows with k^2 (at most 2).
  // Below 1 where the plan itself runs at the limits. Real time.
  double speed_ceiling(const motion::Setpoint& at) const noexcept;

  double k() const noexcept { return k_; }
  double k_dot() const noexcept { return kd_; }
  // The ceiling of k at the last step (1 outside a cruise).
  double ceiling() const noexcept { return ceiling_; }
  // The same state (the limits aside): from it, the same steps follow.
  bool same_state(const TimeScale& o) const noexcept {
    return k_ == o.k_ && kd_ == o.kd_ && ceiling_ == o.ceiling_ && stopping_ == o.stopping_ && u_ == o.u_ && ud_ == o.ud_;
  }

 private:
  double change_step(double target, const motion::Setpoint& at, double cruise_left_s) noexcept;
  double stop_step(const motion::Trajectory& plan, double tau, const motion::Setpoint& at) noexcept;
  TimeScaleLimits lim_;
  double k_ = 1.0, kd_ = 0.0, ceiling_ = 1.0;
  // The stop under way: the tool's path speed and tangential acceleration.
  bool stopping_ = false;
  double u_ = 0.0, ud_ = 0.0;
};

}  // namespace machplan::executor
