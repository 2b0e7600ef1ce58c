#include "engine/executor/planned_source.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::executor {

void PlannedSource::prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) {
  ctx_ = ctx;
  const motion::Job& job = *ctx.job;
  const Trajectories& trajs = *ctx.trajectories;
  const auto fail = [&](int line, const std::string& what) { throw InputError(job.source, line, what); };
  if (trajs.size() != job.steps.size())
    fail(0, fmt::format("{} trajectories for {} steps: planned mode needs one per step", trajs.size(), job.steps.size()));
  Eigen::Vector2d at = start_mm;
  estimate_s_ = 0.0;
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const motion::Step& st = job.steps[i];
    if (st.kind != motion::Step::Kind::move) continue;
    const motion::Trajectory* tr = trajs[i].get();
    if (!tr) fail(st.source_line, fmt::format("move step {} has no trajectory", i));
    const Eigen::Vector2d end = job.stretches[st.stretch].segments.back().end;
    motion::Setpoint a, b;
    tr->sample(0.0, a);
    tr->sample(tr->duration_s(), b);
    if (!(std::isfinite(tr->duration_s()) && tr->duration_s() >= 0))
      fail(st.source_line, fmt::format("trajectory of step {} has duration {}", i, tr->duration_s()));
    if ((a.position_mm - at).norm() > 1e-3 || (b.position_mm - end).norm() > 1e-3)
      fail(st.source_line, fmt::format("trajectory of step {} runs ({:.4f}, {:.4f}) -> ({:.4f}, {:.4f}) but its "
                                       "stretch runs ({:.4f}, {:.4f}) -> ({:.4f}, {:.4f})",
                                       i, a.position_mm.x(), a.position_mm.y(), b.position_mm.x(), b.position_mm.y(),
                                       at.x(), at.y(), end.x(), end.y()));
    estimate_s_ += tr->duration_s() + 0.01;
    at = end;
  }
  hold_mm_ = start_mm;
  cur_ = nullptr;
  t_ = 0.0;
  const MachineSetup& m = *ctx.machine;
  TimeScaleLimits lim;
  lim.max_velocity_mm_per_s = Eigen::Vector2d::Constant(m.max_velocity_mm_per_s);
  lim.max_acceleration_mm_per_s2 = Eigen::Vector2d::Constant(m.max_acceleration_mm_per_s2);
  lim.max_jerk_mm_per_s3 = m.max_jerk_mm_per_s3;
  lim.period_s = ctx.period_s;
  scale_.configure(lim);
  scale_.reset(1.0);
  prepare_motion_times();
}

void PlannedSource::prepare_motion_times() {
  const motion::Job& job = *ctx_.job;
  from_step_.assign(job.steps.size() + 1, MotionTime{});
  motion::Setpoint at;
  for (std::size_t i = job.steps.size(); i-- > 0;) {
    MotionTime m = from_step_[i + 1];
    const motion::Step& st = job.steps[i];
    if (st.kind == motion::Step::Kind::move) {
      const motion::Trajectory& tr = *(*ctx_.trajectories)[i];
      const double T = tr.duration_s();
      if (job.stretches[st.stretch].rapid) {
        m.rapid_s += T;
      } else {
        m.feed_s += T;
        const int n = static_cast<int>(std::ceil(T / kCeilingSampleS));
        const double h = n > 0 ? T / n : 0.0;
        for (int j = 0; j < n; ++j) {
          const double t = (j + 0.5) * h;
          if (!(tr.cruise_left_s(t) > 0.0)) continue;
          tr.sample(t, at);
          const double c = scale_.speed_ceiling(at);
          if (c < 1.0 + kCeilingBin) continue;  // no faster than the plan here
          m.cruise_s[std::min(kCeilingBins - 1, static_cast<int>((c - 1.0) / kCeilingBin))] += h;
        }
      }
    }
    from_step_[i] = m;
  }
}

double PlannedSource::feed_time_s(const MotionTime& m, double rate) noexcept {
  if (rate <= 1.0) return m.feed_s / rate;  // below 100 % the whole plan slows down
  double t = m.feed_s;
  for (int b = 0; b < kCeilingBins; ++b) t -= m.cruise_s[b] - m.cruise_s[b] / std::min(rate, 1.0 + b * kCeilingBin);
  return t;
}

bool PlannedSource::motion_left_s(double feed_rate, double rapid_rate, double& feed_s, double& rapid_s) const noexcept {
  if (from_step_.empty()) return false;
  feed_rate = std::max(feed_rate, 1e-3);
  rapid_rate = std::max(rapid_rate, 1e-3);
  const std::size_t n = ctx_.job->steps.size();
  const MotionTime& after = from_step_[cur_ ? std::min(step_ + 1, n) : 0];
  feed_s = feed_time_s(after, feed_rate);
  rapid_s = after.rapid_s / rapid_rate;
  if (cur_ && !move_done() && step_ < n) {
    // The move under way: its share left, by plan time.
    const double T = cur_->duration_s();
    const double share = T > 0.0 ? std::clamp((T - t_) / T, 0.0, 1.0) : 0.0;
    const MotionTime& with = from_step_[step_];
    if (ctx_.job->stretches[ctx_.job->steps[step_].stretch].rapid)
      rapid_s += share * (with.rapid_s - after.rapid_s) / rapid_rate;
    else
      feed_s += share * (feed_time_s(with, feed_rate) - feed_time_s(after, feed_rate));
  }
  return true;
}

void PlannedSource::begin_move(std::size_t step, const Eigen::Vector2d& measured_mm) noexcept {
  measured_mm_ = measured_mm;
  enter_move(step);
  t_ = 0.0;
  pause_left_mm_ = pause_v_ = paused_mm_ = 0.0;
  scale_.reset(target_);  // the plan starts at rest: the rate takes its target at no cost
}

void PlannedSource::advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs&) noexcept {
  measured_mm_ = measured_mm;
  if (!cur_) return;
  if (pause_moving() && target_ == 0.0 && scale_.k() == 0.0) {
    step_paused();
    return;
  }
  t_ = next_time(scale_, t_);
}

double PlannedSource::next_time(TimeScale& scale, double t) const noexcept {
  if (target_ == 1.0 && scale.k() == 1.0 && scale.k_dot() == 0.0) return t + ctx_.period_s;  // as planned
  return t + scale.step(target_, *cur_, t);
}

void PlannedSource::step_paused() noexcept {
  const double dt = ctx_.period_s, a = kPausedAcceleration;
  const double top = ctx_.machine->torch.paused_motion_speed_mm_per_s;
  // The speed wanted: towards the distance asked, braking to be at rest where it ends; else
  // the operator's speed.
  double want = pause_jog_ * top;
  if (pause_left_mm_ != 0.0)
    want = std::copysign(std::min(top, std::sqrt(2.0 * a * std::abs(pause_left_mm_))), pause_left_mm_);
  pause_v_ += std::clamp(want - pause_v_, -a * dt, a * dt);
  if (pause_v_ == 0.0) return;
  const double dir = pause_v_ > 0 ? 1.0 : -1.0;
  double ds = std::abs(pause_v_) * dt;
  const bool to_distance = pause_left_mm_ != 0.0 && (pause_left_mm_ > 0) == (dir > 0);
  if (to_distance) ds = std::min(ds, std::abs(pause_left_mm_));
  bool crossed = false;
  const double moved = slide(dir, ds, crossed);
  paused_mm_ += dir * moved;
  if (pause_left_mm_ != 0.0) pause_left_mm_ -= dir * moved;
  // Done: the distance asked (within a micrometre), or the end of the path it may follow.
  const bool arrived = to_distance && std::abs(pause_left_mm_) <= 1e-6;
  const bool stuck = moved == 0.0 && !crossed;
  if (arrived || stuck) pause_left_mm_ = pause_v_ = 0.0;
  if (stuck) pause_jog_ = 0.0;  // at the end of the path: a held joystick must be let go
}

// Moves the path time `ds` mm along the path (dir: +1 on, -1 back) and into the neighbouring
// move at an end (`crossed`). Returns the distance moved.
double PlannedSource::slide(double dir, double ds, bool& crossed) noexcept {
  motion::Setpoint now, next;
  cur_->sample(t_, now);
  // Path time per mm: the plan's speed here (at least 1 mm/s: near the move's ends, where the
  // plan is at rest, the motion crawls there rather than jumping).
  const double t_new = std::clamp(t_ + dir * ds / std::max(now.velocity_mm_per_s.norm(), 1.0), 0.0, cur_->duration_s());
  cur_->sample(t_new, next);
  const double moved = (next.position_mm - now.position_mm).norm();
  t_ = t_new;
  const bool at_end = dir < 0 ? t_new == 0.0 : t_new == cur_->duration_s();
  if (at_end && moved < 1e-9) crossed = enter_neighbour(dir);
  return moved;
}

// At an end of the move: go on into the previous (dir < 0) or next move step, skipping the
// torch and dwell steps between. Within a cut, no further than its own moves.
bool PlannedSource::enter_neighbour(double dir) noexcept {
  const motion::Job& job = *ctx_.job;
  std::size_t j = step_;
  while (dir < 0 ? j > 0 : j + 1 < job.steps.size()) {
    j = dir < 0 ? j - 1 : j + 1;
    const motion::Step& st = job.steps[j];
    if (st.kind == motion::Step::Kind::move) {
      if (pause_within_cut_ && !job.stretches[st.stretch].cutting) return false;
      enter_move(j);
      t_ = dir < 0 ? cur_->duration_s() : 0.0;
      if (dir < 0) segment_ = stretch_->segments.empty() ? 0 : stretch_->segments.size() - 1;
      return true;
    }
    if (pause_within_cut_ && st.kind != motion::Step::Kind::dwell) return false;
  }
  return false;
}

// The path the setpoints follow: the planner's executed path (its corners blended within the
// path tolerance) when the trajectory has one. Given the programmed corner instead, a contour
// controller would pull the tool off the blend the setpoint is on, towards the sharp corner.
void PlannedSource::enter_move(std::size_t step) noexcept {
  step_ = step;
  cur_ = (*ctx_.trajectories)[step].get();
  const motion::Stretch* followed = cur_ ? cur_->followed_path() : nullptr;
  stretch_ = followed ? followed : &ctx_.job->stretches[ctx_.job->steps[step].stretch];
  segment_ = 0;
}

void PlannedSource::motion_now(Eigen::Vector2d& v, Eigen::Vector2d& a) const noexcept {
  if (!cur_) {
    v.setZero();
    a.setZero();
    return;
  }
  motion::Setpoint now;
  cur_->sample(t_, now);
  const double k = scale_.k(), kd = scale_.k_dot();
  v = now.velocity_mm_per_s * k;
  a = now.acceleration_mm_per_s2 * (k * k) + now.velocity_mm_per_s * kd;
}

double PlannedSource::path_distance_mm(const Eigen::Vector2d& p) const noexcept {
  if (!stretch_ || stretch_->segments.empty()) return 0.0;
  // The segment under the cursor and its neighbours: at a joint the point may be on either.
  const std::size_t n = stretch_->segments.size();
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = segment_ > 0 ? segment_ - 1 : 0; k < std::min(n, segment_ + 3); ++k)
    best = std::min(best, (closest_point(stretch_->segments[k], p) - p).norm());
  return best;
}

void PlannedSource::plan_slot(AheadSlot& s) const noexcept {
  s.t = next_time(s.scale, s.t);
  motion::Setpoint p;
  cur_->sample(std::min(s.t, cur_->duration_s()), p);
  s.mm = {p.position_mm[0], p.position_mm[1]};
}

int PlannedSource::plan_ahead(std::array<double, hardware::kAxes>* mm, int n) const noexcept {
  n = std::clamp(n, 0, static_cast<int>(ahead_.size()));
  if (pause_moving() || !cur_) ahead_n_ = 0;
  if (pause_moving()) return 0;  // the paused motion's own law: no plan
  if (!cur_) {
    for (int j = 0; j < n; ++j) mm[j] = {hold_mm_[0], hold_mm_[1]};
    return n;
  }
  // The periods to come as advance() will run them while the rate asked for stays as it is: a
  // copy of the time scale takes the same steps.
  const AheadSlot& first = ahead_[static_cast<std::size_t>(ahead_head_)];
  if (n > 0 && ahead_n_ == n && ahead_move_ == cur_ && ahead_target_ == target_ && first.t == t_ && first.scale.same_state(scale_)) {
    // The source is where the plan put it one period ago: its first period is now, the rest
    // holds, and one more follows the last.
    AheadSlot next = ahead_[static_cast<std::size_t>((ahead_head_ + n - 1) % n)];
    plan_slot(next);
    ahead_[static_cast<std::size_t>(ahead_head_)] = next;
    ahead_head_ = (ahead_head_ + 1) % n;
  } else {
    AheadSlot s{{}, t_, scale_};
    for (int j = 0; j < n; ++j) {
      plan_slot(s);
      ahead_[static_cast<std::size_t>(j)] = s;
    }
    ahead_head_ = 0;
    ahead_n_ = n;
    ahead_move_ = cur_;
    ahead_target_ = target_;
  }
  for (int j = ahead_head_; j < n; ++j) *mm++ = ahead_[static_cast<std::size_t>(j)].mm;
  for (int j = 0; j < ahead_head_; ++j) *mm++ = ahead_[static_cast<std::size_t>(j)].mm;
  return n;
}

bool PlannedSource::move_done() const noexcept { return !cur_ || t_ >= cur_->duration_s(); }

void PlannedSource::demand(Demand& d) const noexcept {
  d.kind = Demand::Kind::track;
  d.track.path = nullptr;
  d.track.preview_ticks = 0;
  if (!cur_) {
    for (int i = 0; i < control::kAxes; ++i) {
      d.track.r_mm[i] = hold_mm_[i];
      d.track.v_ff_mm_per_s[i] = d.track.a_ff_mm_per_s2[i] = 0.0;
    }
    d.commanded_mm = hold_mm_;
    return;
  }
  const double dt = ctx_.period_s;
  const MachineSetup& m = *ctx_.machine;
  // Real time T ahead is path time k T ahead (the rate k, time_scale.h); at k = 1 these are the
  // plan's own samples.
  const double k = scale_.k(), kd = scale_.k_dot();
  const double pdt = k * dt;
  motion::Setpoint fb, ff, now;
  for (int i = 0; i < control::kAxes; ++i) {
    cur_->sample(t_ - m.signals[i].reading_latency_ticks * pdt, fb);
    cur_->sample(t_ + (m.signals[i].command_latency_ticks + 1) * pdt, ff);
    d.track.r_mm[i] = fb.position_mm[i];
    d.track.v_ff_mm_per_s[i] = ff.velocity_mm_per_s[i] * k;
    d.track.a_ff_mm_per_s2[i] = ff.acceleration_mm_per_s2[i] * k * k + ff.velocity_mm_per_s[i] * kd;
  }
  cur_->sample(std::min(t_, cur_->duration_s()), now);
  d.commanded_mm = now.position_mm;

  // Preview: the position setpoints 1 .. kMaxPreviewTicks periods after r.
  motion::Setpoint ahead;
  for (int j = 0; j < control::ControllerInput::kMaxPreviewTicks; ++j)
    for (int i = 0; i < control::kAxes; ++i) {
      if (i == 0 || m.signals[i].reading_latency_ticks != m.signals[0].reading_latency_ticks)
        cur_->sample(t_ + (j + 1 - m.signals[i].reading_latency_ticks) * pdt, ahead);
      d.track.r_preview_mm[j][i] = ahead.position_mm[i];
    }
  d.track.preview_ticks = control::ControllerInput::kMaxPreviewTicks;

  // The segment the tool is on: move the cursor on while the next segment is strictly nearer
  // the measured position (a few per period at most: the tool moves far less than a segment
  // per period, except over runs of tiny segments, which the bound lets it catch up with over
  // a few periods). Strictly: on a closed contour the last segment ends where the first
  // starts, and at a joint the cursor waits until the tool has left the segment it is on.
  // Also when the setpoint runs back against the segment's direction (within about 25
  // degrees): after a cusp, a reversal, the next segment starts back along the one the tool is
  // on, so the tool stays nearer the old one, and a contour controller holding it there would
  // keep it from ever leaving. Ordinary corners, even sharp ones, keep the nearest rule.
  const std::vector<Segment>& segs = stretch_->segments;
  if (segs.empty()) return;
  const Eigen::Vector2d y = measured_mm_;
  const Eigen::Vector2d v(now.velocity_mm_per_s[0] * k, now.velocity_mm_per_s[1] * k);
  const auto dist = [&](std::size_t k) { return (closest_point(segs[k], y) - y).squaredNorm(); };
  const auto reversed = [&](std::size_t k) {
    return v.squaredNorm() > 1e-12 && tangent_at(segs[k], closest_point(segs[k], y)).dot(v) < -0.9 * v.norm();
  };
  for (int n = 0; n < 8 && segment_ + 1 < segs.size() && (dist(segment_ + 1) < dist(segment_) || reversed(segment_)); ++n)
    ++segment_;
  // A paused motion back along the path: the cursor follows it back the same way.
  for (int n = 0; n < 8 && pause_v_ < 0.0 && segment_ > 0 && dist(segment_ - 1) < dist(segment_); ++n) --segment_;
  d.track.path = &segs[segment_];
}

int PlannedSource::source_line() const noexcept {
  if (!cur_ || step_ >= ctx_.job->steps.size()) return 0;
  // The line of the segment the tool is on (the cursor; blends carry the next piece's line),
  // else the step's first line.
  if (stretch_ && segment_ < stretch_->source_lines.size() && stretch_->source_lines[segment_] > 0)
    return stretch_->source_lines[segment_];
  return ctx_.job->steps[step_].source_line;
}

}  // namespace machplan::executor
