// `machplan run PROGRAM.ngc --machine NAME|FILE.yaml [...]`: runs a part program on the
// simulated cutting machine (solvers/motion/run.h) and reports cycle time, torch time,
// rapids, contour error per cut, faults and the cycle time against its lower bound.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/json/cut_order_json.h"
#include "cli/json/run.h"
#include "cli/output.h"
#include "cli/gcode_flags.h"
#include "cli/json/cut_order_json.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sheet_map.h"
#include "solvers/calibration/store.h"
#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/common/text_file.h"
#include "engine/hardware/operator_events.h"
#include "solvers/common/picture.h"
#include "solvers/motion/run.h"
#include "solvers/motion/run_plot.h"
#include "solvers/session/job_stats.h"
#include "solvers/session/tuning_store.h"

namespace machplan::cli {
namespace {

// run's modes: every executor mode but jog (the guard's).
executor::Mode mode_of(const std::string& text) {
  const executor::Mode m = accept(executor::parse_mode(text), "--mode");
  if (m == executor::Mode::jog)
    throw InputError("--mode", 0, "jog is the guard's mode (machplan guard); run takes planned, paper-open or paper-closed");
  return m;
}

// `KIND@SECONDS[:AXIS]`, e.g. jam@3.5:x; the kinds are the simulator's (models/sim).
sim::FaultInjection injection_of(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return InputError("--inject", 0, fmt::format("'{}': {} (form KIND@SECONDS[:x|y])", excerpt(text), why));
  };
  const std::size_t at = text.find('@');
  if (at == std::string::npos) throw bad("no '@'");
  const std::string kind = text.substr(0, at);
  std::string rest = text.substr(at + 1), axis;
  if (const std::size_t c = rest.find(':'); c != std::string::npos) {
    axis = rest.substr(c + 1);
    rest = rest.substr(0, c);
  }
  sim::FaultInjection f;
  try {
    f.kind = accept(sim::parse_fault_kind(kind), "--inject");
  } catch (const InputError& e) {
    throw bad(e.message());  // "unknown fault kind 'melt' (known: ...)"
  }
  const std::optional<double> at_s = parse_finite(rest);
  if (!at_s || *at_s < 0) throw bad("the time is not a number >= 0");
  f.at_s = *at_s;
  if (axis == "x" || axis.empty()) f.axis = 0;
  else if (axis == "y") f.axis = 1;
  else throw bad(fmt::format("unknown axis '{}'", excerpt(axis)));
  return f;
}

struct RunArgs {
  std::string program, machine, mode = "planned", blu, calibration, kerf, feed, no_go, trace, plot, magnify = "1", seed,
      backend = "sim", db;
  std::vector<std::string> inject;
  std::string controller;
  std::vector<std::string> gains;
  bool json = false, realtime = false, record = false;
  std::string origin;
  GcodeFlags gcode;
  bool strict_z = false;
  std::string order;
  double max_machine_time_s = motion::RunOptions{}.max_machine_time_s;
  std::string operator_events;
  std::string sheet_warp, sheet_map, align;
  int from_line = 0;
  std::string materials;
  int material = -1;
  bool frame = false, laser = false;
  double frame_feed_mm_per_s = 0.0, frame_margin_mm = 0.0;  // feed 0: the machine's rapid speed
};

// Which flag sets which field of RunOptions and of its machine session, for the error path
// (cli/field_flags.h).
const FieldFlag kRunFields[] = {
    {"machine", "--machine"},
    {"mode", "--mode"},
    {"kerf_mm", "--kerf"},
    {"feed_override_mm_per_s", "--feed"},
    {"paper_feed_mm_per_s", "--feed"},
    {"executor.blu_mm", "--blu"},
    {"executor.calibration_factor", "--calibration"},
    {"calibration", "--calibration"},
    {"active_calibration", "--calibration"},
    {"db_path", "--db"},
    {"origin_mm", "--origin"},
    {"align_mm", "--align"},
    {"controller", "--controller"},
    {"gains", "--gain"},
    {"backend.name", "--backend"},
    {"backend", "--backend"},
    {"backend.sim.faults", "--inject"},
    {"backend.sim.operator_events", "--operator-events"},
    {"backend.sim.sheet_warp_mm", "--sheet-warp"},
    {"backend.sim.sheet_map", "--sheet-map"},
    {"gcode.spindle_count", "--spindles"},
    {"max_machine_time_s", "--max-machine-time"},
    {"magnify", "--magnify"},
    {"plot", "--plot"},
    {"from_line", "--from-line"},
    {"default_material", "--material"},
};

motion::RunOptions run_options(const RunArgs& a) {
  motion::RunOptions o;
  session::MachineSessionOptions& so = o.session;
  so.machine = a.machine;
  so.executor.mode = mode_of(a.mode);
  // The rules between options (the paper modes' settings, what only the simulator does) are
  // the options' own validate(): the panel and a library caller meet them too.
  if (!a.blu.empty()) so.executor.blu_mm = number_flag("--blu", a.blu);
  if (a.calibration == "active") {
    // Paper modes: the open-loop factor for the feed; planned mode: the whole fit, applied to
    // the executor's setup (the machine session does both).
    so.active_calibration = true;
  } else if (!a.calibration.empty()) {
    so.executor.calibration_factor = number_flag("--calibration", a.calibration);
  }
  so.store_path = a.db;
  if (a.kerf == "material") o.kerf_from_materials = true;
  else if (!a.kerf.empty()) o.kerf_mm = number_flag("--kerf", a.kerf);
  o.materials_path = a.materials;
  o.default_material = a.material;
  if (!a.feed.empty()) {
    o.feed_override_mm_per_s = number_flag("--feed", a.feed);
    if (!(o.feed_override_mm_per_s > 0)) throw InputError("--feed", 0, fmt::format("{} must be > 0 mm/s", a.feed));
  }
  if (!a.seed.empty()) so.backend.sim.seed = seed_of(a.seed);
  so.backend.name = a.backend;
  so.backend.sim.realtime = a.realtime;
  for (const std::string& text : a.inject) so.backend.sim.faults.push_back(injection_of(text));
  if (!a.operator_events.empty()) so.backend.sim.operator_events = hardware::read_operator_events(a.operator_events).states;
  if (!a.sheet_warp.empty()) {
    const auto comma = a.sheet_warp.find(',');
    if (comma == std::string::npos)
      throw InputError("--sheet-warp", 0, fmt::format("'{}' is not AMPLITUDE_MM,WAVELENGTH_MM", a.sheet_warp));
    so.backend.sim.sheet_warp_mm = std::make_pair(number_flag("--sheet-warp", a.sheet_warp.substr(0, comma)),
                                                  number_flag("--sheet-warp", a.sheet_warp.substr(comma + 1)));
  }
  if (!a.sheet_map.empty()) so.backend.sim.sheet_map = std::make_shared<const sim::SheetMap>(sim::read_sheet_map(a.sheet_map));
  so.controller = a.controller.empty() || a.controller == "tuned"
                      ? a.controller
                      : accept(control::parse_controller_kind(a.controller), "--controller");
  for (const std::string& g : a.gains) control::parse_gain(g, so.gains);
  o.no_go_path = a.no_go;
  o.gcode = gcode_options(a.gcode);
  o.strict_z = a.strict_z;
  if (!a.order.empty()) {
    o.order = motion::cut_order_from(a.order);
    if (!o.order) throw InputError("--order", 0, fmt::format("'{}' is not an order (program, nearest, optimise)", a.order));
  }
  if (!a.origin.empty()) {
    const auto comma = a.origin.find(',');
    if (comma == std::string::npos) throw InputError("--origin", 0, fmt::format("'{}' is not X,Y (mm)", a.origin));
    o.origin_mm = Eigen::Vector2d(number_flag("--origin", a.origin.substr(0, comma)), number_flag("--origin", a.origin.substr(comma + 1)));
  }
  if (!a.align.empty()) {
    std::vector<double> v;
    std::size_t from = 0;
    for (;;) {
      const std::size_t comma = a.align.find(',', from);
      v.push_back(number_flag("--align", a.align.substr(from, comma == std::string::npos ? std::string::npos : comma - from)));
      if (comma == std::string::npos || v.size() > 4) break;
      from = comma + 1;
    }
    if (v.size() != 4) throw InputError("--align", 0, fmt::format("'{}' is not X1,Y1,X2,Y2 (mm)", a.align));
    o.align_mm = std::make_pair(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
  }
  so.executor.record_trace = !a.plot.empty();
  so.trace_csv_path = a.trace;  // streamed during the run
  o.max_machine_time_s = a.max_machine_time_s;
  o.from_line = a.from_line;
  return o;
}

// --frame: instead of the job, its outline traced with the torch off (solvers/motion/run.h,
// plan_frame); what it frames is told on stderr.
motion::PlannedRun frame_plan(const motion::PlannedRun& job, const motion::RunOptions& o, const RunArgs& a,
                              Termination& stop, Progress& planning, nlohmann::json& report) {
  motion::FrameOptions fo;
  fo.feed_mm_per_s = a.frame_feed_mm_per_s;
  fo.margin_mm = a.frame_margin_mm;
  if (a.laser) {
    if (!job.machine.laser_offset_mm)
      throw InputError("--laser", 0, fmt::format("machine '{}' has no laser pointer (a `laser: {{offset_mm: [x, y]}}` block)",
                                                 job.machine.name));
    fo.pointer_offset_mm = {(*job.machine.laser_offset_mm)[0], (*job.machine.laser_offset_mm)[1]};
    fo.laser = true;
  }
  motion::FramePlan frame = motion::plan_frame(job.job, o, fo, job.machine, {&stop, &planning, nullptr});
  const Eigen::AlignedBox2d& b = frame.outline;
  std::fprintf(stderr, "machplan run: framing %s: X %.3f .. %.3f, Y %.3f .. %.3f mm (%.1f x %.1f mm%s) at %.1f mm/s, torch off%s\n",
               a.program.c_str(), b.min().x(), b.max().x(), b.min().y(), b.max().y(), b.sizes().x(), b.sizes().y(),
               frame.from_cuts ? "" : "; the job cuts nothing: its feed moves", frame.options.feed_mm_per_s,
               a.laser ? ", traced by the laser pointer" : "");
  report = frame_json(frame);
  if (!frame.plan.summary.done()) throw Infeasible(frame.plan.summary.message, frame.plan.limit_field);
  return std::move(frame.plan);
}

void run_command(const RunArgs& a) {
  if (!a.frame && (a.frame_feed_mm_per_s > 0 || a.frame_margin_mm > 0 || a.laser))
    throw InputError(a.laser ? "--laser" : a.frame_feed_mm_per_s > 0 ? "--frame-feed" : "--frame-margin", 0, "is for --frame");
  if (a.frame && mode_of(a.mode) != executor::Mode::planned)
    throw InputError("--frame", 0, "frames in planned mode only (the paper modes run cuts, not a frame)");
  const double magnify = number_flag("--magnify", a.magnify);
  if (!(magnify > 0 && magnify <= 1e6)) throw InputError("--magnify", 0, fmt::format("{} must be > 0 and <= 1e6", a.magnify));
  if (!a.plot.empty() && !is_picture_path(a.plot))
    throw InputError("--plot", 0, fmt::format("'{}' must end in .png or .svg", a.plot));
  // Output files: never one of the inputs, and their folders must exist before the run.
  for (const auto& [flag, path] : {std::pair<const char*, const std::string&>{"--trace", a.trace}, {"--plot", a.plot}}) {
    if (path.empty()) continue;
    refuse_overwriting_input(flag, path, {a.program, a.no_go, a.machine, a.operator_events});
    check_output_folder(flag, path);
  }
  // --record: the run's figures join the machine's statistics (a framing run is no job). The
  // store is opened before the run, so that a bad --db stops nothing halfway.
  if (a.record && a.frame) throw InputError("--record", 0, "records jobs, not a --frame run");
  const std::string db = a.record ? (a.db.empty() ? store::default_store_path() : a.db) : "";
  std::optional<stats::StatsStore> recorder;
  if (a.record) recorder.emplace(db);
  // SIGINT, SIGTERM and SIGHUP stop the machine in a controlled way (exit 3), not the process.
  const StopOnSignals signals;
  Termination stop(StopOnSignals::stop_token());
  Progress planning, running;
  nlohmann::json frame;  // --frame: the outline traced
  const motion::RunOutcome run = [&] {
    const motion::RunOptions o = run_options(a);
    // Rapid planning can take seconds on a long job, and the run itself long: a bar for each
    // on a terminal, drawn by a thread of the watch (the real-time loop draws nothing).
    std::optional<ProgressWatch> watch(std::in_place, "planning rapids", !a.json, planning);
    session::MachineSession session(motion::session_options_for(o));
    motion::PlannedRun plan = motion::plan_program(a.program, o, session.machine(), {&stop, &planning, nullptr});
    // Refused before the run (outside the travel, too long, stopped while planning): exit 3.
    if (!plan.summary.done()) throw Infeasible(plan.summary.message, plan.limit_field);
    if (a.frame) plan = frame_plan(plan, o, a, stop, planning, frame);
    watch.emplace("running", !a.json, running);
    return motion::execute(session, std::move(plan), o, {&stop, nullptr, &running});
  }();
  if (!a.plot.empty()) motion::write_run_plot(a.plot, run, magnify);
  std::int64_t job_id = 0;
  if (recorder) job_id = recorder->record(stats::job_record(run.result, std::filesystem::absolute(a.program).string(), read_text_file(a.program)));

  if (a.json) {
    nlohmann::json j = to_json(run);
    j["cut_order"] = cut_order_json(run.cut_order);
    if (a.frame) j["frame"] = frame;
    if (!a.trace.empty()) j["trace"] = a.trace;
    if (!a.plot.empty()) j["plot"] = a.plot;
    if (job_id) j["recorded"] = {{"db", db}, {"job_id", job_id}};
    print_json(j);
  } else {
    std::printf("%s", run.summary.full_report().c_str());
    if (!a.trace.empty()) std::printf("trace: %s (%zu samples)\n", a.trace.c_str(), run.result.trace_streamed);
    if (!a.plot.empty()) std::printf("picture: %s\n", a.plot.c_str());
    if (job_id) std::printf("recorded as job %lld in %s\n", static_cast<long long>(job_id), db.c_str());
  }
  if (!run.summary.done()) {
    for (const auto& f : run.result.faults) std::fprintf(stderr, "machplan run: fault: %s\n", f.message.c_str());
    set_exit_code(run.summary.exit_code());
  }
}

void add_run(CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  auto* cmd = app.add_subcommand("run", "Run a part program on the simulated XY table or thermal-cutting gantry");
  cmd->add_option("program", a->program, "G-code part program (.ngc)")->required();
  cmd->add_option("--machine", a->machine, "thermal_gantry, xy_table, or a machine YAML file")->required();
  cmd->add_option("--mode", a->mode,
                  "planned (ours: feed planner + servo loop), paper-open (the paper's BLU vectors, open-loop time "
                  "control), paper-closed (vectors re-aimed from the encoders)");
  cmd->add_option("--blu", a->blu, "paper modes: vector length, mm (default 3)");
  cmd->add_option("--calibration", a->calibration,
                  "paper modes: commanded speed / programmed speed (default 1), or 'active': the factor for --feed from "
                  "the machine's active calibration (machplan calibrate apply); planned mode: 'active' starts the "
                  "feed-forward at the stored feed factor, compensates the stored backlash and decodes the encoders "
                  "with the stored scale");
  cmd->add_option("--db", a->db,
                  "calibration store for --calibration active and --controller tuned (default "
                  "$XDG_DATA_HOME/machplan/calibration.db)");
  cmd->add_option("--kerf", a->kerf,
                  "kerf width, mm: closed cuts are offset by half of it (default 0: as programmed); 'material': each "
                  "cut's material's KERF_WIDTH");
  cmd->add_option("--feed", a->feed, "run every feed move at this speed, mm/s, instead of its F (the paper: 4)");
  cmd->add_option("--materials", a->materials,
                  "QtPlasmaC material file ([MATERIAL_NUMBER_n] sections, mm) the program's M190 Pn select from");
  cmd->add_option("--material", a->material,
                  "the material number in force when the program selects none (default: the machine's torch settings)");
  cmd->add_option("--no-go", a->no_go, "YAML file of no-go zones (clamps) the rapids must avoid");
  cmd->add_option("--trace", a->trace, "write the servo-period trace as CSV");
  cmd->add_option("--plot", a->plot, "write a top view, programmed against executed path (.png or .svg)");
  cmd->add_option("--magnify", a->magnify, "draw the contour error this many times larger in the plot (default 1)");
  cmd->add_option("--seed", a->seed, "seed of the simulated machine's noise and faults (default 1)");
  cmd->add_option("--align", a->align,
                  "X1,Y1,X2,Y2: sheet alignment, two points on the sheet's edge (machine mm): the program's zero at the "
                  "first, its X axis along the edge to the second (the program turned by that angle; in place of --origin)");
  cmd->add_option("--origin", a->origin,
                  "X,Y: where the program's zero sits on the machine, mm (default: the machine file's origin_mm, "
                  "else 0,0)");
  cmd->add_option("--controller", a->controller,
                  "servo controller: p, pid, pid_ff (default), zpetc, ccc (cross-coupled contour), flc (fuzzy), or tuned "
                  "(the machine's active tuning from machplan tune --store, in --db)");
  cmd->add_option("--gain", a->gains, "a controller gain, NAME=VALUE (e.g. kp_per_s=120); may be repeated");
  cmd->add_flag("--strict-z", a->strict_z, "refuse a program whose Z moves instead of dropping its Z words");
  cmd->add_option("--order", a->order,
                  "cut order: program (as written; warns when an outline is cut before its holes), nearest, or "
                  "optimise (inner contours first, pierce points chosen, least travel); default: the machine file's "
                  "cut_order, else program");
  add_gcode_options(*cmd, a->gcode);
  cmd->add_flag("--json", a->json, "machine-readable output");
  cmd->add_flag("--realtime", a->realtime, "pace the simulation to the wall clock");
  cmd->add_flag("--record", a->record,
                "add the run to the machine's job statistics in --db (machplan consumables show), however it ended");
  cmd->add_option("--max-machine-time", a->max_machine_time_s,
                  "refuse, before it starts, a run whose estimate exceeds this many seconds of machine time "
                  "(default 14400: 4 h)")
      ->check(kFinitePositive);
  cmd->add_option("--from-line", a->from_line,
                  "run from this program line, with the state the program had there, reached by a safe rapid (the "
                  "torch is lit again where a cut resumes)");
  cmd->add_option("--sheet-warp", a->sheet_warp,
                  "simulator: the sheet warped AMPLITUDE_MM,WAVELENGTH_MM (a seeded sine in x and y; default: the machine "
                  "file's sheet block, else flat): what torch height control must follow");
  cmd->add_option("--sheet-map", a->sheet_map,
                  "simulator: the sheet's surface as a height map, a CSV grid 'x_mm,y_mm,z_mm' (bilinear between its "
                  "points; in place of --sheet-warp)");
  cmd->add_option("--operator-events", a->operator_events,
                  "simulator: the operator's inputs on a timeline, a CSV 't_s,event,value' (hold, start, stop, "
                  "feed_override, rapid_override, paused_motion, paused_motion_speed, thc, torch)");
  cmd->add_option("--backend", a->backend, "the machine behind the executor: sim (the simulated machine; default) or hal (a machine through "
                  "LinuxCNC's HAL, scripts/hal-sim for a simulated one: docs/hal.md)");
  cmd->add_option("--inject", a->inject,
                  "simulator: inject a fault, KIND@SECONDS[:x|y] (jam, encoder-glitch, counter-misread, estop, "
                  "lost-backend, arc-loss, arc-start-failure, watchdog, probe-miss, switch-stuck, breakaway, ohmic-miss); may be repeated");
  cmd->add_flag("--frame", a->frame,
                "trace the job's outline with the torch off instead of cutting it (the rectangle round its cuts, as "
                "they will run), from the job's start and back, so that the operator sees where it lies on the sheet");
  cmd->add_option("--frame-feed", a->frame_feed_mm_per_s, "--frame: speed along the outline, mm/s (default: the machine's rapid speed)")
      ->check(kFinitePositive);
  cmd->add_option("--frame-margin", a->frame_margin_mm, "--frame: grow the outline by this much on every side, mm (default 0)")
      ->check(CLI::Range(0.0, 1000.0));
  cmd->add_flag("--laser", a->laser,
                "--frame: trace the outline with the laser pointer (the machine file's laser block: its offset from the "
                "torch), the laser-on output on while the frame runs");
  field_flags(cmd, kRunFields);
  cmd->callback([a] { run_command(*a); });
}

const Registration reg_run(60, add_run);

}  // namespace
}  // namespace machplan::cli
