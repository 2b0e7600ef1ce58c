// Where the executor's setpoints come from: one small interface, one implementation per file.
//
//   planned_source.h     the feed planner's Trajectory of each move, sampled every period
//   blu_vector_source.h  the thermal-cutting paper's equal vectors of length BLU, open loop
//                        (time control) or closed loop (re-aimed from the encoders)
//   jog_source.h         an operator's joystick: direction and speed, within the machine's
//                        acceleration and jerk limits
//
// Per tick the executor calls, in this order: begin_move() when a move step starts (possibly
// several times in a tick when zero-time steps chain), advance() once, move_done() while a move
// runs, and demand() once, after which an optional filter (the hybrid guard) may change the
// demand before it reaches the controller. Between moves a source holds its last point.
//
// A Demand is either `track` (a setpoint for the position controller, with feed-forward) or
// `speed` (an open-loop speed command per axis that bypasses the controller, as the paper's
// time control does).
//
// Real-time contract: every member but prepare() is O(1), allocates nothing, takes no lock,
// does no I/O and never throws. prepare() runs before the first tick and may allocate and
// throw InputError naming the job's file and line.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "engine/control/controller.h"
#include "engine/executor/machine_setup.h"
#include "engine/hardware/backend.h"
#include "engine/motion/job.h"

namespace machplan::executor {

using Trajectories = std::vector<std::unique_ptr<motion::Trajectory>>;

struct Demand {
  enum class Kind { track, speed };
  Kind kind = Kind::track;
  control::ControllerInput track;                             // kind == track (y, y_dot filled by the executor)
  Eigen::Vector2d speed_mm_per_s = Eigen::Vector2d::Zero();   // kind == speed
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();     // the commanded point now (traces, reports)
};

// What a source may use, fixed for one run.
struct SourceContext {
  const motion::Job* job = nullptr;
  const Trajectories* trajectories = nullptr;  // planned source only
  const MachineSetup* machine = nullptr;
  double period_s = 0.001;
};

class SetpointSource {
 public:
  virtual ~SetpointSource() = default;
  virtual const char* name() const = 0;
  // True when the source runs the job's move steps (planned, BLU vectors); a jog source runs
  // no job.
  virtual bool runs_job() const { return true; }
  // Before the first tick; the machine stands at `start_mm`.
  virtual void prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) = 0;
  // Rough duration of the whole job under this source, s (sizes the trace); 0 if unknown.
  virtual double estimate_s() const { return 0.0; }
  // Move step `step` of the job starts now; the measured position is `measured_mm`.
  virtual void begin_move(std::size_t step, const Eigen::Vector2d& measured_mm) noexcept = 0;
  // One period passes.
  virtual void advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs& op) noexcept = 0;
  // The move begun last has reached its end (the source now holds it).
  virtual bool move_done() const noexcept = 0;
  // The move is still travelling along its path (false once it only waits for the end, e.g.
  // the paper modes' settle time): contour error and arc loss are judged only while it does.
  virtual bool travelling() const noexcept { return !move_done(); }
  // The demand for this period.
  virtual void demand(Demand& d) const noexcept = 0;
  // Program line of the piece being executed (0 when not known).
  virtual int source_line() const noexcept { return 0; }

  // Feed hold and overrides (engine/executor/time_scale.h): the rate the move should run at,
  // 0 (at rest on the path) .. 2 (200 %), reached within the machine's limits. A source that
  // cannot change its rate says so (supports_rate() false) and runs as planned.
  virtual bool supports_rate() const noexcept { return false; }
  virtual void set_rate(double target) noexcept { (void)target; }
  // The rate now (1 when the source cannot change it) and whether the move is at rest.
  virtual double rate() const noexcept { return 1.0; }
  // The time the motion left takes (the rest of the move under way and the moves after it)
  // at these rates, as the machine will run them: a rate above 1 only where its limits leave
  // room (time_scale.h), so at 150 % a job cut at the machine's top speed takes as long as at
  // 100 %. Out: the feed moves' time and the rapids', s. False: the source cannot say.
  virtual bool motion_left_s(double feed_rate, double rapid_rate, double& feed_s, double& rapid_s) const noexcept {
    (void)feed_rate, (void)rapid_rate, (void)feed_s, (void)rapid_s;
    return false;
  }
  // The commanded velocity and acceleration now (not the feed-forward's, which leads by the
  // latencies); zero when not known.
  virtual void motion_now(Eigen::Vector2d& v_mm_per_s, Eigen::Vector2d& a_mm_per_s2) const noexcept {
    v_mm_per_s.setZero();
    a_mm_per_s2.setZero();
  }
  // Distance from `p` to the path the move follows, mm (0 when not known): a hold's
  // deviation from the path.
  virtual double path_distance_mm(const Eigen::Vector2d& p) const noexcept {
    (void)p;
    return 0.0;
  }
  // Paused motion, while a move is held at rest (rate 0): the machine moves along the
  // program's path with the torch off, back (negative) or on, across the moves of the job
  // (rapids included; `within_cut`: only over the cut's own moves, as the automatic backing up
  // after a lost arc does), no further than the job's first or last move. Two ways to ask:
  // a distance (requests add up) and a speed, a fraction -1 .. 1 of the machine's paused-
  // motion speed that holds while it is not 0 (a joystick, a pair of buttons). A source
  // without it ignores both.
  virtual void pause_move(double delta_mm, bool within_cut) noexcept { (void)delta_mm, (void)within_cut; }
  virtual void pause_jog(double speed_fraction) noexcept { (void)speed_fraction; }
  // A paused motion is under way or asked for.
  virtual bool pause_moving() const noexcept { return false; }
  // How far along the path the paused motions moved since the last call, mm (signed).
  virtual double take_paused_mm() noexcept { return 0.0; }
  // Where the commanded point will be 1 .. n periods after this one's, if nothing changes
  // but what the rate is already doing (for a backend that plays them when a command comes
  // late: hardware::Outputs::ahead_mm). Returns how many it wrote; 0: no plan to offer.
  virtual int plan_ahead(std::array<double, hardware::kAxes>* mm, int n) const noexcept {
    (void)mm, (void)n;
    return 0;
  }
  // The step whose move the source is on: the one begin_move gave, or the one a paused motion
  // reached.
  virtual std::size_t move_step() const noexcept { return kNoStep; }
  static constexpr std::size_t kNoStep = static_cast<std::size_t>(-1);
};

// Sits between a source and the controller and may change the demand (the hybrid guard keeps
// the tool out of prohibited regions this way). Same real-time contract as a source.
class DemandFilter {
 public:
  virtual ~DemandFilter() = default;
  virtual void reset(const Eigen::Vector2d& start_mm) = 0;
  virtual void filter(Demand& d, const Eigen::Vector2d& measured_mm, const Eigen::Vector2d& velocity_mm_per_s) noexcept = 0;
};

}  // namespace machplan::executor
