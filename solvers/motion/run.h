// Running a part program on a cutting machine, start to end: the pipeline behind `machplan
// run`, also used by the web panel, the tests and the bench so that all of them run the same
// thing. Two halves, so that a job can be planned once and run when the operator says:
//
//   plan_program (or plan_job):
//     program (.ngc) --read_gcode_file--> Program --order_cuts (RunOptions::order)--> Program
//       --make_job--> Job (QtPlasmaC's words: materials, THC switches, velocity, hole rules,
//                      pierce only: engine/motion/plasma_words.h; F#<_hal[plasmac.cut-feed-rate]>
//                      is the material's CUT_SPEED, else the machine file's value of it)
//       --apply_kerf (when kerf_mm > 0, or by materials)--> closed cuts moved by half the kerf
//       --plan_rapids--> rapids routed round the declared no-go zones and the parts cut so far
//       --plan_stretch, one per move step--> Trajectories (planned mode)   = PlannedRun
//   execute: the PlannedRun on a machine session (solvers/session/machine_session.h: the
//     machine, the named backend, the controller, the calibration) --> RunOutcome (cycle
//     time, contour error per cut, faults, trace, and its Summary)
//
// run_program and run_job do both on a session of their own.
//
// Beside the run it computes what the run should be measured against:
//
//   * motion_lower_bound_s: the sum over move steps of time_lower_bound_s() on the path the
//     planner actually follows (PlannedTrajectory::executed_path(): the programmed path with
//     corners rounded within the planner's path tolerance), under the machine's speed and
//     acceleration limits. No motion along those paths within those limits can be faster.
//   * process_time_s: what the torch sequence takes on this machine whatever the motion does:
//     per torch_on, the initial height sense, the height axis down to pierce height (less the
//     executor's arrival tolerance) at its speed, the arc start delay (plasma) or preheat
//     (oxy-fuel), the pierce delay (the programmed G4 when one follows, else the machine's)
//     and the move down to cut height; per torch_off the retract; every other dwell. The
//     executor keeps the axes at rest during all of these, as the torch must not move while
//     piercing or before it is retracted.
//   * lower_bound_s = motion_lower_bound_s + process_time_s, and cycle_ratio =
//     cycle_time_s / lower_bound_s (>= 1; the issue asks for <= 1.10 in planned mode).
//   * motion_ratio: the planned trajectories' total duration over motion_lower_bound_s, the
//     planner's share of the gap.
//   * motion_optimum_s: the sum over move steps of time_optimal_s() (engine/motion/
//     time_optimal.h) on the same executed paths: the least time any motion along them takes
//     within the machine's per-axis speed and acceleration limits (jerk free). It is >= the
//     bound (which ignores what turning costs), and optimum_ratio = planned_motion_s /
//     motion_optimum_s is what the planner loses, the jerk limit included.
//
// Placing the program: the program's coordinates (machine coordinates of its own work offsets)
// are moved by RunOptions::origin_mm (or the machine file's origin_mm), so that the travel
// check, the rapid planning, the plots and the reports all work in the machine's coordinates.
// Z: on these 2-axis machines Z words are dropped with one warning naming the first line that
// moves Z (the torch height belongs to the machine), unless strict_z keeps them as an error.
//
// Errors: a bad program, machine file, zones file or option throws InputError naming the file
// and line or the field (exit 2 in the CLI, which names the flag). Anything else is a status,
// never an exception: a job the machine cannot do is planned with its summary infeasible (the
// program leaves the machine's travel, a cut enters a declared no-go zone, a rapid with no
// clear route would enter one, or the run's estimate exceeds max_machine_time_s), and a stop
// request, deadline or budget of the RunControl's Termination during rapid or feed planning
// ends the planning with that status. The caller checks PlannedRun::summary; execute() runs
// nothing for a plan that is not done and returns its summary. Once the executor runs, a
// fault, a stop request or the deadline (max_machine_time_s of machine time, for a job held
// longer than its estimate) stops the machine and is the run's Summary.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/executor/executor.h"
#include "engine/motion/feed_planner.h"
#include "engine/motion/frame.h"
#include "engine/motion/job.h"
#include "engine/motion/kerf.h"
#include "engine/motion/time_optimal.h"
#include "engine/programs/gcode.h"
#include "engine/programs/zones.h"
#include "models/cutting/machine_config.h"
#include "solvers/motion/cut_order.h"
#include "solvers/motion/from_line.h"
#include "solvers/motion/offset_probe.h"
#include "solvers/motion/cut_order.h"
#include "solvers/motion/rapid_planner.h"
#include "solvers/motion/rapids.h"
#include "solvers/session/machine_session.h"

namespace machplan::motion {

struct RunOptions {
  // The machine, its backend, controller, calibration, executor options and trace
  // (solvers/session/machine_session.h).
  session::MachineSessionOptions session;
  // Kerf width, mm; 0 leaves the program as written. At most 100 mm.
  double kerf_mm = 0.0;
  // Each closed cut by its material's kerf (a QtPlasmaC material's KERF_WIDTH) where it has
  // one; cuts without one use kerf_mm (KerfOptions::kerf_from_materials).
  bool kerf_from_materials = false;
  // YAML file of declared no-go zones (engine/programs/zones.h); empty for none.
  std::string no_go_path;
  // Also keep rapids away from every closed contour cut before them (parts that may tip up).
  bool zones_from_cuts = true;
  // Rapid planning. Its bounds are replaced by the machine's travel.
  RapidOptions rapids;
  // When > 0, every feed (non-rapid) move runs at this speed, mm/s, instead of its programmed
  // F: the paper ran its shapes at 4 mm/s, our bundled programs are written for 80 mm/s.
  double feed_override_mm_per_s = 0.0;
  // Paper modes measure as the paper did: one counted edge per encoder line (0.0995 mm per
  // count on the gantry) instead of the machine file's decoding.
  bool paper_x1_decoding = true;
  // Paper modes run the rapids at the cutting feed (the slowest feed of the job's cuts), as
  // the paper's controller ran a whole path file at one feed rate. Its vector scheme has no
  // way to stop on a point: at rapid speed, open-loop time control and the closed loop's
  // computation time (ExecutorOptions::paper_compute_s) would land the torch far from the
  // pierce point, and every cut would start with that error.
  bool paper_rapids_at_feed = true;

  // How the program is read: parameter values, spindles, require_program_end. The machine
  // file's gcode: params are added (a given value of the same name wins) and its spindles
  // raise spindle_count.
  GcodeOptions gcode;
  // Where the program's zero sits on the machine, mm; unset: the machine file's origin_mm,
  // else (0, 0).
  std::optional<Eigen::Vector2d> origin_mm;
  // Sheet alignment: two points on the sheet's edge, machine coordinates, mm. The first is the
  // program's zero (in place of origin_mm), the edge from it to the second is the program's X
  // axis: the program runs rotated by that edge's angle (counter-clockwise positive) about its
  // zero, checked against the travel like any job. Arcs in the XZ or YZ plane cannot rotate.
  std::optional<std::pair<Eigen::Vector2d, Eigen::Vector2d>> align_mm;
  static constexpr double kMinAlignEdgeMm = 20.0;  // the points' least distance apart
  // Refuse a program whose Z moves (true) instead of dropping its Z words with a warning.
  bool strict_z = false;
  // QtPlasmaC material file (engine/motion/materials.h, in mm) the program's M190 words select
  // from; empty for none. Material comments "(o=...)" in the program need no file.
  std::string materials_path;
  // The material in force when the program selects none: a number in materials_path's file;
  // -1: the machine's own torch settings.
  int default_material = -1;
  // The order of the cuts (solvers/motion/cut_order.h), applied to the program once its Z
  // words are dropped; unset: the machine file's cut_order, else the program's own order.
  std::optional<CutOrder> order;
  // Run from line (solvers/motion/from_line.h): start at this program line, with the state the
  // program had there, reached by a safe rapid (0: from the start).
  int from_line = 0;
  // The longest run accepted, s of machine time (> 0, at most one year). A run is refused
  // before it starts (infeasible, the message giving the estimate) when its time estimate
  // exceeds this: first the time no motion can beat (each move at its feed capped by the
  // machine's speed, plus the torch process and dwells), checked before rapid and feed
  // planning, then the planned motion plus process time, checked before the executor starts.
  // It is also the run's deadline in machine time: a run that lasts longer (held, waiting on
  // an input that never comes) is stopped with the torch off and ends with status deadline. A
  // simulation runs faster than the machine, but it still takes wall time in proportion: an
  // absurd feed (1e-6 mm/s), a machine with a tiny speed or acceleration or a helix of
  // enormous length would otherwise simulate for days.
  double max_machine_time_s = 4 * 3600.0;

  // Throws InputError::field naming the offending field ("kerf_mm", "executor.blu_mm", ...).
  void validate() const;
};

// Who watches and stops a run; each may be null.
struct RunControl {
  Termination* termination = nullptr;  // stop request; its deadline and budget cap the run too
  Progress* planning = nullptr;        // rapid planning (the slow part of planning)
  Progress* running = nullptr;         // the run itself, by its expected machine time
};

// A job planned for a machine, ready to run: what the run will do and what it is measured
// against.
struct PlannedRun {
  cutting::MachineConfig machine;
  PlannerOptions planner;
  Job programmed;                    // after make_job (before kerf and rapid planning)
  Job job;                           // what runs: after kerf and rapid planning
  std::optional<KerfReport> kerf;    // when kerf_mm > 0 or kerf_from_materials
  RapidsReport rapids;
  std::vector<NoGoZone> declared_zones;
  std::vector<Contour> cut_zones;    // the closed cuts, as plan_rapids saw them
  executor::Trajectories trajectories;  // one per step (null for non-moves)
  Eigen::Vector2d origin_mm = Eigen::Vector2d::Zero();  // where the program's zero sat
  std::string origin_from = "none";                     // "given" (RunOptions), "machine file", "sheet alignment" or "none"
  double rotation_deg = 0.0;                            // the sheet alignment's rotation (0: none)
  std::vector<std::string> warnings;                    // from reading and placing the program
  std::vector<std::string> notes;                       // program words the machine ignores (M8, M52, ...)
  CutOrderReport cut_order;                             // the order the cuts were made in
  std::optional<LineStart> from_line;                   // when the run starts at a program line
  std::size_t offset_probes = 0;     // probe steps the offset probe adds (solvers/motion/offset_probe.h)
  bool paper_x1_decoding = false;    // the encoders are counted x1 (paper modes)

  double planned_motion_s = 0.0;     // sum of trajectory durations
  double motion_lower_bound_s = 0.0;
  double motion_optimum_s = 0.0;
  double optimum_ratio = 0.0;        // planned_motion_s / motion_optimum_s
  double process_time_s = 0.0;
  double lower_bound_s = 0.0;
  double motion_ratio = 0.0;
  // The run's expected machine time: the planned motion plus the torch process and dwells.
  double expected_s() const { return planned_motion_s + process_time_s; }

  // Planned: done. Refused: infeasible, or what ended the planning (cancelled, deadline,
  // budget), with the reason as message and reports (see the file comment). For a RunOutcome,
  // how the run ended (done, faulted, cancelled, deadline), with the brief and the full
  // report for people: run summary, per-cut errors, faults, bound and ratio.
  Summary summary;
  // The RunOptions field whose limit refused the plan ("max_machine_time_s"), so that a
  // caller can name its own setting of it; empty otherwise.
  std::string limit_field;
};

// What a run did, beside what it planned.
struct RunOutcome : PlannedRun {
  executor::ExecutionResult result;
  std::string controller;            // the servo controller's kind
  double cycle_ratio = 0.0;
  // Over all cuts, weighted by samples: the RMS of the measured contour error, mm.
  double rms_contour_error_mm = 0.0;
  double rms_true_contour_error_mm = 0.0;  // NaN: the backend has no truth (result.truth_available)

  bool faulted() const { return !result.summary.done(); }
};

// The machine session a run of these options runs on: its machine loaded once (the paper
// modes count the encoders x1 when paper_x1_decoding is set), the feed override as the feed
// for a calibration's open-loop factor.
session::MachineSessionOptions session_options_for(const RunOptions& options);

// Reads a program for `machine`: the machine file's G-code parameters and spindles added to
// `gcode` (a given value of the same name wins); unless `strict_z`, Z words dropped from the
// first move that changes Z, with one warning added to `warnings` (the torch height, or the
// tool's, is the machine's on these 2-axis machines).
Program read_program_for(const std::string& program_path, GcodeOptions gcode, const cutting::MachineConfig& machine,
                         bool strict_z, std::vector<std::string>& warnings);

// Plans `program_path` for `machine` as described in the file comment.
PlannedRun plan_program(const std::string& program_path, const RunOptions& options, const cutting::MachineConfig& machine,
                        const RunControl& control = {});
// The same from a Job already made (make_job with the machine's rapid feed): for callers that
// build or trim jobs themselves, such as the paper reproduction in bench/.
PlannedRun plan_job(Job programmed, const RunOptions& options, const cutting::MachineConfig& machine,
                    const RunControl& control = {});
// The frame of a planned job (PlannedRun::job; engine/motion/frame.h: its outline traced with
// the torch off, from and back to its start), planned for `machine` like any job: the travel and the
// declared no-go zones of `options` apply; kerf, cut order and run-from-line are in the job's
// path already and are not applied again, nor is the feed override. Feeds of 0 in `frame` take
// the machine's rapid speed. Throws InputError as frame_job does.
struct FramePlan {
  PlannedRun plan;
  Eigen::AlignedBox2d outline;
  bool from_cuts = true;
  FrameOptions options;  // as used
};
FramePlan plan_frame(const Job& job, RunOptions options, FrameOptions frame, const cutting::MachineConfig& machine,
                     const RunControl& control = {});

// Runs a planned job on `session` (whose machine it was planned for); a plan whose summary is
// not done is not run (the outcome keeps its summary).
RunOutcome execute(session::MachineSession& session, PlannedRun plan, const RunOptions& options,
                   const RunControl& control = {});

// Plan and execute on a session of their own.
RunOutcome run_program(const std::string& program_path, const RunOptions& options, const RunControl& control = {});
RunOutcome run_job(Job programmed, const RunOptions& options, const RunControl& control = {});

// The process time of the file comment for `job` on `machine`, s: the torch sequence at the
// machine file's delays and speeds, and the dwells (engine/motion/process_time.h).
double process_time_s(const Job& job, const cutting::MachineConfig& machine, double height_tolerance_mm);

// The machine file's cut_order (program when it has none); InputError naming the file for a
// name that is not an order.
CutOrder cut_order_of(const cutting::MachineConfig& machine);

// The machine file's cut_order (program when it has none); InputError naming the file for a
// name that is not an order.
CutOrder cut_order_of(const cutting::MachineConfig& machine);

// The feed planner's limits for a machine: its limits block and servo period.
PlannerOptions planner_options_for(const cutting::MachineConfig& machine);

}  // namespace machplan::motion
