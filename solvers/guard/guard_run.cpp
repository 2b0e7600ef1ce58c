#include "solvers/guard/guard_run.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <random>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/executor/executor.h"
#include "engine/geometry/offset.h"
#include "engine/motion/feed_planner.h"
#include "engine/programs/dxf.h"
#include "models/cutting/machine_config.h"
#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"

namespace machplan::guard {

const char* to_string(OperatorSpec::Kind k) {
  switch (k) {
    case OperatorSpec::Kind::script: return "script";
    case OperatorSpec::Kind::random: return "random";
    case OperatorSpec::Kind::joystick: return "joystick";
    case OperatorSpec::Kind::keys: return "keys";
    case OperatorSpec::Kind::panel: return "panel";
  }
  return "?";
}

OperatorSpec operator_from_string(const std::string& text) {
  OperatorSpec s;
  const auto bad = [&](const std::string& why) {
    return InputError::field("op", fmt::format("'{}': {} (give script.csv, random:N, joystick[:DEVICE] or keys)",
                                               excerpt(text), why));
  };
  if (text.empty()) throw bad("empty");
  if (text == "keys") {
    s.kind = OperatorSpec::Kind::keys;
  } else if (text == "joystick" || text.rfind("joystick:", 0) == 0) {
    s.kind = OperatorSpec::Kind::joystick;
    s.path = text.size() > 9 ? text.substr(9) : "";
  } else if (text.rfind("random:", 0) == 0) {
    s.kind = OperatorSpec::Kind::random;
    const std::string n = text.substr(7);
    std::size_t used = 0;
    long v = 0;
    try {
      v = std::stol(n, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (n.empty() || used != n.size()) throw bad("N is not a whole number");
    if (v < 1 || v > 100000) throw bad("N must be in 1 .. 100000");
    s.strokes = static_cast<int>(v);
  } else {
    s.kind = OperatorSpec::Kind::script;
    s.path = text;
  }
  return s;
}

void GuardRunOptions::validate() const {
  require_field(std::isfinite(region.tool_radius_mm) && region.tool_radius_mm >= 0 && region.tool_radius_mm <= 1000,
                "region.tool_radius_mm", region.tool_radius_mm, "mm must be in [0, 1000]");
  require_field(std::isfinite(guard.tolerance_mm) && guard.tolerance_mm >= 0 && guard.tolerance_mm <= 100,
                "guard.tolerance_mm", guard.tolerance_mm, "mm must be in [0, 100]");
  // Named in ms, as people give a PC link's round trip.
  require_field(std::isfinite(guard.latency_s) && guard.latency_s >= 0 && guard.latency_s <= 1, "guard.latency_s",
                guard.latency_s * 1000, "ms must be in [0, 1000]");
  require_field(std::isfinite(feed_mm_per_s) && feed_mm_per_s > 0 && feed_mm_per_s <= 1000, "feed_mm_per_s",
                feed_mm_per_s, "mm/s must be in (0, 1000]");
  require_field(std::isfinite(finish_feed_mm_per_s) && finish_feed_mm_per_s >= 0 && finish_feed_mm_per_s <= 1000,
                "finish_feed_mm_per_s", finish_feed_mm_per_s, "mm/s must be in [0, 1000] (0: the feed)");
  require_field(std::isfinite(finish_allowance_mm) && finish_allowance_mm >= 0 && finish_allowance_mm <= 10,
                "finish_allowance_mm", finish_allowance_mm, "mm must be in [0, 10]");
  require_field(std::isfinite(max_session_s) && max_session_s > 0 && max_session_s <= 86400, "max_session_s",
                max_session_s, "s must be in (0, 86400]");
  require_field(backend != "hal" || op.kind != OperatorSpec::Kind::random, "backend", backend,
                "cannot drive the random operator: its strokes each start somewhere else, which a real machine "
                "cannot; use a script, joystick or keys");
  validate_member("region", region);
  validate_member("guard", guard);
}

namespace {


// What every session shares.
struct Rig {
  cutting::MachineConfig machine;
  const ProhibitedRegion* region = nullptr;
  GuardRunOptions o;
  double jog_speed = 0.0;
  std::vector<std::string>* warnings = nullptr;
  Termination* termination = nullptr;
  const GuardLink* link = nullptr;  // a panel's, or null
  const int* strokes = nullptr;     // the result's count, for the panel's live view
  long stops = 0, failsafe = 0, emergency = 0;

  // The panel's E-stop, and the state it shows (GuardLink).
  void link_inputs(hardware::OperatorInputs& in) const {
    if (link && link->estop && link->estop->load(std::memory_order_acquire)) in.estop = true;
  }
  void publish(GuardLive::Phase phase, double t, const Eigen::Vector2d& p, bool holding) const {
    if (!link || !link->live) return;
    GuardLive g;
    g.phase = phase;
    g.t_s = t;
    g.position_mm = p;
    g.distance_mm = region->query(p).signed_distance_mm;
    g.guard_holding = holding;
    g.strokes = strokes ? *strokes : 0;
    link->live->publish(g);
  }

  // A machine session on the rig's machine: the simulated table from `start_mm`, seeded.
  session::MachineSessionOptions session(executor::Mode mode, std::uint64_t seed, bool realtime) const {
    session::MachineSessionOptions so;
    so.machine_config = machine;
    so.backend.name = o.backend;
    so.backend.sim.seed = seed;
    so.backend.sim.realtime = realtime;
    so.executor.mode = mode;
    so.executor.jog.speed_mm_per_s = jog_speed;
    so.executor.record_trace = mode != executor::Mode::jog;
    return so;
  }
};

// One jog session under the guard from `start`. Before every tick `step(t, true_mm, guard,
// inputs)` sets the operator's inputs and returns false to end the manual part (cycle start).
// Returns the session's length, s; `end_mm` gets the final true position.
template <class Step>
double jog_session(Rig& rig, const Eigen::Vector2d& start, std::uint64_t seed, bool realtime, Step&& step,
                   Eigen::Vector2d& end_mm) {
  session::MachineSession ms(rig.session(executor::Mode::jog, seed, realtime));
  hardware::Backend& be = ms.backend(start);
  executor::Guard guard(*rig.region, rig.o.guard, ms.setup(), be.period_s());
  motion::Job job;
  job.source = "operator";
  job.start_mm = start;
  session::MachineSession::RunHooks hooks;
  hooks.filter = &guard;
  hooks.termination = rig.termination;
  const std::unique_ptr<executor::Session> s = ms.start(job, {}, hooks);
  hardware::OperatorInputs in{};
  const double dt = be.period_s();
  double t = 0.0;
  bool ending = false;
  long after_end = 0;
  Eigen::Vector2d p = start;
  for (;;) {
    if (!ending && !step(t, p, guard, in)) {
      ending = true;
      in = {};
      in.cycle_start = true;
    }
    rig.link_inputs(in);
    ms.operator_inputs().set(in);
    if (!s->tick()) break;
    t += dt;
    if (!be.true_position(p)) p = guard.setpoint_mm();
    rig.publish(GuardLive::Phase::roughing, t, p, guard.holding());
    if (ending && ++after_end > 20000) break;  // the controlled stop takes far less
  }
  const executor::ExecutionResult r = s->finish();
  for (const auto& f : r.faults)
    if (f.kind != executor::FaultKind::stop_requested && rig.warnings)
      rig.warnings->push_back(fmt::format("session at ({:.2f}, {:.2f}): {}", start.x(), start.y(), f.message));
  rig.stops += guard.counters().stops_sent;
  rig.failsafe += guard.counters().failsafe_ticks;
  rig.emergency += guard.counters().emergency_ticks;
  end_mm = p;
  return t;
}

// Splits the operator's pushes into attempts and measures them (see the header).
class Tracker {
 public:
  Tracker(const ProhibitedRegion& region, double tolerance_mm, GuardRunResult& out)
      : region_(region), T_(tolerance_mm), out_(out) {}

  void push_start(double t, const Eigen::Vector2d& p, const Eigen::Vector2d& aim, double speed, long limited_now) {
    close();
    open_ = true;
    cur_ = Attempt{};
    cur_.start_mm = p;
    cur_.aim_mm = aim;
    cur_.speed_mm_per_s = speed;
    cur_.closest_mm = kInf;
    t0_ = t;
    limited0_ = limited_now;
    engaged_ = false;
    n_ = 0;
    ++out_.strokes;
  }

  void sample(double t, const Eigen::Vector2d& p, long limited_now) {
    if (!open_) return;
    const double d = region_.query(p).signed_distance_mm;
    if (d < cur_.closest_mm) {
      cur_.closest_mm = d;
      cur_.closest_at_mm = p;
    }
    if (d <= T_ || limited_now != limited0_) engaged_ = true;
    if (n_++ % 10 == 0) cur_.path_mm.push_back(p);
    cur_.time_s = t - t0_;
  }

  // A new session starts: the guard's counters restart.
  void rebase(long limited_now) { limited0_ = limited_now; }

  void close() {
    if (!open_) return;
    open_ = false;
    if (!engaged_ || !std::isfinite(cur_.closest_mm)) return;
    cur_.index = static_cast<int>(out_.attempts.size());
    cur_.success = cur_.closest_mm >= -1e-6;
    cur_.invasion_mm = std::max(0.0, -cur_.closest_mm);
    cur_.undercut_mm = cur_.success ? std::max(0.0, cur_.closest_mm) : 0.0;
    out_.attempts.push_back(std::move(cur_));
  }

 private:
  const ProhibitedRegion& region_;
  double T_;
  GuardRunResult& out_;
  bool open_ = false, engaged_ = false;
  Attempt cur_;
  double t0_ = 0.0;
  long limited0_ = 0;
  long n_ = 0;
};

// A random point of the allowed region whose distance to the boundary lies in [lo, hi].
Eigen::Vector2d random_start(const ProhibitedRegion& region, std::mt19937_64& rng, double lo, double hi) {
  Eigen::AlignedBox2d box;
  for (const Contour& c : region.boundary()) box.extend(bounding_box(c));
  box.min() -= Eigen::Vector2d::Constant(hi);
  box.max() += Eigen::Vector2d::Constant(hi);
  std::uniform_real_distribution<double> ux(box.min().x(), box.max().x()), uy(box.min().y(), box.max().y());
  for (int k = 0; k < 100000; ++k) {
    const Eigen::Vector2d p(ux(rng), uy(rng));
    const double d = region.query(p).signed_distance_mm;
    if (d >= lo && d <= hi) return p;
  }
  throw InputError::field("op", fmt::format("no place {:.1f} .. {:.1f} mm from the prohibited region to start a stroke "
                                           "from",
                                           lo, hi));
}

// A point uniformly along the boundary's length.
Eigen::Vector2d random_boundary_point(const ProhibitedRegion& region, std::mt19937_64& rng) {
  double total = 0;
  for (const Contour& c : region.boundary()) total += perimeter(c);
  double s = std::uniform_real_distribution<double>(0.0, total)(rng);
  for (const Contour& c : region.boundary()) {
    const double p = perimeter(c);
    if (s <= p) return point_at_length(c, s);
    s -= p;
  }
  return point_at_length(region.boundary().back(), 0.0);
}

// Where an operator aiming at `aim` (a boundary point) starts from: `lo` .. `hi` mm away from
// it, within 60 degrees of the boundary's normal there (an operator roughing toward the profile
// pushes at it, not along it), in the allowed region at least `lo` / 2 from the boundary.
// Falls back to any place at that distance when the neighbourhood has no room (a narrow pocket).
Eigen::Vector2d approach_start(const ProhibitedRegion& region, std::mt19937_64& rng, const Eigen::Vector2d& aim, double lo,
                               double hi) {
  const Eigen::Vector2d n = region.query(aim).normal;
  std::uniform_real_distribution<double> angle(-M_PI / 3, M_PI / 3), dist(lo, hi);
  for (int k = 0; k < 200; ++k) {
    const double a = angle(rng), r = dist(rng);
    const Eigen::Vector2d dir(std::cos(a) * n.x() - std::sin(a) * n.y(), std::sin(a) * n.x() + std::cos(a) * n.y());
    const Eigen::Vector2d p = aim + r * dir;
    if (region.query(p).signed_distance_mm >= 0.5 * lo) return p;
  }
  return random_start(region, rng, lo, hi);
}

void set_stick(hardware::OperatorInputs& in, const Eigen::Vector2d& dir, double speed, double jog_speed) {
  const double k = std::min(1.0, speed / jog_speed);
  in.jog[0] = std::clamp(dir.x() * k, -1.0, 1.0);
  in.jog[1] = std::clamp(dir.y() * k, -1.0, 1.0);
  in.cycle_start = false;
}

// The contour's spans as one path that starts and ends at the point of `c` nearest to `p`.
std::vector<Segment> contour_from(const Contour& c, const Eigen::Vector2d& p) {
  const ContourPoint cp = closest_point(c, p);
  const std::size_t n = c.size(), k = cp.span;
  const Segment sk = c.span(k);
  const double t = parameter_at(sk, cp.point);
  const double sweep = sk.is_arc() ? sk.sweep : 0.0;
  const Eigen::Vector2d a = c.vertices()[k], b = c.vertices()[(k + 1) % n];
  std::vector<Segment> out;
  const auto add = [&out](const Segment& s) {
    if (length(s) > 1e-6) out.push_back(s);
  };
  add(make_segment(cp.point, b, std::tan(sweep * (1 - t) / 4)));
  for (std::size_t i = 1; i < n; ++i) add(c.span((k + i) % n));
  add(make_segment(a, cp.point, std::tan(sweep * t / 4)));
  // make_segment keeps the given end points, so the path is contiguous; close exactly.
  if (!out.empty()) out.back().end = out.front().start;
  return out;
}

motion::Stretch stretch_of(std::vector<Segment> segs, double feed) {
  motion::Stretch s;
  s.segments = std::move(segs);
  s.feed_mm_per_s.assign(s.segments.size(), feed);
  s.source_lines.assign(s.segments.size(), 0);
  return s;
}

double distance_to_path(const std::vector<Segment>& path, const Eigen::Vector2d& p) {
  double best = kInf;
  for (const Segment& s : path) best = std::min(best, (closest_point(s, p) - p).norm());
  return best;
}

// The automatic mode: from `from`, touch the nearest boundary contour and contour it whole
// (first at the allowance when one is asked), planned and executed like any program.
void finish_profile(Rig& rig, const Eigen::Vector2d& from, GuardRunResult& r) {
  const ProhibitedRegion& region = *rig.region;
  const RegionDistance q = region.query(from);
  const Contour& final_contour = region.boundary()[q.contour];
  const double feed = rig.o.finish_feed_mm_per_s > 0 ? rig.o.finish_feed_mm_per_s : rig.o.feed_mm_per_s;

  struct Pass {
    double allowance;
    std::vector<Segment> path;
  };
  std::vector<Pass> passes;
  Eigen::Vector2d at = from;
  if (rig.o.finish_allowance_mm > 0) {
    // Away from the prohibited region: grow what the contour encloses when that is the
    // region (outside machining, a counter-clockwise limit), shrink it otherwise.
    const bool ccw = orientation(final_contour) == Orientation::ccw;
    const bool outside = region.options().side == MachiningSide::outside;
    const double d = (ccw == outside) ? rig.o.finish_allowance_mm : -rig.o.finish_allowance_mm;
    const OffsetResult off = offset_contour(final_contour, d);
    if (off.contours.empty()) {
      r.warnings.push_back(fmt::format("the over-dimension pass at {} mm vanishes; only the final pass runs", rig.o.finish_allowance_mm));
    } else {
      std::size_t best = 0;
      double bd = kInf;
      for (std::size_t i = 0; i < off.contours.size(); ++i) {
        const double dd = distance(off.contours[i], from);
        if (dd < bd) bd = dd, best = i;
      }
      passes.push_back({rig.o.finish_allowance_mm, contour_from(off.contours[best], from)});
      at = passes.back().path.front().start;
    }
  }
  passes.push_back({0.0, contour_from(final_contour, at)});

  motion::Job job;
  job.source = "finishing";
  job.start_mm = from;
  std::vector<std::size_t> pass_step(passes.size());
  Eigen::Vector2d cur = from;
  for (std::size_t i = 0; i < passes.size(); ++i) {
    const Eigen::Vector2d target = passes[i].path.front().start;
    if ((target - cur).norm() > 1e-6) {
      job.stretches.push_back(stretch_of({make_segment(cur, target, 0.0)}, feed));
      job.steps.push_back({motion::Step::Kind::move, 0, job.stretches.size() - 1, 0.0});
    }
    job.stretches.push_back(stretch_of(passes[i].path, feed));
    job.steps.push_back({motion::Step::Kind::move, 0, job.stretches.size() - 1, 0.0});
    pass_step[i] = job.steps.size() - 1;
    cur = passes[i].path.back().end;
  }
  const motion::PlannerOptions po = motion::planner_options_for(rig.machine);
  executor::Trajectories trajs(job.steps.size());
  for (std::size_t i = 0; i < job.steps.size(); ++i) trajs[i] = motion::plan_stretch(job.stretches[job.steps[i].stretch], po);

  const bool paced = rig.link && rig.link->paced_finish;
  session::MachineSession ms(rig.session(executor::Mode::planned, rig.o.seed + 7919, paced));
  session::MachineSession::RunHooks hooks;
  hooks.termination = rig.termination;
  const std::unique_ptr<executor::Session> run = ms.start(job, trajs, hooks);
  hardware::OperatorInputs in{};
  for (double t = 0.0;; t += ms.setup().servo_period_s) {
    rig.link_inputs(in);
    if (rig.link) ms.operator_inputs().set(in);
    if (!run->tick()) break;
    Eigen::Vector2d p;
    if (!ms.backend().true_position(p)) p = ms.live().read_single().measured_mm;
    rig.publish(GuardLive::Phase::finishing, t, p, false);
  }
  const executor::ExecutionResult res = run->finish();
  r.finishing_time_s = res.cycle_time_s;

  for (std::size_t i = 0; i < passes.size(); ++i) {
    FinishPass fp;
    fp.allowance_mm = passes[i].allowance;
    fp.completed = res.steps_completed > static_cast<int>(pass_step[i]);
    if (!fp.completed && !res.faults.empty()) fp.fault = res.faults.front().message;
    double t0 = kInf, t1 = 0, sum2 = 0;
    long n = 0;
    for (const executor::TraceSample& s : res.trace) {
      if (s.step != static_cast<int>(pass_step[i]) || !std::isfinite(s.true_mm.x())) continue;
      const double dev = passes[i].allowance > 0 ? distance_to_path(passes[i].path, s.true_mm)
                                                 : std::abs(region.query(s.true_mm).signed_distance_mm);
      fp.max_deviation_mm = std::max(fp.max_deviation_mm, dev);
      if (passes[i].allowance == 0) fp.max_from_profile_mm = fp.max_deviation_mm;
      sum2 += dev * dev;
      if (n % 10 == 0) fp.path_mm.push_back(s.true_mm);
      ++n;
      t0 = std::min(t0, s.t_s);
      t1 = std::max(t1, s.t_s);
    }
    fp.samples = static_cast<std::size_t>(n);
    fp.rms_deviation_mm = n ? std::sqrt(sum2 / n) : 0.0;
    fp.time_s = n ? t1 - t0 : 0.0;
    r.finish.push_back(std::move(fp));
  }
}

}  // namespace

namespace {

// Seeded random strokes toward random boundary points (the paper's repeated attempts).
void rough_random(Rig& rig, const ProhibitedRegion& region, Tracker& tracker, std::mt19937_64& rng, Eigen::Vector2d& last,
                  GuardRunResult& r, Progress* progress) {
  const GuardRunOptions& options = rig.o;
  const double T = options.guard.tolerance_mm;
  const double L = options.guard.latency_s;
  rig.jog_speed = options.feed_mm_per_s;
  const double v = options.feed_mm_per_s;
  const double lo = T + 2.0 + 0.05 * v, hi = T + 12.0 + 0.05 * v;
  for (int i = 0; i < options.op.strokes; ++i) {
    const Eigen::Vector2d aim = random_boundary_point(region, rng);
    const Eigen::Vector2d start = approach_start(region, rng, aim, lo, hi);
    const double delay = std::uniform_real_distribution<double>(0.0, 0.2 + L)(rng);
    const Eigen::Vector2d dir = (aim - start).normalized();
    const double push_s = (aim - start).norm() / v + 0.5;
    bool pushed = false, released = false;
    double released_at = 0.0, rest_since = -1.0;
    tracker.rebase(0);
    r.roughing_time_s += jog_session(
        rig, start, options.seed * 1000003u + static_cast<std::uint64_t>(i), false,
        [&](double t, const Eigen::Vector2d& p, const executor::Guard& g, hardware::OperatorInputs& in) {
          tracker.sample(t, p, g.counters().limited_ticks);
          if (t < delay) {
            in = {};
            return true;
          }
          if (!pushed) {
            tracker.push_start(t, p, aim, v, g.counters().limited_ticks);
            pushed = true;
          }
          if (!released) {
            const bool at_rest = g.holding() && g.setpoint_velocity_mm_per_s().norm() < 1e-9;
            if (at_rest && rest_since < 0) rest_since = t;
            if (!at_rest) rest_since = -1.0;
            if (t - delay > push_s || (rest_since >= 0 && t - rest_since > 0.05)) {
              released = true;
              released_at = t;
            }
          }
          if (released) {
            in = {};
            return t - released_at < 0.15;
          }
          set_stick(in, dir, v, rig.jog_speed);
          return true;
        },
        last);
    tracker.close();
  }
}

// A scripted operator (engine/hardware/operator_input.h).
void rough_script(Rig& rig, const ProhibitedRegion& region, Tracker& tracker, Eigen::Vector2d& last, GuardRunResult& r,
                  Progress* progress) {
  const GuardRunOptions& options = rig.o;
  const hardware::OperatorScript script = hardware::read_operator_script(options.op.path);
  if (!script.start_mm)
    throw InputError(script.source, script.rows.front().line, "the script has no start row (start,X,Y) before its first data row");
  if (region.prohibited(*script.start_mm))
    throw InputError(script.source, 0,
                     fmt::format("the start ({:.3f}, {:.3f}) lies in the prohibited region", script.start_mm->x(), script.start_mm->y()));
  double top = options.feed_mm_per_s;
  for (const auto& row : script.rows) top = std::max(top, row.speed_mm_per_s);
  rig.jog_speed = top;
  const hardware::ScriptRow* prev = nullptr;
  r.roughing_time_s += jog_session(
      rig, *script.start_mm, options.seed, false,
      [&](double t, const Eigen::Vector2d& p, const executor::Guard& g, hardware::OperatorInputs& in) {
        tracker.sample(t, p, g.counters().limited_ticks);
        const hardware::ScriptRow* row = script.at(t);
        in = {};
        if (!row) return true;
        const double a = row->direction_deg * M_PI / 180.0;
        const Eigen::Vector2d dir(std::cos(a), std::sin(a));
        if (row != prev && row->speed_mm_per_s > 0)
          tracker.push_start(t, p, p + dir * 10.0, row->speed_mm_per_s, g.counters().limited_ticks);
        prev = row;
        if (row->speed_mm_per_s > 0) set_stick(in, dir, row->speed_mm_per_s, rig.jog_speed);
        return t < script.end_s() && t < options.max_session_s;
      },
      last);
  tracker.close();
}

// A person at a joystick or the keyboard, paced to the wall clock.
void rough_live(Rig& rig, const ProhibitedRegion& region, Tracker& tracker, std::mt19937_64& rng, Eigen::Vector2d& last,
                GuardRunResult& r) {
  const GuardRunOptions& options = rig.o;
  const double T = options.guard.tolerance_mm;
  const bool js = options.op.kind == OperatorSpec::Kind::joystick;
  // A device of our own, or the stick a panel writes (GuardLink).
  std::optional<hardware::LiveOperator> device;
  if (options.op.kind != OperatorSpec::Kind::panel)
    device.emplace(js ? hardware::LiveOperator::Kind::joystick : hardware::LiveOperator::Kind::keys, options.op.path,
                   options.feed_mm_per_s);
  const auto read_stick = [&] {
    return device ? device->read() : hardware::LiveOperator::unpack(rig.link->stick->load(std::memory_order_acquire));
  };
  rig.jog_speed = options.feed_mm_per_s;
  const Eigen::Vector2d start = random_start(region, rng, T + 10.0, T + 30.0);
  bool was_pushing = false;
  r.roughing_time_s += jog_session(
      rig, start, options.seed, true,
      [&](double t, const Eigen::Vector2d& p, const executor::Guard& g, hardware::OperatorInputs& in) {
        tracker.sample(t, p, g.counters().limited_ticks);
        const hardware::StickState st = read_stick();
        const Eigen::Vector2d dir(st.x, st.y);
        const bool pushing = dir.norm() > 0.02 && st.speed_mm_per_s > 0;
        if (pushing && !was_pushing)
          tracker.push_start(t, p, p + dir.normalized() * 10.0, st.speed_mm_per_s, g.counters().limited_ticks);
        was_pushing = pushing;
        in = {};
        const double k = std::min(1.0, st.speed_mm_per_s / rig.jog_speed);
        in.jog[0] = std::clamp(st.x * k, -1.0, 1.0);
        in.jog[1] = std::clamp(st.y * k, -1.0, 1.0);
        if (st.quit) r.quit_by_operator = true;
        return !st.quit && t < options.max_session_s;
      },
      last);
  tracker.close();
}

// Successes, invasions and under-cut over the attempts.
void count_attempts(Rig& rig, GuardRunResult& r) {
  r.guard_stops = rig.stops;
  r.guard_failsafe_ticks = rig.failsafe;
  r.guard_emergency_ticks = rig.emergency;
  double sum_u = 0;
  for (const Attempt& a : r.attempts) {
    if (a.success) {
      ++r.successes;
      sum_u += a.undercut_mm;
      r.max_undercut_mm = std::max(r.max_undercut_mm, a.undercut_mm);
    } else {
      ++r.invasions;
      r.max_invasion_mm = std::max(r.max_invasion_mm, a.invasion_mm);
    }
  }
  r.mean_undercut_mm = r.successes ? sum_u / r.successes : 0.0;
}

}  // namespace

namespace {

// How the session ended, and its reports.
void summarize(GuardRunResult& r, const Termination& termination) {
  Summary& s = r.summary;
  s.status = termination.ended() ? status_of(termination.reason()) : Status::done;
  if (!s.done()) s.message = fmt::format("{} after {} strokes", termination.describe(), r.strokes);
  s.brief = fmt::format("guard on {}: {}{} attempts, {} successes ({:.1f} %), {} invasions, mean under-cut {:.2f} mm",
                        r.profile_source, s.done() ? "" : fmt::format("{} ({}); ", to_string(s.status), s.message),
                        r.attempts.size(), r.successes, r.success_percent(), r.invasions, r.mean_undercut_mm);
  s.full = r.report();
  if (!s.done()) s.full += fmt::format("  {}: {}; the figures above count the attempts made until then\n", to_string(s.status), s.message);
}

GuardRunResult guard_session(const std::vector<Contour>& profile, const std::string& source, const GuardRunOptions& options,
                             std::vector<std::string> warnings, Termination& termination, Progress* progress,
                             const GuardLink* link) {
  options.validate();
  if (options.op.kind == OperatorSpec::Kind::panel && !(link && link->stick))
    throw InputError::field("op", "the panel operator needs a panel's stick (GuardLink::stick)");
  GuardRunResult r;
  r.warnings = std::move(warnings);
  r.profile_source = source;
  r.options = options;
  r.profile = profile;
  Rig rig;
  rig.o = options;
  rig.machine = cutting::load_machine(cutting::find_machine(options.machine));
  rig.termination = &termination;
  rig.link = link;
  rig.strokes = &r.strokes;
  r.machine = rig.machine.name;
  rig.warnings = &r.warnings;
  const ProhibitedRegion region = ProhibitedRegion::build(profile, options.region);
  rig.region = &region;
  r.boundary = region.boundary();
  for (const OffsetProblem& p : region.problems()) r.warnings.push_back(p.message);

  Tracker tracker(region, options.guard.tolerance_mm, r);
  Eigen::Vector2d last = Eigen::Vector2d::Zero();
  std::mt19937_64 rng(options.seed);
  // Roughing is most of the work: 0 .. 0.9, finishing the rest.
  Progress roughing(progress, 0.0, options.finish ? 0.9 : 1.0);
  switch (options.op.kind) {
    case OperatorSpec::Kind::random: rough_random(rig, region, tracker, rng, last, r, &roughing); break;
    case OperatorSpec::Kind::script: rough_script(rig, region, tracker, last, r, &roughing); break;
    case OperatorSpec::Kind::joystick:
    case OperatorSpec::Kind::keys:
    case OperatorSpec::Kind::panel: rough_live(rig, region, tracker, rng, last, r); break;
  }
  count_attempts(rig, r);
  const bool stopped = termination.should_end();
  if (options.finish && !stopped) finish_profile(rig, last, r);
  report_progress(progress, 1.0);
  rig.publish(GuardLive::Phase::done, 0.0, last, false);
  summarize(r, termination);
  return r;
}

}  // namespace

GuardRunResult run_guard(const std::vector<Contour>& profile, const std::string& source, const GuardRunOptions& options,
                         Termination& termination, Progress* progress, const GuardLink* link) {
  return guard_session(profile, source, options, {}, termination, progress, link);
}

std::vector<Contour> read_guard_profile(const std::string& dxf_path, std::vector<std::string>& warnings) {
  const ProfileReadResult pr = read_dxf_profile(dxf_path);
  for (const ProfileProblem& p : pr.problems)
    if (p.severity == ProfileProblem::Severity::error) throw InputError(dxf_path, 0, p.message);
  if (pr.contours.empty()) throw InputError(dxf_path, 0, "no closed contour in the drawing");
  std::vector<Contour> profile;
  for (const ProfileContour& c : pr.contours) profile.push_back(c.contour);
  for (const ProfileProblem& p : pr.problems) warnings.insert(warnings.begin(), p.message);
  return profile;
}

GuardRunResult run_guard_file(const std::string& dxf_path, const GuardRunOptions& options, Termination& termination,
                              Progress* progress, const GuardLink* link) {
  options.validate();
  std::vector<std::string> warnings;
  std::vector<Contour> profile = read_guard_profile(dxf_path, warnings);
  return guard_session(profile, dxf_path, options, std::move(warnings), termination, progress, link);
}

std::string GuardRunResult::report() const {
  std::string s;
  const auto& o = options;
  s += fmt::format("guard: {} on {} ({} machining, tool radius {} mm, {} offset)\n", profile_source, machine,
                   to_string(o.region.side), o.region.tool_radius_mm, to_string(o.region.method));
  s += fmt::format("  strategy {}, tolerance T {} mm, link latency {} ms, feed {} mm/s, operator {}\n",
                   executor::to_string(o.guard.strategy), o.guard.tolerance_mm, o.guard.latency_s * 1000, o.feed_mm_per_s,
                   to_string(o.op.kind));
  for (const std::string& w : warnings) s += fmt::format("  warning: {}\n", w);
  s += "  attempt  start (mm)            closest (mm)  result     under-cut (mm)  time (s)\n";
  for (const Attempt& a : attempts)
    s += fmt::format("  {:7d}  ({:8.2f}, {:8.2f})  {:12.3f}  {:9}  {:14.3f}  {:8.2f}\n", a.index + 1, a.start_mm.x(),
                     a.start_mm.y(), a.closest_mm, a.success ? "success" : "INVASION", a.undercut_mm, a.time_s);
  s += fmt::format("  attempts {}, successes {} ({:.2f} %), invasions {}, max invasion {:.3f} mm\n", attempts.size(), successes,
                   success_percent(), invasions, max_invasion_mm);
  s += fmt::format("  under-cut over the successes: mean {:.3f} mm, max {:.3f} mm; roughing time {:.2f} s ({} strokes)\n",
                   mean_undercut_mm, max_undercut_mm, roughing_time_s, strokes);
  if (guard_failsafe_ticks > 0) s += fmt::format("  the guard held the axes for a late or lost link in {} ticks\n", guard_failsafe_ticks);
  for (const FinishPass& f : finish) {
    s += fmt::format("  finishing pass {}: {}, {:.2f} s, deviation from its path max {:.4f} mm, rms {:.4f} mm\n",
                     f.allowance_mm > 0 ? fmt::format("at +{} mm", f.allowance_mm) : std::string("on the offset profile"),
                     f.completed ? "completed" : "NOT completed (" + f.fault + ")", f.time_s, f.max_deviation_mm,
                     f.rms_deviation_mm);
  }
  return s;
}

}  // namespace machplan::guard
