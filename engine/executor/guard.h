// The hybrid guard: a DemandFilter that keeps the tool centre out of a prohibited region while
// an operator drives the table (the hybrid manual / servo-assisted machine of Franco Garcia and
// Horikawa, "Manual and Servo Assisted, Hybrid System for Position Control in Machine Tools").
//
// The operator's source (jog_source.h) says where the operator wants to go: its velocity is
// the intent v_in. The guard owns the setpoint that reaches the controller: per tick it picks
// an allowed velocity v, slews its own velocity toward it within the machine's acceleration A,
// and integrates its setpoint g += v T. Away from the region v = v_in and g follows the source
// exactly; near it the guard slows and removes the part of v_in that points into the region,
// so the table slides along the boundary (tangential part passes, normal part removed).
//
// The link. The guard stands for the program on the PC of the paper's prototype, which learns
// the table's position by asking the motion controller over a serial line. `latency_s` (L) is
// the round trip from the controller sampling the position to the controller acting on the
// command the PC computed from it (ask, answer, compare, send). The guard sees the measured
// position of L ago; its command acts at once (equivalent for the loop: only the sum of the
// delays matters). It asks again as soon as an answer arrives, so one position arrives every L.
//
// Strategies (GuardStrategy):
//   paper       the paper's: on each answer, compare its distance d to the region's boundary
//               with the tolerance T; when d <= T and the operator pushes toward the region,
//               send a stop (the axes decelerate at A and are held). The stop is released when
//               an answer finds the operator's direction no longer pointing into the region.
//               Between answers the table runs blind, so it stops up to v L (1 + 1) + v^2 / 2A
//               beyond the point where the check fired: the paper's invasions.
//   predictive  ours: does not wait for the position. It knows the commands it sends, so it
//               judges the commanded point g (where the controller takes the table, and where
//               the table comes to rest), not a position L old, and limits every tick the
//               speed toward the region to what can still stop at A_b = braking_fraction x A
//               before the boundary plus a standoff s = min(standoff_mm, T / 2) (the clearance
//               h = d - s must cover one period at that speed and the braking distance:
//               v T + v^2 / 2 A_b <= h); the tangential part passes. A second query where
//               braking would end catches the next feature (the other side of a pocket's
//               corner) before the table slides into it. The answers, each paired with the
//               setpoint of its time (plant_lag_ ticks before it was read), check that the
//               table follows: one off by more than tracking_limit_mm (a jam, a slipped drive)
//               holds the axes. The standoff covers what the table may still overshoot g.
//
// Fail safe: a measured position that is not finite, an answer older than L plus one answer
// period (a lost or late link; see drop_answers()) or a non-finite intent makes the guard stop
// the axes (decelerate at A and hold) until fresh, finite answers arrive. Timing cannot bypass
// it: the guard's decision happens in the tick that outputs the setpoint.
//
// Real time: filter() allocates nothing, takes no lock, does no I/O and never throws; at most
// ten region queries (O(log n) each) per tick. The buffers are sized in the constructor.
// Measured (bench/guard_bench.cpp, bench/results/guard.txt): about 0.03 us per tick for the
// paper strategy and 0.5-0.6 us for the predictive one, against the executor's 50 us budget.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/names.h"
#include "engine/executor/machine_setup.h"
#include "engine/executor/setpoint_source.h"
#include "engine/geometry/region.h"

namespace machplan::executor {

enum class GuardStrategy { paper, predictive };
const char* to_string(GuardStrategy s);
// "paper" | "predictive"; InputError::field("strategy", ...) listing them otherwise.
Parsed<GuardStrategy> parse_guard_strategy(std::string_view text);

// The round trip that reproduces the paper's Tables 2 and 3 with the paper strategy on our
// simulated XY table best (bench/guard_paper.sh; bench/results/guard_paper.md): 0.15 s, a plausible
// figure for MATLAB polling an NSK controller over RS-232C.
inline constexpr double kPaperLatencyS = 0.15;

struct GuardOptions {
  GuardStrategy strategy = GuardStrategy::predictive;
  double tolerance_mm = 1.0;          // T: the band outside the boundary where the guard stops the tool
  double latency_s = kPaperLatencyS;  // L, see the file comment; [0, 1] s
  double standoff_mm = 0.08;          // predictive: aim this far outside the boundary (at most T / 2); covers the
                                      // table's overshoot of the setpoint when it brakes (up to 0.06 mm measured on xy_table)
  double braking_fraction = 0.5;      // predictive: plan braking at this share of A, (0, 1]; 1/2 lets two perpendicular limits brake at once
  double acceleration_mm_per_s2 = 0;  // A; 0: the machine's
  double tracking_limit_mm = 1.0;     // predictive: an answer this far from the setpoint of its time holds the axes
  void validate() const;              // throws InputError naming the field
};

// What the guard did, for reports (read between ticks, on the executor's thread).
struct GuardCounters {
  long ticks = 0;
  long answers = 0;          // positions received over the link
  long stops_sent = 0;       // paper: stop commands; predictive: ticks that entered a hold
  long limited_ticks = 0;    // ticks in which the guard changed the operator's velocity
  long failsafe_ticks = 0;   // ticks held because the link was late or a value not finite
  long emergency_ticks = 0;  // predictive: ticks whose step was shortened beyond the ramp (see filter())
};

class Guard final : public DemandFilter {
 public:
  // `region` must outlive the guard. Throws InputError when the options do not validate.
  Guard(const ProhibitedRegion& region, const GuardOptions& options, const MachineSetup& machine, double period_s);

  void reset(const Eigen::Vector2d& start_mm) override;
  void filter(Demand& d, const Eigen::Vector2d& measured_mm, const Eigen::Vector2d& velocity_mm_per_s) noexcept override;

  // Test hook: from now on answers are lost (true) or arrive again (false); a lost link must
  // stop the axes.
  void drop_answers(bool drop) noexcept { drop_ = drop; }

  // True while the guard holds the axes against the operator (a stop sent, a fail-safe hold,
  // or a predictive limit that brought the table to rest).
  bool holding() const noexcept { return holding_; }
  const GuardCounters& counters() const noexcept { return counters_; }
  const GuardOptions& options() const noexcept { return o_; }
  Eigen::Vector2d setpoint_mm() const noexcept { return g_; }
  Eigen::Vector2d setpoint_velocity_mm_per_s() const noexcept { return v_; }
  // The standoff the predictive strategy aims at, mm.
  double standoff_mm() const noexcept { return s_; }

 private:
  Eigen::Vector2d predictive_velocity(const Eigen::Vector2d& p, const Eigen::Vector2d& v_in) const noexcept;
  double braking_speed(double clearance_mm) const noexcept;

  const ProhibitedRegion& region_;
  GuardOptions o_;
  double dt_ = 0.001, A_ = 0.0, Ab_ = 0.0, s_ = 0.0;
  int lag_ticks_ = 0;    // L in ticks
  int read_latency_ = 0; // the controller's reading latency (the setpoint lags by it, like the jog source's)
  int plant_lag_ = 1;    // ticks from a setpoint to the position read back for it
  std::size_t ring_ = 1;
  std::vector<Eigen::Vector2d> measured_, setpoint_;  // per tick, ring of `ring_`
  std::vector<char> measured_ok_;
  long tick_ = 0, next_answer_ = 0, last_answer_tick_ = 0;
  bool have_answer_ = false, drop_ = false, holding_ = false, stop_latched_ = false, tracking_lost_ = false;
  Eigen::Vector2d answer_mm_{0, 0}, answer_g_mm_{0, 0};  // last answer and our setpoint at its sampling
  Eigen::Vector2d g_{0, 0}, v_{0, 0}, a_{0, 0};
  GuardCounters counters_;
};

}  // namespace machplan::executor
