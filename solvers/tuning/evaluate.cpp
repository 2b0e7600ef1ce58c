#include "solvers/tuning/evaluate.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/motion/make_job.h"
#include "engine/programs/gcode.h"
#include "solvers/session/machine_session.h"
#include "models/cutting/controller_plant.h"
#include "solvers/motion/run.h"

namespace machplan::tuning {
namespace {

double parse_number(const std::string& text, const std::string& spec, const char* what) {
  const std::optional<double> v = parse_finite(text);
  if (!v)
    throw InputError::field("contours", fmt::format("'{}': {} '{}' is not a number", excerpt(spec), what, excerpt(text)));
  return *v;
}

// A setpoint that jumps from `a` to `b` at t > 0 and holds: the step of the constraint tests.
class StepTrajectory final : public motion::Trajectory {
 public:
  StepTrajectory(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double duration_s) : a_(a), b_(b), d_(duration_s) {}
  double duration_s() const override { return d_; }
  void sample(double t_s, motion::Setpoint& out) const override {
    out.position_mm = t_s <= 0.0 ? a_ : b_;
    out.velocity_mm_per_s.setZero();
    out.acceleration_mm_per_s2.setZero();
  }

 private:
  Eigen::Vector2d a_, b_;
  double d_;
};

motion::Stretch feed_stretch(std::vector<Segment> segs, double feed_mm_per_s) {
  motion::Stretch s;
  s.cutting = false;
  s.rapid = false;
  s.feed_mm_per_s.assign(segs.size(), feed_mm_per_s);
  s.source_lines.assign(segs.size(), 1);
  s.segments = std::move(segs);
  return s;
}

motion::Job one_move_job(const std::string& source, const Eigen::Vector2d& start, motion::Stretch s) {
  motion::Job j;
  j.source = source;
  j.start_mm = start;
  j.stretches.push_back(std::move(s));
  motion::Step st;
  st.kind = motion::Step::Kind::move;
  st.stretch = 0;
  st.source_line = 1;
  j.steps.push_back(st);
  return j;
}

// The program as a Job of motion only: torch and dwell steps dropped (a tuning run cuts
// nothing; the XY table has no torch), every feed stretch counted.
motion::Job program_job(const TestContour& c, const cutting::MachineConfig& m) {
  std::vector<std::string> warnings;  // a tuning run moves X and Y only: the Z words go unremarked
  const Program program = motion::read_program_for(c.path, {}, m, false, warnings);
  motion::JobOptions jo;
  jo.rapid_feed_mm_per_s = m.limits.rapid_mm_per_s;
  motion::Job full = motion::make_job(program, jo);
  motion::Job j;
  j.source = full.source;
  j.start_mm = full.start_mm;
  j.stretches = full.stretches;
  for (motion::Stretch& s : j.stretches) s.cutting = false;
  for (const motion::Step& st : full.steps)
    if (st.kind == motion::Step::Kind::move) j.steps.push_back(st);
  if (j.steps.empty()) throw InputError(c.path, 0, "the program has no motion to tune on");
  return j;
}

Eigen::AlignedBox2d job_box(const motion::Job& j) {
  Eigen::AlignedBox2d b(j.start_mm, j.start_mm);
  for (const motion::Stretch& s : j.stretches)
    for (const Segment& g : s.segments) b.extend(bounding_box(g));
  return b;
}

void shift(motion::Job& j, const Eigen::Vector2d& d) {
  j.start_mm += d;
  for (motion::Stretch& s : j.stretches)
    for (Segment& g : s.segments) {
      g.start += d;
      g.end += d;
      g.center += d;
    }
}

double segment_distance(const Segment& s, const Eigen::Vector2d& p) { return (closest_point(s, p) - p).norm(); }

}  // namespace

// A job planned once, and which of its steps are measured (stretch index, or -1).
struct Evaluator::Prepared {
  motion::Job job;
  executor::Trajectories trajectories;
  std::vector<int> measured_stretch;
  // The path each measured step is asked to follow: the planner's executed path (the program
  // with its corners blended within the planner's path tolerance), whose deviation from the
  // program is the planner's choice, not a servo error.
  std::vector<const motion::Stretch*> reference;
  Eigen::Vector2d step_from = Eigen::Vector2d::Zero(), step_to = Eigen::Vector2d::Zero();
};

TestContour parse_contour(const std::string& spec) {
  TestContour c;
  c.spec = spec;
  const std::string quoted = excerpt(spec);  // for messages
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (kind == "program") {
    if (rest.empty()) throw InputError::field("contours", fmt::format("'{}': program:FILE.ngc names no file", quoted));
    c.kind = TestContour::Kind::program;
    c.path = rest;
    return c;
  }
  if (kind != "line" && kind != "circle" && kind != "corner" && kind != "square")
    throw InputError::field("contours", fmt::format("'{}': unknown contour kind '{}' (line:ANGLE_DEG:FEED_MM_MIN, "
                                                    "circle:RADIUS_MM:FEED_MM_MIN, corner:TURN_DEG:FEED_MM_MIN, "
                                                    "square:SIDE_MM:FEED_MM_MIN or program:FILE.ngc)",
                                                    quoted, excerpt(kind)));
  const auto colon2 = rest.find(':');
  if (colon == std::string::npos || colon2 == std::string::npos)
    throw InputError::field("contours", fmt::format("'{}': expected {}:{}:FEED_MM_MIN", quoted, kind,
                                                    kind == "circle"   ? "RADIUS_MM"
                                                    : kind == "square" ? "SIDE_MM"
                                                    : kind == "line"   ? "ANGLE_DEG"
                                                                       : "TURN_DEG"));
  const double a = parse_number(rest.substr(0, colon2), spec,
                                kind == "circle" ? "the radius" : kind == "square" ? "the side" : "the angle");
  const double f = parse_number(rest.substr(colon2 + 1), spec, "the feed");
  if (!(f > 0 && f <= 600000))
    throw InputError::field("contours", fmt::format("'{}': feed {} mm/min is out of range (0, 600000]", quoted, f));
  c.feed_mm_per_min = f;
  if (kind == "corner") {
    if (!(a > -180 && a < 180 && std::abs(a) >= 1))
      throw InputError::field("contours",
                              fmt::format("'{}': turn {} deg is out of range (-180, 180), at least 1 deg", quoted, a));
    c.kind = TestContour::Kind::corner;
    c.angle_deg = a;
  } else if (kind == "line") {
    if (!(a >= -360 && a <= 360))
      throw InputError::field("contours", fmt::format("'{}': angle {} deg is out of range [-360, 360]", quoted, a));
    c.kind = TestContour::Kind::line;
    c.angle_deg = a;
  } else if (kind == "square") {
    if (!(a >= 0.5 && a <= 10000))
      throw InputError::field("contours", fmt::format("'{}': side {} mm is out of range [0.5, 10000]", quoted, a));
    c.kind = TestContour::Kind::square;
    c.length_mm = a;
  } else {
    if (!(a >= 0.5 && a <= 10000))
      throw InputError::field("contours", fmt::format("'{}': radius {} mm is out of range [0.5, 10000]", quoted, a));
    c.kind = TestContour::Kind::circle;
    c.radius_mm = a;
  }
  return c;
}

namespace {
constexpr Spelling kObjectiveNames[] = {{"max"}, {"rms"}, {"itae"}};
}  // namespace

const char* to_string(Objective o) { return kObjectiveNames[static_cast<std::size_t>(o)].name.data(); }

Parsed<Objective> parse_objective(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kObjectiveNames, text, "objective", "objective");
  return {static_cast<Objective>(p.value), p.note};
}

void EvaluationOptions::validate() const {
  auto check = [](bool ok, const char* field, double v, const char* rule) {
    if (!ok) throw InputError::field(field, fmt::format("{} is out of range: {}", v, rule));
  };
  if (machine.empty()) throw InputError::field("machine", "names no machine");
  if (noise_runs < 1 || noise_runs > 100)
    throw InputError::field("noise_runs", fmt::format("{} is out of range: must be in [1, 100]", noise_runs));
  check(std::isfinite(step_mm) && step_mm > 0 && step_mm <= 20, "step_mm", step_mm, "must be in (0, 20] mm");
  check(std::isfinite(step_window_s) && step_window_s >= 0.05 && step_window_s <= 10, "step_window_s", step_window_s,
        "must be in [0.05, 10] s");
  check(std::isfinite(margin_gain_factor) && margin_gain_factor >= 1 && margin_gain_factor <= 10, "margin_gain_factor",
        margin_gain_factor, "must be in [1, 10]");
  check(std::isfinite(max_residual) && max_residual > 0, "max_residual", max_residual, "must be > 0");
  check(std::isfinite(max_overshoot) && max_overshoot > 0, "max_overshoot", max_overshoot, "must be > 0");
  check(std::isfinite(max_saturation_share) && max_saturation_share > 0 && max_saturation_share <= 1,
        "max_saturation_share", max_saturation_share, "must be in (0, 1]");
  check(std::isfinite(following_error_limit_mm) && following_error_limit_mm >= 0, "following_error_limit_mm",
        following_error_limit_mm, "must be >= 0");
}

double Evaluation::value(Objective o) const {
  switch (o) {
    case Objective::max: return max_mm;
    case Objective::rms: return rms_mm;
    case Objective::itae: return itae_mm_s2;
  }
  return max_mm;
}

Evaluator::Evaluator(const EvaluationOptions& options, const std::vector<TestContour>& contours)
    : options_(options), contours_(contours) {
  options_.validate();
  if (contours_.empty()) throw InputError::field("contours", "no test contour given");
  machine_ = cutting::load_machine(cutting::find_machine(options_.machine));
  margin_machine_ = machine_;
  for (auto& a : margin_machine_.axes) a.plant.gain_factor *= options_.margin_gain_factor;
  setup_ = machine_.setup();
  plant_ = cutting::controller_plant(machine_);
  following_limit_mm_ = options_.following_error_limit_mm > 0
                            ? options_.following_error_limit_mm
                            : std::min(setup_.servo[0].following_error_limit_mm, setup_.servo[1].following_error_limit_mm);
  const Eigen::Vector2d travel(machine_.axes[0].travel_mm, machine_.axes[1].travel_mm);
  const Eigen::Vector2d centre = travel / 2;
  const motion::PlannerOptions planner = motion::planner_options_for(machine_);

  for (const TestContour& c : contours_) {
    auto p = std::make_unique<Prepared>();
    if (c.kind == TestContour::Kind::line) {
      const double th = c.angle_deg * M_PI / 180.0;
      const Eigen::Vector2d d(std::cos(th), std::sin(th));
      const Eigen::Vector2d a = centre - d * c.length_mm / 2, b = centre + d * c.length_mm / 2;
      p->job = one_move_job(c.spec, a, feed_stretch({make_segment(a, b, 0.0)}, c.feed_mm_per_min / 60.0));
    } else if (c.kind == TestContour::Kind::corner) {
      // Along +X into the corner at the centre, then off at the turn angle: one stretch, so
      // the planner blends (and slows for) the corner as it does in a program.
      const double th = c.angle_deg * M_PI / 180.0, half = c.length_mm / 2;
      const Eigen::Vector2d a = centre - Eigen::Vector2d(half, 0), b = centre + half * Eigen::Vector2d(std::cos(th), std::sin(th));
      p->job = one_move_job(c.spec, a, feed_stretch({make_segment(a, centre, 0.0), make_segment(centre, b, 0.0)},
                                                    c.feed_mm_per_min / 60.0));
    } else if (c.kind == TestContour::Kind::square) {
      // Counter-clockwise from the lower left corner, one stretch: four 90 degree corners, and
      // on each axis a stop, a hold while the other axis moves, and a start the other way.
      const double h = c.length_mm / 2;
      const Eigen::Vector2d p0 = centre + Eigen::Vector2d(-h, -h), p1 = centre + Eigen::Vector2d(h, -h),
                            p2 = centre + Eigen::Vector2d(h, h), p3 = centre + Eigen::Vector2d(-h, h);
      p->job = one_move_job(c.spec, p0,
                            feed_stretch({make_segment(p0, p1, 0.0), make_segment(p1, p2, 0.0), make_segment(p2, p3, 0.0),
                                          make_segment(p3, p0, 0.0)},
                                         c.feed_mm_per_min / 60.0));
    } else if (c.kind == TestContour::Kind::circle) {
      // Counter-clockwise from the point at angle 0, two half circles (bulge 1).
      const Eigen::Vector2d a = centre + Eigen::Vector2d(c.radius_mm, 0), b = centre - Eigen::Vector2d(c.radius_mm, 0);
      p->job = one_move_job(c.spec, a, feed_stretch({make_segment(a, b, 1.0), make_segment(b, a, 1.0)}, c.feed_mm_per_min / 60.0));
    } else {
      p->job = program_job(c, machine_);
      // Programs are placed with their extent centred in the travel.
      shift(p->job, centre - job_box(p->job).center());
    }
    const Eigen::AlignedBox2d box = job_box(p->job);
    if (box.min().minCoeff() < 0 || box.max().x() > travel.x() || box.max().y() > travel.y())
      throw Infeasible(fmt::format("{}: the contour ({:.1f} x {:.1f} mm) does not fit the travel of machine '{}' "
                                   "({:g} x {:g} mm)",
                                   c.spec, box.sizes().x(), box.sizes().y(), machine_.name, travel.x(), travel.y()));
    p->trajectories.resize(p->job.steps.size());
    p->measured_stretch.assign(p->job.steps.size(), -1);
    p->reference.assign(p->job.steps.size(), nullptr);
    for (std::size_t i = 0; i < p->job.steps.size(); ++i) {
      const motion::Step& st = p->job.steps[i];
      if (st.kind != motion::Step::Kind::move) continue;
      auto tr = motion::plan_stretch_detailed(p->job.stretches[st.stretch], planner);
      if (!p->job.stretches[st.stretch].rapid) {
        p->measured_stretch[i] = static_cast<int>(st.stretch);
        p->reference[i] = &tr->executed_path();
      }
      p->trajectories[i] = std::move(tr);
    }
    prepared_.push_back(std::move(p));
  }
  // The step of the constraint tests, from the middle of the travel.
  step_ = std::make_unique<Prepared>();
  const Eigen::Vector2d to = centre + Eigen::Vector2d::Constant(options_.step_mm);
  step_->job = one_move_job("step test", centre, feed_stretch({make_segment(centre, to, 0.0)}, 1.0));
  step_->trajectories.resize(1);
  step_->trajectories[0] = std::make_unique<StepTrajectory>(centre, to, options_.step_window_s);
  step_->measured_stretch.assign(1, -1);
  step_->step_from = centre;
  step_->step_to = to;
}

Evaluator::~Evaluator() = default;

const motion::Job& Evaluator::job(std::size_t i) const { return prepared_.at(i)->job; }

namespace {

executor::ExecutionResult run_prepared(const motion::Job& job, const executor::Trajectories& trajectories,
                                       const cutting::MachineConfig& m, control::Controller& controller, std::uint64_t seed) {
  session::MachineSessionOptions so;
  so.machine_config = m;
  so.backend.sim.seed = seed;
  so.backend.sim.realtime = false;
  so.executor.record_trace = true;
  so.executor.trace_every_ticks = 1;
  session::MachineSession session(std::move(so));
  session::MachineSession::RunHooks hooks;
  hooks.controller = &controller;
  return session.run(job, trajectories, hooks);
}

}  // namespace

executor::ExecutionResult Evaluator::run_contour(std::size_t i, const std::string& kind, const control::Gains& gains) const {
  const Prepared& p = *prepared_.at(i);
  auto c = control::make_controller(kind, gains, plant_);
  return run_prepared(p.job, p.trajectories, machine_, *c, options_.seed);
}

ContourScore Evaluator::score(const Prepared& p, const executor::ExecutionResult& r, ErrorSeries* series) const {
  const double inf = std::numeric_limits<double>::infinity();
  const int dac_max[2] = {(1 << (setup_.signals[0].dac_bits - 1)) - 1, (1 << (setup_.signals[1].dac_bits - 1)) - 1};
  ContourScore s;
  s.faulted = !r.summary.done();
  if (s.faulted && !r.faults.empty()) s.fault = r.faults.front().message;
  const double T = setup_.servo_period_s > 0 ? setup_.servo_period_s : machine_.servo_period_s;
  int cur_step = -2;
  double t_start = 0.0;
  std::size_t saturated = 0;
  double s2 = 0.0;
  int max_stretch = -1;  // the stretch the maximum was measured on
  for (const executor::TraceSample& ts : r.trace) {
    if (ts.step < 0 || static_cast<std::size_t>(ts.step) >= p.measured_stretch.size()) continue;
    const int k = p.measured_stretch[static_cast<std::size_t>(ts.step)];
    if (k < 0) continue;
    if (ts.step != cur_step) {
      cur_step = ts.step;
      t_start = ts.t_s;
    }
    const Eigen::Vector2d pos = options_.use_true_position && !std::isnan(ts.true_mm.x()) ? ts.true_mm : ts.measured_mm;
    // Distance to the stretch's path as a whole (after the run, so no window is needed: a
    // tool wobbling about the start of a closed contour is near its start, not its end).
    const auto& segs = p.reference[static_cast<std::size_t>(ts.step)]->segments;
    double e = inf;
    for (const Segment& g : segs) e = std::min(e, segment_distance(g, pos));
    if (e > s.max_mm) {
      s.max_mm = e;
      s.max_at_s = ts.t_s;
      s.max_at_x_mm = pos.x();
      s.max_at_y_mm = pos.y();
      max_stretch = k;
    }
    s2 += e * e;
    s.itae_mm_s2 += (ts.t_s - t_start) * e * T;
    for (int a = 0; a < 2; ++a)
      s.max_following_error_mm = std::max(s.max_following_error_mm, std::abs(ts.commanded_mm[a] - ts.measured_mm[a]));
    if (std::abs(ts.dac_x) >= dac_max[0] || std::abs(ts.dac_y) >= dac_max[1]) ++saturated;
    ++s.samples;
    if (series) {
      series->t_s.push_back(ts.t_s);
      series->error_mm.push_back(e);
    }
  }
  s.rms_mm = s.samples ? std::sqrt(s2 / static_cast<double>(s.samples)) : 0.0;
  if (max_stretch >= 0) {
    // The program line of the programmed segment nearest the maximum, looked up once.
    const motion::Stretch& st = p.job.stretches[static_cast<std::size_t>(max_stretch)];
    const Eigen::Vector2d at(s.max_at_x_mm, s.max_at_y_mm);
    double best = inf;
    for (std::size_t g = 0; g < st.segments.size(); ++g)
      if (const double d = segment_distance(st.segments[g], at); d < best) {
        best = d;
        s.max_at_line = g < st.source_lines.size() ? st.source_lines[g] : 0;
      }
  }
  s.saturation_share = s.samples ? static_cast<double>(saturated) / static_cast<double>(s.samples) : 0.0;
  return s;
}

Evaluator::ErrorSeries Evaluator::error_series(std::size_t i, const std::string& kind, const control::Gains& gains) const {
  ErrorSeries out;
  score(*prepared_.at(i), run_contour(i, kind, gains), &out);
  return out;
}

Evaluation Evaluator::evaluate(const std::string& kind, const control::Gains& gains) const {
  Evaluation ev;
  const double inf = std::numeric_limits<double>::infinity();
  double sum2 = 0.0;
  std::size_t n_all = 0;
  for (std::size_t ci = 0; ci < prepared_.size(); ++ci) {
    const Prepared& p = *prepared_[ci];
    ContourScore s;
    double s2 = 0.0;
    for (int run = 0; run < options_.noise_runs; ++run) {
      auto ctl = control::make_controller(kind, gains, plant_);
      const executor::ExecutionResult r =
          run_prepared(p.job, p.trajectories, machine_, *ctl, options_.seed + static_cast<std::uint64_t>(run));
      ev.machine_s += r.cycle_time_s;
      const ContourScore one = score(p, r, nullptr);
      s2 += one.rms_mm * one.rms_mm * static_cast<double>(one.samples);
      s.samples += one.samples;
      if (run == 0 || one.max_mm > s.max_mm) {
        s.max_mm = one.max_mm;
        s.max_at_s = one.max_at_s;
        s.max_at_x_mm = one.max_at_x_mm;
        s.max_at_y_mm = one.max_at_y_mm;
        s.max_at_line = one.max_at_line;
      }
      s.itae_mm_s2 += one.itae_mm_s2 / options_.noise_runs;
      s.saturation_share = std::max(s.saturation_share, one.saturation_share);
      s.max_following_error_mm = std::max(s.max_following_error_mm, one.max_following_error_mm);
      if (one.faulted && !s.faulted) s.fault = one.fault;
      s.faulted = s.faulted || one.faulted;
    }
    s.rms_mm = s.samples ? std::sqrt(s2 / static_cast<double>(s.samples)) : 0.0;
    s.contour = contours_[ci].spec;
    sum2 += s2;
    n_all += s.samples;
    ev.max_mm = std::max(ev.max_mm, s.max_mm);
    ev.itae_mm_s2 += s.itae_mm_s2;
    ev.saturation_share = std::max(ev.saturation_share, s.saturation_share);
    ev.max_following_error_mm = std::max(ev.max_following_error_mm, s.max_following_error_mm);
    ev.faulted = ev.faulted || s.faulted;
    ev.contours.push_back(std::move(s));
  }
  ev.rms_mm = n_all ? std::sqrt(sum2 / static_cast<double>(n_all)) : 0.0;

  ev.overshoot = std::numeric_limits<double>::quiet_NaN();
  ev.margin_residual = std::numeric_limits<double>::quiet_NaN();
  if (!options_.constraints) return ev;
  // Step tests: nominal plant (overshoot), plant with the gain margin (residual wobble).
  for (int margin = 0; margin < 2; ++margin) {
    auto ctl = control::make_controller(kind, gains, plant_);
    const executor::ExecutionResult r =
        run_prepared(step_->job, step_->trajectories, margin ? margin_machine_ : machine_, *ctl, options_.seed);
    ev.machine_s += r.cycle_time_s;
    const bool faulted = !r.summary.done();
    double overshoot = 0.0;
    double lo[2] = {inf, inf}, hi[2] = {-inf, -inf};
    const double t_tail = options_.step_window_s * 2.0 / 3.0;
    double t0 = -1.0;
    for (const executor::TraceSample& ts : r.trace) {
      if (ts.step != 0) continue;
      if (t0 < 0) t0 = ts.t_s;
      const Eigen::Vector2d pos = !std::isnan(ts.true_mm.x()) ? ts.true_mm : ts.measured_mm;
      for (int a = 0; a < 2; ++a) {
        const double y = (pos[a] - step_->step_from[a]) / options_.step_mm;  // 0 -> 1
        overshoot = std::max(overshoot, y - 1.0);
        if (ts.t_s - t0 >= t_tail) {
          lo[a] = std::min(lo[a], y);
          hi[a] = std::max(hi[a], y);
        }
      }
    }
    if (margin == 0) {
      ev.overshoot = faulted ? inf : overshoot;
    } else {
      double wobble = 0.0;
      for (int a = 0; a < 2; ++a) wobble = std::max(wobble, hi[a] - lo[a]);
      ev.margin_residual = faulted || !std::isfinite(wobble) ? inf : wobble;
    }
  }
  return ev;
}

}  // namespace machplan::tuning
