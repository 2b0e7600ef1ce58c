#include "solvers/motion/run.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <map>
#include <string>
#include <utility>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/motion/materials.h"
#include "engine/motion/plasma_words.h"
#include "engine/motion/process_time.h"
#include "engine/programs/gcode.h"

namespace machplan::motion {
namespace {

using executor::Mode;

void check_range(const char* field, double v, double lo, double hi, bool lo_open, const char* unit) {
  const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
  if (!ok)
    throw InputError::field(field, fmt::format("{} is out of range: must be {} {} and <= {}{}", v, lo_open ? ">" : ">=", lo,
                                               hi, unit));
}

// The machine's travel box, mm (axes run from 0 to their travel).
Eigen::AlignedBox2d travel_box(const cutting::MachineConfig& m) {
  return Eigen::AlignedBox2d(Eigen::Vector2d::Zero(), Eigen::Vector2d(m.axes[0].travel_mm, m.axes[1].travel_mm));
}

// Why the job cannot be run: a refusal of the planning (Summary infeasible or what ended the
// work), for the caller to check; the executor is never started for it.
void refuse(PlannedRun& o, Status status, std::string message, std::string limit_field = {}) {
  o.summary.status = status;
  o.summary.message = std::move(message);
  o.summary.brief = o.summary.message;
  o.summary.full = o.summary.message + "\n";
  o.limit_field = std::move(limit_field);
}

// The ends of the travel `b` crosses, each named with how far: "Y reaches -0.600 mm, 0.600 mm
// below its low end".
std::string ends_crossed(const Eigen::AlignedBox2d& b, const Eigen::AlignedBox2d& box, double tol) {
  std::string out;
  for (int a = 0; a < 2; ++a) {
    const auto add = [&](double reach, bool low) {
      out += fmt::format("{}{} reaches {:.3f} mm, {:.3f} mm {} its {} end", out.empty() ? "" : " and ", a == 0 ? 'X' : 'Y',
                         reach, low ? box.min()[a] - reach : reach - box.max()[a], low ? "below" : "beyond",
                         low ? "low" : "high");
    };
    if (b.min()[a] < box.min()[a] - tol) add(b.min()[a], true);
    if (b.max()[a] > box.max()[a] + tol) add(b.max()[a], false);
  }
  return out;
}

// A job outside the travel: names the ends `crossing` crosses, and where the program's zero
// would have to sit on the machine for the whole job to fit (setting `field` to the option that
// moves it: the origin, or under a sheet alignment the alignment points), or that no place fits a
// job larger than the travel.
std::string outside_travel(const std::string& where, const std::string& what, const Eigen::AlignedBox2d& crossing,
                           const Job& job, const Eigen::AlignedBox2d& box, const Eigen::Vector2d& origin, bool aligned,
                           const std::string& machine, double tol, std::string& field) {
  Eigen::AlignedBox2d all(job.start_mm, job.start_mm);
  for (const Stretch& s : job.stretches)
    for (const Segment& g : s.segments) all.extend(bounding_box(g));
  const std::string head = fmt::format("{}: {} outside the travel of machine '{}' (X {:g} .. {:g}, Y {:g} .. {:g} mm): {}. "
                                       "The job spans X {:.3f} .. {:.3f}, Y {:.3f} .. {:.3f} mm",
                                       where, what, machine, box.min().x(), box.max().x(), box.min().y(), box.max().y(),
                                       ends_crossed(crossing, box, tol), all.min().x(), all.max().x(), all.min().y(),
                                       all.max().y());
  const Eigen::Vector2d size = all.sizes(), travel = box.sizes();
  if (size.x() > travel.x() + tol || size.y() > travel.y() + tol)
    return fmt::format("{}, {:.3f} x {:.3f} mm: larger than the travel, so no program origin fits it", head, size.x(),
                       size.y());
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (int a = 0; a < 2; ++a) {
    if (all.min()[a] < box.min()[a]) shift[a] = box.min()[a] - all.min()[a];
    else if (all.max()[a] > box.max()[a]) shift[a] = box.max()[a] - all.max()[a];
    // Away from zero to the printed thousandth, so that the figures as read move it inside.
    shift[a] = std::copysign(std::ceil(std::abs(shift[a]) * 1000.0 - 1e-9) / 1000.0, shift[a]);
  }
  const Eigen::Vector2d fits = origin + shift;
  field = aligned ? "align_mm" : "origin_mm";
  if (aligned)
    return fmt::format("{}; it fits with the program's zero, the first alignment point, at X {:.3f}, Y {:.3f} on the "
                       "machine (it is at X {:.3f}, Y {:.3f}): move the sheet by X {:.3f}, Y {:.3f} and take the points "
                       "again",
                       head, fits.x(), fits.y(), origin.x(), origin.y(), shift.x(), shift.y());
  return fmt::format("{}; it fits with the program's zero at X {:.3f}, Y {:.3f} on the machine (it is at X {:.3f}, "
                     "Y {:.3f}): move the zero there",
                     head, fits.x(), fits.y(), origin.x(), origin.y());
}

// Why the job leaves the travel, naming the first program line whose motion does ("" when it
// stays inside); `origin` is where the program's zero sits on the machine (`aligned`: set by a
// sheet alignment), `field` is set to the option that would move the job inside.
std::string leaves_travel(const Job& job, const cutting::MachineConfig& m, const Eigen::Vector2d& origin, bool aligned,
                          std::string& field) {
  const Eigen::AlignedBox2d box = travel_box(m);
  const double tol = 1e-6;
  const auto inside = [&](const Eigen::AlignedBox2d& b) {
    return b.min().x() >= box.min().x() - tol && b.min().y() >= box.min().y() - tol && b.max().x() <= box.max().x() + tol &&
           b.max().y() <= box.max().y() + tol;
  };
  const Eigen::AlignedBox2d start(job.start_mm, job.start_mm);
  if (!inside(start))
    return outside_travel(job.source, "the start position lies", start, job, box, origin, aligned, m.name, tol, field);
  for (const Stretch& s : job.stretches)
    for (std::size_t i = 0; i < s.segments.size(); ++i) {
      const Eigen::AlignedBox2d b = bounding_box(s.segments[i]);
      if (inside(b)) continue;
      return outside_travel(fmt::format("{}:{}", job.source, s.source_lines[i]),
                            fmt::format("the move (X {:.3f} .. {:.3f}, Y {:.3f} .. {:.3f} mm) goes", b.min().x(), b.max().x(),
                                        b.min().y(), b.max().y()),
                            b, job, box, origin, aligned, m.name, tol, field);
    }
  return {};
}

// Names the first cut that enters (or touches) a declared no-go zone ("" when none does):
// the zones are clamps and the like, which the torch must never burn. A feed move with the
// torch off (a frame, a marking pass) is not re-routed as a rapid is, so it must stay out too.
std::string cut_in_zone(const Job& job, const std::vector<NoGoZone>& zones, const std::string& zones_path) {
  for (const Stretch& s : job.stretches) {
    if (s.rapid) continue;
    for (std::size_t i = 0; i < s.segments.size(); ++i) {
      const Segment& g = s.segments[i];
      for (const NoGoZone& z : zones) {
        bool enters = contains(z.contour, g.start);
        for (std::size_t k = 0; !enters && k < z.contour.size(); ++k) enters = !intersect(g, z.contour.span(k)).empty();
        if (enters)
          return fmt::format("{}:{}: the {} enters the no-go zone '{}' declared at {}:{}", job.source, s.source_lines[i],
                             s.cutting ? "cut" : "move (torch off)", z.name, zones_path, z.line);
      }
    }
  }
  return {};
}

// Seconds as people read them: "3.2 h (11520 s)".
std::string duration_text(double s) {
  if (s >= 1e9) return fmt::format("{:.3g} h ({:.3g} s)", s / 3600, s);
  if (s >= 3600) return fmt::format("{:.1f} h ({:.0f} s)", s / 3600, s);
  if (s >= 60) return fmt::format("{:.1f} min ({:.0f} s)", s / 60, s);
  return fmt::format("{:.1f} s", s);
}

// The time no motion of `job` can beat: every stretch at its feed, capped by the machine's
// speed, with no time lost to acceleration. Length sums stay finite: the travel check has
// passed, so every segment lies within the machine.
double motion_floor_s(const Job& job, double max_speed_mm_per_s) {
  double t = 0.0;
  for (const Stretch& s : job.stretches)
    for (std::size_t k = 0; k < s.segments.size(); ++k) {
      const double feed = std::min(k < s.feed_mm_per_s.size() ? s.feed_mm_per_s[k] : max_speed_mm_per_s, max_speed_mm_per_s);
      if (feed > 0) t += length(s.segments[k]) / feed;
    }
  return t;
}

// Refuses the run when its estimate exceeds the limit; false then.
bool within_time_limit(PlannedRun& o, double estimate_s, double limit_s, const char* what) {
  if (!(estimate_s > limit_s)) return true;
  refuse(o, Status::infeasible,
         fmt::format("{}: the run would take {} of machine time ({}), more than the limit of {}; nothing "
                     "was run. Check the feeds and the machine's limits, or raise the limit",
                     o.job.source, duration_text(estimate_s), what, duration_text(limit_s)),
         "max_machine_time_s");
  return false;
}

// The run's session with the feed its calibration's open-loop factor is for (the paper modes
// run every feed move at the override).
session::MachineSessionOptions with_paper_feed(session::MachineSessionOptions so, const RunOptions& o) {
  if (o.feed_override_mm_per_s > 0) so.paper_feed_mm_per_s = o.feed_override_mm_per_s;
  return so;
}

}  // namespace

void RunOptions::validate() const {
  // The session's rules as the run's own (its fields named as the session names them: a run
  // and its session are one set of options to the caller).
  with_paper_feed(session, *this).validate();
  check_range("kerf_mm", kerf_mm, 0.0, 100.0, false, " mm");
  // Below a micrometre a kerf is lost in the offset's own tolerance (engine/geometry/offset.h).
  if (kerf_mm > 0 && kerf_mm < 0.001)
    throw InputError::field("kerf_mm",
                            fmt::format("{} mm is below 0.001 mm, the smallest kerf compensated; give 0 for none", kerf_mm));
  if (feed_override_mm_per_s != 0.0) check_range("feed_override_mm_per_s", feed_override_mm_per_s, 0.0, 10000.0, true, " mm/s");
  if (origin_mm) {
    check_range("origin_mm", origin_mm->x(), -1e6, 1e6, false, " mm");
    check_range("origin_mm", origin_mm->y(), -1e6, 1e6, false, " mm");
  }
  if (align_mm) {
    if (origin_mm) throw InputError::field("align_mm", "a sheet alignment sets the program's zero: give it or origin_mm, not both");
    for (const Eigen::Vector2d& p : {align_mm->first, align_mm->second}) {
      check_range("align_mm", p.x(), -1e6, 1e6, false, " mm");
      check_range("align_mm", p.y(), -1e6, 1e6, false, " mm");
    }
    const double d = (align_mm->second - align_mm->first).norm();
    if (d < kMinAlignEdgeMm)
      throw InputError::field("align_mm", fmt::format("the two points are {:.3f} mm apart: at least {:g} mm along the edge, for "
                                                      "its angle to be known",
                                                      d, kMinAlignEdgeMm));
  }
  validate_member("gcode", gcode);
  check_range("max_machine_time_s", max_machine_time_s, 0.0, 365 * 24 * 3600.0, true, " s");
  require_field(from_line >= 0 && from_line <= 100000000, "from_line", from_line, "must be a line number >= 1 (0: from the start)");
  validate_member("rapids", rapids);
  require_field(default_material >= -1 && default_material <= 999999, "default_material", default_material,
                "must be a material number in 0 .. 999999 (-1: none)");
  if (default_material >= 0 && materials_path.empty())
    throw InputError::field("default_material", fmt::format("material {} is chosen but no material file is given", default_material));
}

CutOrder cut_order_of(const cutting::MachineConfig& m) {
  if (m.cut_order.empty()) return CutOrder::program;
  const std::optional<CutOrder> o = cut_order_from(m.cut_order);
  if (!o)
    throw InputError(m.source, m.cut_order_line,
                     fmt::format("key 'cut_order' must be program, nearest or optimise, got '{}'", m.cut_order.substr(0, 40)));
  return *o;
}

PlannerOptions planner_options_for(const cutting::MachineConfig& m) {
  PlannerOptions p;
  p.max_velocity_mm_per_s = Eigen::Vector2d::Constant(m.limits.velocity_mm_per_s);
  p.max_acceleration_mm_per_s2 = Eigen::Vector2d::Constant(m.limits.acceleration_mm_per_s2);
  p.max_jerk_mm_per_s3 = m.limits.jerk_mm_per_s3;
  p.servo_period_s = m.servo_period_s;
  return p;
}

double process_time_s(const Job& job, const cutting::MachineConfig& m, double tol) {
  const auto& th = m.torch_height;
  const bool plasma = m.torch.kind == executor::TorchSetup::Kind::plasma;
  const bool oxy = m.torch.kind == executor::TorchSetup::Kind::oxy_fuel;
  TorchTimes times;
  if (th.fitted)
    times.height = TorchTimes::Height{th.retract_height_mm, th.pierce_height_mm, th.cut_height_mm, th.speed_mm_per_s, tol};
  if (th.fitted && th.probe.fitted()) {
    const auto& p = th.probe;
    times.probe = TorchTimes::Probe{p.probe_height_mm, p.probe_speed_mm_per_s, p.ohmic ? -p.ohmic_offset_mm : p.float_travel_mm,
                                    p.debounce_periods * m.servo_period_s, p.skip_distance_mm, p.offset(), p.offset_delay_s};
  }
  if (plasma) times.start_s = m.torch.plasma.arc_start_delay_s;
  if (oxy) times.start_s = m.torch.oxy_fuel.preheat_s;
  times.pierce_s = oxy ? m.torch.oxy_fuel.pierce_delay_s : m.torch.plasma.pierce_delay_s;
  times.use_materials = true;  // the executor takes each cut's material (torch_sequencer.h)
  if (m.spindle) {  // a spindle: its spin-up after M3/M4, its run-down after M5
    times.start_s = m.spindle->spin_up_s;
    times.pierce_s = 0.0;
    times.torch_off_s = m.spindle->spin_down_s;
  }
  return motion::process_time_s(job, times);
}

namespace {

bool paper_mode(const RunOptions& o) { return o.session.executor.mode != Mode::planned; }

// Words the machine does not act on: one note per kind, naming the first line.
std::vector<std::string> ignored_words(const Program& program, const std::string& machine) {
  std::vector<std::string> notes;
  std::map<ProgramEvent::Kind, std::pair<int, int>> seen;  // kind -> (first line, count)
  for (const ProgramEvent& e : program.events) {
    if (plasma_word(e)) continue;  // make_job acts on these
    auto [it, fresh] = seen.try_emplace(e.kind, e.line, 0);
    ++it->second.second;
  }
  for (const auto& [kind, where] : seen)
    notes.push_back(fmt::format("{}:{}: {} ({} in the program) ignored: machine '{}' does not act on it", program.source,
                                where.first, to_string(kind), where.second, machine));
  return notes;
}

// On these 2-axis machines the torch height is the machine's: the first move that changes Z
// (a helix included) is reported once, then every Z word is dropped.
void flatten_z(Program& program, const std::string& machine, std::vector<std::string>& warnings) {
  double z = program.start.z();
  for (const Move& m : program.moves) {
    if (!is_motion(m) || m.plane != Move::Plane::xy) continue;
    if (std::abs(m.end.z() - z) > 1e-9) {
      warnings.push_back(fmt::format("{}:{}: Z words dropped from here on (Z {:.6g} -> {:.6g} mm): machine '{}' moves X "
                                     "and Y only (strict_z refuses them instead)",
                                     program.source, m.line, z, m.end.z(), machine));
      break;
    }
    z = m.end.z();
  }
  for (Move& m : program.moves)
    if (m.plane == Move::Plane::xy) m.end.z() = program.start.z();
}

// Where the program's zero sits on the machine, and who said so: "given" (RunOptions),
// "machine file" or "none" (machine zero).
std::pair<Eigen::Vector2d, std::string> program_origin(const RunOptions& options, const cutting::MachineConfig& machine) {
  if (options.align_mm) return {options.align_mm->first, "sheet alignment"};
  if (options.origin_mm) return {*options.origin_mm, "given"};
  if (machine.origin_mm) return {Eigen::Vector2d((*machine.origin_mm)[0], (*machine.origin_mm)[1]), "machine file"};
  return {Eigen::Vector2d::Zero(), "none"};
}

// Moves the program's zero to `origin` on the machine, turned by `rotation_rad` about it (an
// arc keeps its sense; one outside the XY plane cannot turn).
void place_program(Program& program, const Eigen::Vector2d& origin, double rotation_rad = 0.0) {
  if (rotation_rad != 0.0) {
    const Eigen::Rotation2Dd r(rotation_rad);
    program.start.head<2>() = r * Eigen::Vector2d(program.start.head<2>());
    for (Move& m : program.moves) {
      if (m.kind == Move::Kind::arc && m.plane != Move::Plane::xy)
        throw InputError(program.source, m.line, "an arc outside the XY plane cannot be turned by the sheet alignment");
      m.end.head<2>() = r * Eigen::Vector2d(m.end.head<2>());
      if (m.kind == Move::Kind::arc) m.center = r * m.center;
    }
  }
  if (origin == Eigen::Vector2d::Zero()) return;
  program.start.head<2>() += origin;
  for (Move& m : program.moves) {
    m.end.head<2>() += origin;
    if (m.kind != Move::Kind::arc) continue;
    // The centre is in the plane's axis order: (x, y), (z, x) or (y, z).
    if (m.plane == Move::Plane::xy) m.center += origin;
    else if (m.plane == Move::Plane::xz) m.center.y() += origin.x();
    else m.center.x() += origin.y();
  }
}

// The feeds the job runs at: --feed on every cut, and in the paper modes the rapids at the
// slowest cutting feed (RunOptions::paper_rapids_at_feed).
void set_feeds(Job& job, const RunOptions& options) {
  if (options.feed_override_mm_per_s > 0)
    for (Stretch& s : job.stretches)
      if (!s.rapid) std::fill(s.feed_mm_per_s.begin(), s.feed_mm_per_s.end(), options.feed_override_mm_per_s);
  if (!paper_mode(options) || !options.paper_rapids_at_feed) return;
  double slowest = std::numeric_limits<double>::infinity();
  for (const Stretch& s : job.stretches)
    if (!s.rapid)
      for (double f : s.feed_mm_per_s) slowest = std::min(slowest, f);
  if (std::isfinite(slowest))
    for (Stretch& s : job.stretches)
      if (s.rapid)
        for (double& f : s.feed_mm_per_s) f = std::min(f, slowest);
}

// Rapids round the declared zones and the parts cut so far; a rapid left as programmed must at
// least not run into a declared zone (a clamp). False (o.summary says why) when the job
// cannot run so.
bool plan_the_rapids(PlannedRun& o, const RunOptions& options, const RunControl& control) {
  if (!options.no_go_path.empty()) o.declared_zones = load_zones(options.no_go_path);
  const std::vector<Contour> declared = zone_contours(o.declared_zones);
  if (std::string why = cut_in_zone(o.job, o.declared_zones, options.no_go_path); !why.empty()) {
    refuse(o, Status::infeasible, std::move(why));
    return false;
  }
  RapidOptions ro = options.rapids;
  ro.bounds = travel_box(o.machine);
  ro.slug_tip_size_mm = o.machine.slug_tip_size_mm;
  ro.travel_height_over_cut_mm = o.machine.torch_height.fitted ? o.machine.torch_height.travel_height_over_cut_mm : 0.0;
  Termination never;
  Termination rapids_end(control.termination ? *control.termination : never);
  o.rapids = plan_rapids(o.job, declared, ro, options.zones_from_cuts, rapids_end, control.planning);
  if (o.rapids.ended_early()) {
    refuse(o, o.rapids.summary.status,
           fmt::format("{}: {} while planning the rapids; nothing was run", o.job.source, rapids_end.describe()));
    return false;
  }
  for (const Stretch& s : o.job.stretches)
    if (s.cutting && !s.rapid)
      if (auto loop = closed_loop(s)) o.cut_zones.push_back(std::move(*loop));
  for (const RapidReport& r : o.rapids.rapids) {
    if (r.replaced || r.programmed_clear || declared.empty()) continue;
    const Stretch& s = o.job.stretches[r.stretch];
    std::vector<Eigen::Vector2d> route{s.segments.front().start};
    for (const Segment& g : s.segments) route.push_back(g.end);
    if (polyline_clearance_mm(route, declared) <= 0.0) {
      refuse(o, Status::infeasible,
             fmt::format("{}:{}: the rapid from ({:.3f}, {:.3f}) to ({:.3f}, {:.3f}) has no clear route ({}) "
                         "and its programmed route enters a declared no-go zone",
                         o.job.source, r.source_line, r.from.x(), r.from.y(), r.to.x(), r.to.y(), r.message));
      return false;
    }
  }
  return true;
}

// One trajectory per move step (also for the paper modes, for the bound), and the bounds.
// False (o.summary says why) when the caller's Termination ended the planning.
bool plan_the_feeds(PlannedRun& o, const RunControl& control) {
  o.trajectories.resize(o.job.steps.size());
  for (std::size_t i = 0; i < o.job.steps.size(); ++i) {
    const Step& st = o.job.steps[i];
    if (st.kind != Step::Kind::move) continue;
    if (control.termination && control.termination->should_end()) {
      refuse(o, status_of(control.termination->reason()),
             fmt::format("{}: {} while planning the feeds; nothing was run", o.job.source, control.termination->describe()));
      return false;
    }
    auto tr = plan_stretch_detailed(o.job.stretches[st.stretch], o.planner);
    o.planned_motion_s += tr->duration_s();
    o.motion_lower_bound_s += time_lower_bound_s(tr->executed_path(), o.planner);
    o.motion_optimum_s += time_optimal_s(tr->executed_path(), o.planner);
    o.trajectories[i] = std::move(tr);
  }
  o.process_time_s = process_time_s(o.job, o.machine, o.machine.setup().torch.height_tolerance_mm);
  o.lower_bound_s = o.motion_lower_bound_s + o.process_time_s;
  o.motion_ratio = o.motion_lower_bound_s > 0 ? o.planned_motion_s / o.motion_lower_bound_s : 1.0;
  o.optimum_ratio = o.motion_optimum_s > 0 ? o.planned_motion_s / o.motion_optimum_s : 1.0;
  return true;
}

}  // namespace

session::MachineSessionOptions session_options_for(const RunOptions& options) {
  session::MachineSessionOptions so = with_paper_feed(options.session, options);
  if (!so.machine_config) so.machine_config = cutting::load_machine(cutting::find_machine(so.machine));
  if (paper_mode(options) && options.paper_x1_decoding)
    for (auto& a : so.machine_config->axes) a.plant.decoding = 1;
  return so;
}

Program read_program_for(const std::string& program_path, GcodeOptions gcode, const cutting::MachineConfig& machine,
                         bool strict_z, std::vector<std::string>& warnings) {
  // The machine file's parameters and spindles; the given values win.
  for (const auto& [name, value] : machine.gcode_params) gcode.params.emplace(name, value);
  gcode.spindle_count = std::max(gcode.spindle_count, machine.gcode_spindles);
  Program program = read_gcode_file(program_path, gcode);
  warnings.insert(warnings.end(), program.warnings.begin(), program.warnings.end());
  if (!strict_z) flatten_z(program, machine.name, warnings);
  return program;
}

PlannedRun plan_program(const std::string& program_path, const RunOptions& options, const cutting::MachineConfig& machine,
                        const RunControl& control) {
  options.validate();
  std::vector<std::string> warnings;
  // QtPlasmaC's words: the hole-rule parameters and material comments are reported, and
  // F#<_hal[plasmac.cut-feed-rate]> reads a marker that make_job replaces by the material's
  // CUT_SPEED (or the machine file's value), unless the caller gave that parameter a value.
  GcodeOptions gcode = options.gcode;
  gcode.report_magic_comments = true;
  gcode.reported_params = plasma_reported_params();
  const std::string feed_param = "_hal[plasmac.cut-feed-rate]";
  JobOptions jo;
  if (!gcode.params.count(feed_param)) {
    jo.material_feed_marker_mm_per_min = kMaterialCutFeed;
    for (const auto& [name, value] : machine.gcode_params)
      if (name == feed_param) jo.machine_cut_feed_mm_per_s = value / 60.0;
    gcode.params[feed_param] = kMaterialCutFeed;
  }
  std::optional<MaterialTable> materials;
  if (!options.materials_path.empty()) materials = read_materials_file(options.materials_path);
  jo.materials = materials ? &*materials : nullptr;
  jo.default_material = options.default_material;
  Program program = read_program_for(program_path, gcode, machine, options.strict_z, warnings);
  if (materials) warnings.insert(warnings.end(), materials->warnings.begin(), materials->warnings.end());
  std::vector<std::string> notes = ignored_words(program, machine.name);
  // The order of the cuts: the option, else the machine file's, else the program's own.
  CutOrderOptions order;
  order.order = options.order.value_or(cut_order_of(machine));
  // QtPlasmaC's words are modal (a material, a velocity, THC off, a hole rule holds until the
  // next one): cuts moved past them would change material. Such a program keeps its order.
  if (order.order != CutOrder::program)
    for (const ProgramEvent& e : program.events)
      if (plasma_word(e)) {
        warnings.push_back(fmt::format("{}:{}: cuts left in program order: the program sets materials, THC, velocity or "
                                       "hole rules ({}), which hold from where they stand",
                                       program.source, e.line, to_string(e.kind)));
        order.order = CutOrder::program;
        break;
      }
  OrderedProgram ordered = order_cuts(program, order);
  program = std::move(ordered.program);
  warnings.insert(warnings.end(), ordered.report.warnings.begin(), ordered.report.warnings.end());
  const auto [origin, from] = program_origin(options, machine);
  const double rotation = options.align_mm ? std::atan2(options.align_mm->second.y() - options.align_mm->first.y(),
                                                        options.align_mm->second.x() - options.align_mm->first.x())
                                           : 0.0;
  place_program(program, origin, rotation);
  jo.rapid_feed_mm_per_s = machine.limits.rapid_mm_per_s;
  PlannedRun o = plan_job(make_job(program, jo), options, machine, control);
  o.origin_mm = origin;
  o.origin_from = from;
  o.rotation_deg = rotation * 180.0 / std::numbers::pi;
  o.warnings = std::move(warnings);
  o.notes = std::move(notes);
  for (const CutParameters& c : o.programmed.materials)
    o.notes.push_back(fmt::format("material {}{}: cut feed {:.0f} mm/min, pierce {:.2f} mm for {:.2f} s, cut height {:.2f} mm, "
                                  "kerf {:.2f} mm{}, THC {}",
                                  c.number == 0 ? "(temporary)" : std::to_string(c.number),
                                  c.name.empty() ? "" : fmt::format(" '{}'", excerpt(c.name, 40)), c.cut_feed_mm_per_s * 60.0,
                                  c.pierce_height_mm, c.pierce_delay_s, c.cut_height_mm, c.kerf_mm,
                                  options.kerf_from_materials ? " (compensated)"
                                  : options.kerf_mm > 0       ? fmt::format(" (cuts compensated by {:.2f} mm)", options.kerf_mm)
                                                              : " (not compensated: kerf_mm is 0)",
                                  c.thc ? "on" : "off"));
  o.cut_order = std::move(ordered.report);
  return o;
}

PlannedRun plan_job(Job programmed, const RunOptions& options, const cutting::MachineConfig& machine,
                    const RunControl& control) {
  options.validate();
  PlannedRun o;
  o.machine = machine;
  o.paper_x1_decoding = paper_mode(options) && options.paper_x1_decoding;
  o.planner = planner_options_for(o.machine);
  o.programmed = std::move(programmed);
  set_feeds(o.programmed, options);
  o.job = o.programmed;

  if (options.kerf_mm > 0 || options.kerf_from_materials) {
    KerfOptions ko;
    ko.kerf_from_materials = options.kerf_from_materials;
    o.kerf = apply_kerf(o.job, options.kerf_mm, ko);
  }
  if (options.from_line > 0) {
    LineStart start;
    o.job = start_at_line(o.job, options.from_line, o.machine.limits.rapid_mm_per_s, start);
    o.from_line = start;
  }
  if (o.machine.torch_height.fitted)
    o.offset_probes = insert_offset_probes(o.job, o.machine.torch_height.probe, o.machine.limits.rapid_mm_per_s,
                                           o.from_line ? o.from_line->prefix_steps : 0);
  std::string travel_field;
  if (std::string why = leaves_travel(o.job, o.machine, program_origin(options, machine).first,
                                      options.align_mm.has_value(), travel_field);
      !why.empty()) {
    refuse(o, Status::infeasible, std::move(why), std::move(travel_field));
    return o;
  }

  // Refused before any planning when even the fastest conceivable motion is too long.
  const double height_tolerance_mm = o.machine.setup().torch.height_tolerance_mm;
  if (!within_time_limit(o, motion_floor_s(o.job, o.machine.limits.velocity_mm_per_s) +
                                process_time_s(o.job, o.machine, height_tolerance_mm),
                         options.max_machine_time_s, "at least: every move at its feed, no time to accelerate"))
    return o;
  if (!plan_the_rapids(o, options, control)) return o;
  if (o.from_line) {  // the cuts before the line were there for the rapid planner only
    drop_prefix(o.job, *o.from_line);
    for (RapidReport& r : o.rapids.rapids) r.stretch -= o.from_line->prefix_stretches;
  }
  if (!plan_the_feeds(o, control)) return o;
  within_time_limit(o, o.expected_s(), options.max_machine_time_s, "the planned motion plus the torch process and dwells");
  return o;
}

FramePlan plan_frame(const Job& job, RunOptions options, FrameOptions frame, const cutting::MachineConfig& machine,
                     const RunControl& control) {
  const double rapid = machine.limits.rapid_mm_per_s;
  if (frame.rapid_feed_mm_per_s == 0.0) frame.rapid_feed_mm_per_s = rapid;
  if (frame.feed_mm_per_s == 0.0) frame.feed_mm_per_s = rapid;
  Frame f = frame_job(job, frame);
  options.kerf_mm = 0.0;
  options.kerf_from_materials = false;
  options.from_line = 0;
  options.feed_override_mm_per_s = 0.0;
  FramePlan out;
  out.outline = f.outline;
  out.from_cuts = f.from_cuts;
  out.options = frame;
  out.plan = plan_job(std::move(f.job), options, machine, control);
  return out;
}

namespace {

// The probes for the sheet: how many, by which sensor, the surface they found and, with the
// backend's truth, how far from its pierce height each pierce fired (--json: probes).
std::string probes_line(const executor::ExecutionResult& r) {
  std::size_t skipped = 0, ohmic = 0, offset = 0, known = 0;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, worst = 0.0, time_s = 0.0;
  for (const executor::ProbeReport& p : r.probes) {
    skipped += p.skipped;
    ohmic += !p.skipped && std::string_view(p.sensor) == "ohmic";
    offset += !p.skipped && std::string_view(p.sensor) == "offset_probe";
    lo = std::min(lo, p.surface_mm);
    hi = std::max(hi, p.surface_mm);
    time_s += p.duration_s;
    if (!std::isnan(p.pierce_height_error_mm)) ++known, worst = std::max(worst, std::abs(p.pierce_height_error_mm));
  }
  const std::size_t probed = r.probes.size() - skipped;
  const std::string by = offset > 0 ? fmt::format("{} by the offset probe", offset)
                                    : fmt::format("{} by the ohmic contact, {} by the float switch", ohmic, probed - ohmic);
  std::string s = fmt::format("  probes           {} ({} skipped; {}), {:.3f} s; surface {:+.3f} .. {:+.3f} mm\n", r.probes.size(),
                              skipped, by, time_s, lo, hi);
  if (known > 0)
    s += fmt::format("                   pierce height within {:.3f} mm of the true surface's over {} pierces\n", worst, known);
  return s;
}

// Each paused motion along the path while the job was held (--json: paused_motions), the
// first kShown of them.
std::string paused_motion_lines(const executor::ExecutionResult& r) {
  constexpr std::size_t kShown = 20;
  std::string s;
  for (std::size_t i = 0; i < std::min(kShown, r.paused_motions.size()); ++i) {
    const executor::PausedMotionReport& p = r.paused_motions[i];
    s += fmt::format("  paused motion    {:+.3f} mm along the path at {:.2f} s, from line {} ({:.3f}, {:.3f}) to line {} "
                     "({:.3f}, {:.3f}){}\n",
                     p.moved_mm, p.t_s, p.from_line, p.from_mm.x(), p.from_mm.y(), p.to_line, p.to_mm.x(), p.to_mm.y(),
                     p.by_arc_loss ? ", back to where the arc went out" : "");
  }
  const std::size_t more = r.paused_motions.size() - std::min(kShown, r.paused_motions.size()) + r.paused_motions_dropped;
  if (more > 0) s += fmt::format("                   and {} more\n", more);
  return s;
}

// Torch height control over the cuts, the figures --json gives per cut (cuts[].thc), from the
// backend's truth: how far the torch was from its cut height while THC held it. Empty when no
// cut has them (no height axis, a machine without truth, THC never took hold).
std::string thc_lines(const executor::ExecutionResult& r) {
  std::size_t cuts = 0, samples = 0, worst = 0;
  double max_mm = -1.0, sum2 = 0.0, active = 0.0, velocity_change = 0.0, void_change = 0.0;
  for (std::size_t i = 0; i < r.cuts.size(); ++i) {
    const executor::ThcFigures& h = r.cuts[i].thc;
    if (h.samples == 0 || std::isnan(h.max_mm)) continue;
    ++cuts;
    samples += h.samples;
    sum2 += h.rms_mm * h.rms_mm * static_cast<double>(h.samples);
    active += h.active_share * static_cast<double>(h.samples);
    if (h.max_mm > max_mm) max_mm = h.max_mm, worst = i;
    velocity_change = std::max(velocity_change, h.velocity_lock_change_mm);
    void_change = std::max(void_change, h.void_lock_change_mm);
  }
  if (cuts == 0) return {};
  const double n = static_cast<double>(samples);
  return fmt::format("  torch height     max {:.3f} mm, rms {:.3f} mm off the cut height over {} cuts while THC held it "
                     "(largest in cut {}, line {}); THC acting {:.0f} % of that time\n"
                     "                   height change under a velocity lock at most {:.3f} mm, under a void lock {:.3f} mm\n",
                     max_mm, std::sqrt(sum2 / n), cuts, worst + 1, r.cuts[worst].source_line, 100.0 * active / n,
                     velocity_change, void_change);
}

// The full report for people: what the planning did, then the run.
std::string full_report(const RunOutcome& o, const session::MachineSession& session) {
  const executor::ExecutionResult& r = o.result;
  std::string s;
  if (o.kerf) s += fmt::format("kerf compensation\n{}\n", o.kerf->brief(o.job.source));
  if (o.cut_order.reordered) s += fmt::format("{}\n", o.cut_order.summary.full_report());
  s += fmt::format("rapids (straight G0 against planned, mm)\n{}\n", o.rapids.summary.full_report());
  if (o.paper_x1_decoding)
    s += fmt::format("paper mode: encoders counted x1 as in the paper ({:.4f} mm per count), BLU {:g} mm, calibration {:g}\n\n",
                     o.machine.axes[0].plant.mm_per_count(), session.executor_options().blu_mm,
                     session.executor_options().calibration_factor);
  s += fmt::format("{} on {} ({} mode): {}\n", r.source, r.machine, executor::to_string(r.mode),
                   o.summary.done() ? "completed" : o.faulted() && o.summary.status == Status::faulted ? "FAULTED"
                                                                                                         : to_string(o.summary.status));
  s += fmt::format("  program origin   X {:.3f} Y {:.3f} mm on the machine ({}){}\n", o.origin_mm.x(), o.origin_mm.y(),
                   o.origin_from == "none" ? "none given: program zero is machine zero" : o.origin_from,
                   o.rotation_deg != 0.0 ? fmt::format(", the program turned {:+.3f} deg about it", o.rotation_deg) : "");
  if (o.controller != "pid_ff") s += fmt::format("  servo controller {}\n", o.controller);
  if (o.from_line)
    s += fmt::format("  from line        {} at ({:.3f}, {:.3f}){}\n", o.from_line->line, o.from_line->at_mm.x(),
                     o.from_line->at_mm.y(), o.from_line->relight ? ", lit again there" : "");
  for (const std::string& w : o.warnings) s += fmt::format("  warning: {}\n", w);
  for (const std::string& w : r.backend_notes) s += fmt::format("  warning: {}\n", w);
  for (const std::string& n : o.notes) s += fmt::format("  note: {}\n", n);
  s += fmt::format("  cycle time       {:9.3f} s\n", r.cycle_time_s);
  s += fmt::format("  {:<16} {:9.3f} s{}\n", o.machine.spindle ? "spindle on" : "torch on", r.torch_on_s,
                   r.ramp_pierces > 0 ? fmt::format("  ({} ramp pierces, moving along the cut)", r.ramp_pierces) : "");
  if (r.dry_pierces > 0)
    s += fmt::format("  torch disabled   {} pierces skipped by the operator's torch switch: those cuts ran dry\n", r.dry_pierces);
  if (!r.probes.empty()) s += probes_line(r);
  s += paused_motion_lines(r);
  s += fmt::format("  rapid distance   {:9.1f} mm  (straight {:.1f} mm; {} detours, +{:.1f} mm)\n", r.rapid_distance_mm,
                   o.rapids.straight_length_mm, o.rapids.detours, o.rapids.detour_extra_mm);
  for (const RapidReport& d : o.rapids.rapids)
    if (!d.reason.empty())
      s += fmt::format("    detour at line {:>5}: +{:.1f} mm round {}\n", d.source_line, d.extra_length_mm, d.reason);
  s += fmt::format("  lower bound      {:9.3f} s  (motion {:.3f} s on the planned paths at the machine's limits + "
                   "torch sequence and dwells {:.3f} s)\n",
                   o.lower_bound_s, o.motion_lower_bound_s, o.process_time_s);
  if (o.summary.done())
    s += fmt::format("  cycle ratio      {:9.4f}    (cycle time / lower bound; planned motion / motion bound {:.4f})\n",
                     o.cycle_ratio, o.motion_ratio);
  else
    s += fmt::format("  cycle ratio           -      (the run did not complete; planned motion / motion bound {:.4f})\n",
                     o.motion_ratio);
  s += fmt::format("  motion           {:9.3f} s  planned; time-optimal on the same paths {:.3f} s (ratio {:.4f})\n",
                   o.planned_motion_s, o.motion_optimum_s, o.optimum_ratio);
  s += fmt::format("  contour error    max {:.4f} mm, rms {:.4f} mm over {} cuts, torch on, from the encoders",
                   r.max_contour_error_mm(), o.rms_contour_error_mm, r.cuts.size());
  const double mt = r.max_true_contour_error_mm();
  if (!std::isnan(mt)) s += fmt::format(" (simulated truth: max {:.4f}, rms {:.4f})", mt, o.rms_true_contour_error_mm);
  if (!o.summary.done()) s += " (until the run stopped)";
  s += "\n";
  // A machine (the HAL backend) has no truth to compare with: no true columns, and a line saying so.
  const bool truth = r.truth_available;
  if (!truth)
    s += fmt::format("  true error       unavailable: the {} backend reports only what the machine measures\n", r.backend);
  s += fmt::format("  {:>4} {:>7} {:>6} {:>10} {:>10}", "cut", "line", "samples", "max mm", "rms mm");
  s += truth ? fmt::format(" {:>10} {:>10}\n", "true max", "true rms") : "\n";
  for (std::size_t i = 0; i < r.cuts.size(); ++i) {
    const executor::CutError& c = r.cuts[i];
    s += fmt::format("  {:>4} {:>7} {:>6} {:>10.4f} {:>10.4f}", i + 1, c.source_line, c.samples, c.max_mm, c.rms_mm);
    if (truth) s += fmt::format(" {:>10.4f} {:>10.4f}", c.max_true_mm, c.rms_true_mm);
    s += c.complete ? "\n" : "  interrupted\n";
  }
  s += thc_lines(r);
  if (r.faults.empty()) {
    s += "  faults           none; torch off at the end\n";
  } else {
    for (const executor::FaultReport& f : r.faults) s += fmt::format("  FAULT {}: {}\n", executor::to_string(f.kind), f.message);
    s += fmt::format("  torch {} at the end; machine {}\n", r.torch_off_at_end ? "off" : "ON",
                     r.stopped_at_rest ? "stopped at rest" : "stop not confirmed");
  }
  if (r.trace_truncated) s += "  trace truncated (buffer full)\n";
  return s;
}

// How the run ended (the executor's summary: done; faulted; cancelled or what ended its
// Termination), with a brief for a list.
Summary summarize(const RunOutcome& o) {
  const executor::ExecutionResult& r = o.result;
  Summary s;
  s.status = r.summary.status;
  s.message = r.summary.message;
  if (s.done()) {
    s.brief = fmt::format("{} on {}: done in {:.3f} s, max contour error {:.4f} mm over {} cuts", r.source, r.machine,
                          r.cycle_time_s, r.max_contour_error_mm(), r.cuts.size());
    return s;
  }
  const executor::FaultReport& f = r.faults.front();
  s.brief = fmt::format("{} on {}: {} at {:.3f} s (line {}): {}", r.source, r.machine,
                        s.status == Status::faulted ? "FAULTED" : to_string(s.status), f.time_s, f.source_line,
                        executor::to_string(f.kind));
  return s;
}

}  // namespace

RunOutcome execute(session::MachineSession& session, PlannedRun plan, const RunOptions& options, const RunControl& control) {
  RunOutcome o;
  static_cast<PlannedRun&>(o) = std::move(plan);
  if (!o.summary.done()) return o;  // refused by its planning: nothing runs
  // The caller's stop request, and the deadline: no run lasts longer than the machine time
  // allowed (a job held and never resumed, an input that never comes).
  Termination never;
  Termination t(control.termination ? *control.termination : never);
  t.set_deadline(options.max_machine_time_s, "machine time");
  session::MachineSession::RunHooks hooks;
  hooks.termination = &t;
  hooks.progress = control.running;
  hooks.expected_s = o.expected_s();
  static const executor::Trajectories kNone;
  const bool planned = session.executor_options().mode == Mode::planned;
  o.result = session.run(o.job, planned ? o.trajectories : kNone, hooks);
  o.controller = session.controller_name();
  o.cycle_ratio = o.lower_bound_s > 0 ? o.result.cycle_time_s / o.lower_bound_s : 1.0;

  double sum2 = 0, sum2_true = 0;
  std::size_t n = 0;
  for (const executor::CutError& c : o.result.cuts) {
    sum2 += c.rms_mm * c.rms_mm * static_cast<double>(c.samples);
    if (!std::isnan(c.rms_true_mm)) sum2_true += c.rms_true_mm * c.rms_true_mm * static_cast<double>(c.samples);
    n += c.samples;
  }
  o.rms_contour_error_mm = n ? std::sqrt(sum2 / static_cast<double>(n)) : 0.0;
  o.rms_true_contour_error_mm = !o.result.truth_available ? std::numeric_limits<double>::quiet_NaN()
                                : n                          ? std::sqrt(sum2_true / static_cast<double>(n))
                                                             : 0.0;
  o.summary = summarize(o);
  o.summary.full = full_report(o, session);
  return o;
}

RunOutcome run_program(const std::string& program_path, const RunOptions& options, const RunControl& control) {
  session::MachineSession session(session_options_for(options));
  PlannedRun plan = plan_program(program_path, options, session.machine(), control);
  return execute(session, std::move(plan), options, control);
}

RunOutcome run_job(Job programmed, const RunOptions& options, const RunControl& control) {
  session::MachineSession session(session_options_for(options));
  PlannedRun plan = plan_job(std::move(programmed), options, session.machine(), control);
  return execute(session, std::move(plan), options, control);
}

}  // namespace machplan::motion
