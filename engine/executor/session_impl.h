// Inside the executor (not an API): the state of one run, Session::Impl, shared by the files
// that make up a run:
//
//   session.cpp    before the first tick (Session::Impl::prepare: checks, buffers) and after
//                  the last (Session::Impl::finish: the ExecutionResult)
//   executor.cpp   the tick: everything the real-time loop runs (rules in executor.h)
//   report.cpp     the result in words: fault messages, ExecutionResult::report()
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "engine/executor/executor.h"
#include "engine/executor/surface_map.h"

namespace machplan::executor {

struct Session::Impl {
  // `held`: the operator holds the job while no move runs (an interrupted torch-on step).
  enum class Phase { dispatch, move, torch, dwell, end_hold, jog, held, done };

  Impl(Executor& ex, const motion::Job& job, const Trajectories& trajs, hardware::Backend& be, const RunParts& parts)
      : ms(ex.setup_), opt(ex.options_), job(job), trajs(trajs), be(be), parts(parts),
        dt(be.period_s()), session_id(next_session_id()) {}
  static std::uint32_t next_session_id() noexcept;

  void prepare(double machine_period_s);
  bool tick() noexcept;
  ExecutionResult finish();
  // The message of fault `f` for people, composed after the run (report.cpp): what happened,
  // with the numbers the tick recorded, where in the program, and the last trusted position.
  std::string fault_message(const FaultReport& f) const;

  // --- the real-time part -------------------------------------------------------------------
  void sequence() noexcept;
  void begin_step() noexcept;
  void next_step() noexcept;
  void torch_off_and_retract(bool resume, double height_mm = 0.0) noexcept;
  void raise(FaultKind kind, int axis, double value) noexcept;
  static FaultKind torch_fault(TorchSequencer::Failure f) noexcept;
  void record_probes(bool was_firing) noexcept;
  bool moving_cut() const noexcept {
    return phase == Phase::move && !sup.stopping() && !cut_off && !dry && source->travelling() && step < job.steps.size() &&
           job.stretches[job.steps[step].stretch].cutting;
  }
  // The operator's buttons and overrides (feed hold, resume, stop).
  void operate() noexcept;
  void begin_hold(bool by_override) noexcept;
  void follow_hold() noexcept;
  void follow_paused_motion() noexcept;
  void enter_paused_step(std::size_t j) noexcept;
  void use_material(int index) noexcept;
  // Paused motion is for the torches (a held spindle cut has no re-pierce to resume with).
  bool pauses_along_path() const noexcept {
    return ms.torch.kind == TorchSetup::Kind::plasma || ms.torch.kind == TorchSetup::Kind::oxy_fuel;
  }
  // The arc went out in a cut: a fault, or (the machine's on_arc_loss: recover) a hold the
  // operator recovers from.
  void arc_lost() noexcept;
  // Torch height control in a cut, and its figures.
  void thc_tick() noexcept;
  void follow_surface(bool thc_allowed) noexcept;
  void start_torch(bool programmed, bool preheated, double moving_delay_s = -1.0) noexcept;
  void start_ramp() noexcept;
  void cut_torch_off() noexcept;
  void follow_ramp() noexcept;
  double ramp_rate() const noexcept;
  bool move_is_rapid() const noexcept {
    return step < job.steps.size() && job.steps[step].kind == motion::Step::Kind::move && job.stretches[job.steps[step].stretch].rapid;
  }
  double move_rate() const noexcept { return held ? 0.0 : move_is_rapid() ? rapid_rate : feed_rate * ramp_rate(); }
  void record_trace() noexcept;
  void publish_live() noexcept;

  // --- inputs -------------------------------------------------------------------------------
  const MachineSetup& ms;
  const ExecutorOptions& opt;
  const motion::Job& job;
  const Trajectories& trajs;
  hardware::Backend& be;
  RunParts parts;
  double expected_s = 1.0;  // the job's expected machine time, for RunParts::progress
  const double dt;

  // --- parts --------------------------------------------------------------------------------
  std::optional<PlannedSource> planned;
  std::optional<BluVectorSource> blu;
  std::optional<JogSource> jogger;
  SetpointSource* source = nullptr;
  control::PidFfController pid_ff;
  control::Controller* controller = nullptr;
  FeedbackAdapter adapter;
  Supervisor sup;
  TorchSequencer torch;
  ContourMonitor contour;
  ThcController thc;
  TraceRecorder recorder;
  std::vector<TraceSample>* trace_out = nullptr;
  ExecutionResult result;

  // --- state --------------------------------------------------------------------------------
  hardware::Outputs out{};
  hardware::Inputs in{};
  Demand demand{};
  control::ControllerOutput cout{};
  long ticks = 0;
  double t = 0.0;
  std::size_t step = 0;
  Phase phase = Phase::dispatch;
  double phase_t = 0.0;
  bool resume_after_torch_off = false;
  Eigen::Vector2d sp_mm = Eigen::Vector2d::Zero();  // the commanded point now
  Eigen::Vector2d true_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  bool has_truth = false;
  Eigen::Vector2d u = Eigen::Vector2d::Zero();  // commanded speed, mm/s (nominal drive units)
  bool clipped = false;
  double torch_on_s = 0.0;
  int steps_completed = 0;
  double rapid_mm = 0.0;
  std::vector<double> stretch_len;
  bool over = false;
  // The operator: feed hold, resume, overrides, stop.
  const std::uint32_t session_id;  // LiveState::session
  hardware::OperatorInputs prev_op{};
  double feed_rate = 1.0, rapid_rate = 1.0;  // the overrides as rates of the plan
  bool held = false;              // a hold is in force
  bool held_by_override = false;  // ... because the feed override is 0 %
  bool resume_asked = false;
  bool cut_off = false;           // the hold turned the torch off in a cut: the resume re-pierces
  bool torch_off_running = false; // that torch-off sequence runs beside the braking
  bool repiercing = false;
  bool dry = false;               // the cut under way runs without the torch (the operator's torch switch)
  bool restart_step = false;      // the hold interrupted a torch-on step: it runs again on resume
  HoldReport* hold = nullptr;     // the hold being recorded (in result.holds)
  // Paused motion: the distance asked and not yet handed to the source, the motion being
  // recorded (in result.paused_motions), whether one was under way last period, and whether
  // the next is the automatic backing up after a lost arc.
  double paused_pending_mm = 0.0;
  PausedMotionReport* paused = nullptr;
  bool paused_moving = false, paused_by_arc_loss = false;
  std::size_t cut_begin = static_cast<std::size_t>(-1);  // the torch_on step of the cut under way
  // A ramp pierce: the move it starts (kNoRamp: none pending), its torch sequence running in
  // the move, its speed cap in force, and the distance moved since the motion began.
  static constexpr std::size_t kNoRamp = static_cast<std::size_t>(-1);
  std::size_t ramp_cut_step = kNoRamp;
  bool pierce_moving = false, ramp_on = false;
  double ramp_mm = 0.0;
  Eigen::Vector2d ramp_last_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d last_sp = Eigen::Vector2d::Zero();
  double progress_s = 0.0;        // the job's expected time done: path time in moves, else machine time
  bool be_realtime = true;
  int ahead_periods = 0;  // positions planned ahead the backend plays (Backend::plays_ahead_periods)
  // The plasma process: the material of the cut under way, THC, cut recovery.
  int material = -1;              // index into job.materials (-1: the machine's settings)
  bool thc_fitted = false;        // plasma, a height axis and THC enabled
  struct ThcAcc {
    std::size_t n = 0, active = 0, velocity_locked = 0, void_locked = 0;
    double max = 0.0, sum2 = 0.0, target_v = 0.0, velocity_change = 0.0, void_change = 0.0;
    int material = -1;
  };
  std::vector<ThcAcc> thc_acc;    // per stretch
  bool velocity_locked = false, void_locked = false;
  bool thc_acting = false;        // THC moved the height this period
  double velocity_lock_h = 0.0, void_lock_h = 0.0;  // the height when the lock began
  // Feed-forward from the surface map (follow_surface): the probes and the heights THC held,
  // dense along the cuts, so a narrower reach than the probes' own map.
  SurfaceMap surface{100.0};
  double surface_ff = 0.0, surface_base = 0.0;
  bool surface_following = false;
  Eigen::Vector2d surface_last_xy = Eigen::Vector2d::Constant(1e9);
  bool awaiting_pierce = false;   // a probe was recorded and its pierce has not fired yet
  int float_closed = 0;           // periods in a row the float switch read closed while the torch fired
  Eigen::Vector2d last_loss_mm = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
};

}  // namespace machplan::executor
