#include "engine/motion/feed_planner.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/internal/speed_profile.h"
#include "engine/motion/interpolator.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
using internal::kAccelTable;
using internal::SpeedZone;
constexpr double kTangentRad = 1e-9;        // planner: junctions this straight are passed as they are
constexpr double kBoundTangentRad = 1e-6;   // bound: junctions this straight are not counted as stops
constexpr double kMinPieceMm = 1e-9;        // shorter pieces are dropped
constexpr double kMinBlendMm = 1e-6;        // shorter blends become stops
constexpr double kZoneMergeRel = 0.005;     // caps within 0.5 % share a zone
constexpr int kDeviationSamples = 64;

Vector2d left_normal(const Vector2d& t) { return Vector2d(-t.y(), t.x()); }


}  // namespace

void validate_stretch(const Stretch& st) {
  MACHPLAN_ASSERT(!st.segments.empty(), "plan_stretch: the stretch has no segments");
  MACHPLAN_ASSERT(st.feed_mm_per_s.size() == st.segments.size() && st.source_lines.size() == st.segments.size(),
                  "plan_stretch: {} segments but {} feeds and {} source lines", st.segments.size(),
                  st.feed_mm_per_s.size(), st.source_lines.size());
  for (std::size_t i = 0; i < st.segments.size(); ++i) {
    const double f = st.feed_mm_per_s[i];
    MACHPLAN_ASSERT(std::isfinite(f) && f > 0.0, "plan_stretch: segment {} has feed {} mm/s (must be > 0)", i, f);
    const Segment& s = st.segments[i];
    MACHPLAN_ASSERT(!s.is_arc() || (std::isfinite(s.radius) && s.radius > 0.0 && std::isfinite(s.sweep)),
                    "plan_stretch: arc segment {} has radius {} and sweep {}", i, s.radius, s.sweep);
    MACHPLAN_ASSERT(i == 0 || (s.start - st.segments[i - 1].end).norm() <= 1e-6,
                    "plan_stretch: segment {} starts {} mm away from the end of segment {}", i,
                    (s.start - st.segments[std::max<std::size_t>(i, 1) - 1].end).norm(), i - 1);
  }
}

namespace {

// The part of `s` between path lengths a and b (0 <= a <= b <= length).
Segment sub_segment(const Segment& s, double a, double b) {
  Segment r = s;
  r.start = interpolate(s, a).position_mm;
  r.end = interpolate(s, b).position_mm;
  if (s.is_arc()) {
    const double sign = s.sweep >= 0 ? 1.0 : -1.0;
    r.start_angle = s.start_angle + sign * a / s.radius;
    r.sweep = sign * (b - a) / s.radius;
  }
  return r;
}

// The circular arc that leaves `a` along unit tangent `t` and ends at `b` (a line when
// straight enough).
Segment arc_from(const Vector2d& a, const Vector2d& t, const Vector2d& b) {
  Segment s;
  s.start = a;
  s.end = b;
  const Vector2d c = b - a;
  const double cc = c.squaredNorm();
  const double cr = cross(t, c);
  if (cc == 0.0 || std::abs(cr) <= 1e-12 * cc) return s;  // straight
  const double k = 2.0 * cr / cc;                        // signed curvature
  s.kind = Segment::Kind::arc;
  s.radius = 1.0 / std::abs(k);
  s.center = a + left_normal(t) / k;
  s.start_angle = std::atan2(a.y() - s.center.y(), a.x() - s.center.x());
  s.sweep = 2.0 * std::atan2(cr, t.dot(c));
  return s;
}

// Biarc from (p1, t1) to (p2, t2) with equal control lengths; empty when degenerate.
std::vector<Segment> biarc(const Vector2d& p1, const Vector2d& t1, const Vector2d& p2, const Vector2d& t2) {
  const Vector2d v = p2 - p1;
  const Vector2d t = t1 + t2;
  const double vv = v.squaredNorm(), vt = v.dot(t), tt = t.squaredNorm();
  if (vv <= 1e-24) return {};
  double d;
  if (std::abs(tt - 4.0) < 1e-12) {
    if (vt <= 0.0) return {};
    d = vv / (2.0 * vt);
  } else {
    const double disc = vt * vt - (tt - 4.0) * vv;
    d = (vt - std::sqrt(std::max(0.0, disc))) / (tt - 4.0);
  }
  if (!(d > 0.0) || !std::isfinite(d)) return {};
  const Vector2d q1 = p1 + d * t1, q2 = p2 - d * t2;
  const Vector2d j = 0.5 * (q1 + q2);
  const Vector2d dq = q2 - q1;
  if (dq.norm() <= 0.0) return {};
  const Vector2d tj = dq / dq.norm();
  std::vector<Segment> out;
  for (const Segment& s : {arc_from(p1, t1, j), arc_from(j, tj, p2)})
    if (length(s) > kMinPieceMm) out.push_back(s);
  return out;
}

// Largest distance from the pieces to the union of segments a and b, sampled.
double sampled_deviation(const std::vector<Segment>& pieces, const Segment& a, const Segment& b) {
  double worst = 0.0;
  for (const Segment& p : pieces) {
    const double len = length(p);
    for (int k = 0; k <= kDeviationSamples; ++k) {
      const Vector2d q = interpolate(p, len * k / kDeviationSamples).position_mm;
      const double da = (closest_point(a, q) - q).norm(), db = (closest_point(b, q) - q).norm();
      worst = std::max(worst, std::min(da, db));
    }
  }
  return worst;
}

// ---- S-curve transitions -------------------------------------------------------------

// An arc as the acceleration box sees it: curvature and, per axis i, the range of |n_i| over
// the arc (|n_x| = |cos th|, |n_y| = |sin th| of the radial angle th; the tangent's |u_i| is
// sqrt(1 - |n_i|^2)).
struct ArcRange {
  double kappa = 0.0, lo = 0.0, hi = 0.0;
  double n_min[2] = {0, 0}, n_max[2] = {0, 0};
};

double min_abs_trig(double lo, double hi, int which);
double max_abs_trig(double lo, double hi, int which);

ArcRange arc_range(const Segment& s) {
  ArcRange a;
  a.kappa = 1.0 / s.radius;
  a.lo = std::min(s.start_angle, s.end_angle());
  a.hi = std::max(s.start_angle, s.end_angle());
  for (int i = 0; i < 2; ++i) {
    a.n_min[i] = min_abs_trig(a.lo, a.hi, i);
    a.n_max[i] = max_abs_trig(a.lo, a.hi, i);
  }
  return a;
}

// The tangential acceleration that the per-axis box leaves, at path speed v, at every point
// of the arc: min over the arc and the axes of (amax_i - w |n_i|) / |u_i|, w = v^2 kappa (0
// when the normal part alone exceeds an axis limit somewhere). As a function of |n_i| = c the
// ratio (amax_i - w c) / sqrt(1 - c^2) falls, then rises, with its least at c = w / amax_i;
// |n_i| is continuous along the arc, so it takes every value between its extremes, and the
// least over the arc is at that c when the arc reaches it, else at the nearer extreme. No
// trigonometry: ArcRange holds what is needed.
double arc_tangential_accel(const ArcRange& arc, double v, const Vector2d& amax) {
  const double w = v * v * arc.kappa;
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 2; ++i) {
    if (amax[i] - w * arc.n_max[i] < 0.0) return 0.0;
    const auto ratio = [&](double c) {
      const double u = std::sqrt(std::max(0.0, 1.0 - c * c));
      return u > 1e-12 ? (amax[i] - w * c) / u : std::numeric_limits<double>::infinity();
    };
    best = std::min(best, ratio(std::clamp(w / amax[i], arc.n_min[i], arc.n_max[i])));
  }
  return std::max(0.0, best);
}

// Largest |cos| (which = 0) or |sin| (which = 1) over angles [lo, hi].
double max_abs_trig(double lo, double hi, int which) {
  constexpr double kPiL = std::numbers::pi;
  const double offset = which == 0 ? 0.0 : kPiL / 2;  // where |cos| or |sin| is 1
  const double k = std::ceil((lo - offset) / kPiL);
  if (offset + k * kPiL <= hi) return 1.0;
  auto f = [which](double x) { return which == 0 ? std::abs(std::cos(x)) : std::abs(std::sin(x)); };
  return std::max(f(lo), f(hi));
}

struct PieceInfo {
  double cap = 0.0;  // speed cap, mm/s
  ArcRange arc;      // arcs
  double a_line = std::numeric_limits<double>::infinity();  // lines: tangential acceleration cap
  double kappa = 0.0;                                       // arcs: curvature 1/r
  double jerk = 0.0;  // path jerk limit: lines min_i J / |u_i| (a box, as a_line); arcs J
  bool stop_before = false;
};

// Smallest |cos| (which = 0) or |sin| (which = 1) over angles [lo, hi].
double min_abs_trig(double lo, double hi, int which) {
  // zeros of cos at pi/2 + k pi, of sin at k pi
  const double offset = which == 0 ? kPi / 2 : 0.0;
  const double k = std::ceil((lo - offset) / kPi);
  if (offset + k * kPi <= hi) return 0.0;
  auto f = [which](double x) { return which == 0 ? std::abs(std::cos(x)) : std::abs(std::sin(x)); };
  return std::min(f(lo), f(hi));
}

// min_i lim_i / |w_i| for a direction whose components are bounded below by (wx, wy).
double axis_cap(const Vector2d& lim, double wx, double wy) {
  double r = std::numeric_limits<double>::infinity();
  if (wx > 0) r = std::min(r, lim.x() / wx);
  if (wy > 0) r = std::min(r, lim.y() / wy);
  return r;
}

// Step 1 of plan_stretch_detailed: what happens at each junction between the non-degenerate
// programmed segments idx[k] and idx[k+1]: passed (tangent), blended (trims and blend
// pieces) or a stop.
struct Junctions {
  std::vector<double> len, trim_start, trim_end;  // per segment of idx
  std::vector<std::vector<Segment>> blends;       // blends[k]: between k and k+1
  std::vector<bool> stop_after;
  double max_deviation_mm = 0.0;
  int blended = 0;
};

// The blend replacing the corner between a and b (turning by phi, te: a's end tangent): its
// pieces (none: stop there), the trim length d on both sides and its deviation.
std::vector<Segment> blend_corner(const Segment& a, const Segment& b, double len_a, double len_b, double phi,
                                  const Vector2d& te, double tol, double& d, double& dev) {
  const double d_max = std::min(0.5 * len_a, 0.5 * len_b);
  const double q = std::tan(phi / 4.0);
  std::vector<Segment> pieces;
  dev = 0.0;
  d = std::min(0.999 * tol / q, d_max);
  if (!a.is_arc() && !b.is_arc()) {
    if (d >= kMinBlendMm) {
      const Vector2d p1 = interpolate(a, len_a - d).position_mm, p2 = interpolate(b, d).position_mm;
      Segment s = arc_from(p1, te, p2);
      s.end = p2;
      pieces.push_back(s);
      dev = d * q;
    }
  } else {
    d = std::min(tol / q, d_max);
    for (int it = 0; it < 60 && d >= kMinBlendMm; ++it, d *= 0.5) {
      const PathPoint p1 = interpolate(a, len_a - d), p2 = interpolate(b, d);
      pieces = biarc(p1.position_mm, p1.tangent, p2.position_mm, p2.tangent);
      if (pieces.empty()) continue;
      dev = sampled_deviation(pieces, a, b);
      if (dev <= 0.9 * tol) break;
      pieces.clear();
    }
  }
  return pieces;
}

Junctions plan_junctions(const Stretch& stretch, const std::vector<std::size_t>& idx, double tol) {
  const std::size_t n = idx.size();
  Junctions j;
  j.len.resize(n);
  j.trim_start.assign(n, 0.0);
  j.trim_end.assign(n, 0.0);
  j.blends.resize(n);
  j.stop_after.assign(n, false);
  for (std::size_t k = 0; k < n; ++k) j.len[k] = length(stretch.segments[idx[k]]);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Segment& a = stretch.segments[idx[k]];
    const Segment& b = stretch.segments[idx[k + 1]];
    const Vector2d te = interpolate(a, j.len[k]).tangent, ts = interpolate(b, 0.0).tangent;
    const double phi = std::atan2(std::abs(cross(te, ts)), te.dot(ts));
    if (phi <= kTangentRad) continue;
    if (phi > kStopAngleRad) {
      j.stop_after[k] = true;
      continue;
    }
    double d = 0.0, dev = 0.0;
    std::vector<Segment> pieces = blend_corner(a, b, j.len[k], j.len[k + 1], phi, te, tol, d, dev);
    if (pieces.empty()) {
      j.stop_after[k] = true;
      continue;
    }
    j.trim_end[k] = d;
    j.trim_start[k + 1] = d;
    j.blends[k] = std::move(pieces);
    j.max_deviation_mm = std::max(j.max_deviation_mm, dev);
    ++j.blended;
  }
  return j;
}

// Step 2: the speed cap, acceleration cap and jerk limit of one piece of the executed path.
PieceInfo piece_caps(const Segment& s, double feed, const PlannerOptions& o) {
  const Vector2d& vmax = o.max_velocity_mm_per_s;
  const Vector2d& amax = o.max_acceleration_mm_per_s2;
  const double f_n = o.curve_normal_fraction;
  const double tol = o.path_tolerance_mm;
  PieceInfo pi;
  if (s.is_arc()) {
    const double r = s.radius;
    // The radial angle range; the tangent is perpendicular, so |u_x| = |sin|, |u_y| = |cos|.
    pi.arc = arc_range(s);
    const double nx = pi.arc.n_max[0], ny = pi.arc.n_max[1];
    const double a_n = axis_cap(amax, nx, ny);        // most normal acceleration everywhere on the arc
    const double v_axes = axis_cap(vmax, ny, nx);     // |u_x| = |sin| <= ny, |u_y| = |cos| <= nx
    pi.cap = std::min({feed, v_axes, std::sqrt(f_n * a_n * r), std::sqrt(8.0 * r * tol) / o.servo_period_s});
    pi.kappa = 1.0 / r;
    pi.jerk = o.max_jerk_mm_per_s3;
  } else {
    const Vector2d u = (s.end - s.start).normalized();
    pi.cap = std::min(feed, axis_cap(vmax, std::abs(u.x()), std::abs(u.y())));
    pi.a_line = axis_cap(amax, std::abs(u.x()), std::abs(u.y()));
    pi.jerk = o.max_jerk_mm_per_s3 / std::max(std::abs(u.x()), std::abs(u.y()));
  }
  return pi;
}

// Step 2: the executed path (trimmed segments and blends, sharing their end points exactly)
// into `path`, the caps of each of its pieces; returns the number of stop junctions.
int build_executed_path(const Stretch& stretch, const std::vector<std::size_t>& idx, const Junctions& j,
                        const PlannerOptions& o, Stretch& path, std::vector<PieceInfo>& info) {
  const std::size_t n = idx.size();
  int stops = 0;
  bool pending_stop = false;
  auto add = [&](const Segment& s, double feed, int line) {
    PieceInfo pi = piece_caps(s, feed, o);
    pi.stop_before = pending_stop && !path.segments.empty();
    pending_stop = false;
    path.segments.push_back(s);
    path.feed_mm_per_s.push_back(feed);
    path.source_lines.push_back(line);
    info.push_back(pi);
  };
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = idx[k];
    const double a = j.trim_start[k], b = j.len[k] - j.trim_end[k];
    if (b - a > kMinPieceMm) add(sub_segment(stretch.segments[i], a, b), stretch.feed_mm_per_s[i], stretch.source_lines[i]);
    if (k + 1 < n) {
      if (j.stop_after[k]) {
        pending_stop = true;
        ++stops;
      }
      const double feed = std::min(stretch.feed_mm_per_s[i], stretch.feed_mm_per_s[idx[k + 1]]);
      for (const Segment& s : j.blends[k]) add(s, feed, stretch.source_lines[idx[k + 1]]);
    }
  }
  // Make consecutive pieces share their end points exactly (trimmed ends are computed from
  // either side with the same formula; blends end where the next piece starts).
  for (std::size_t k = 1; k < path.segments.size(); ++k) path.segments[k].start = path.segments[k - 1].end;
  return stops;
}

// Step 3: zones, consecutive pieces whose speed caps agree within kZoneMergeRel, with the
// tangential acceleration table of those holding arcs.
std::vector<SpeedZone> make_zones(const Stretch& path, const std::vector<PieceInfo>& info,
                             const std::vector<double>& piece_s0, const Vector2d& amax) {
  std::vector<SpeedZone> zones;
  for (std::size_t k = 0; k < info.size(); ++k) {
    const PieceInfo& pi = info[k];
    const double l = length(path.segments[k]);
    bool join = !zones.empty() && !pi.stop_before;
    if (join) join = std::abs(pi.cap - info[zones.back().first].cap) <= kZoneMergeRel * info[zones.back().first].cap;
    if (!join) {
      SpeedZone z;
      z.first = k;
      z.s0 = piece_s0[k];
      z.cap = pi.cap;
      zones.push_back(z);
    }
    SpeedZone& z = zones.back();
    z.last = k;
    z.length += l;
    z.cap = std::min(z.cap, pi.cap);
    z.a_line = std::min(z.a_line, pi.a_line);
    z.kappa = std::max(z.kappa, pi.kappa);
    z.jerk = std::min(z.jerk, pi.jerk);
  }
  for (SpeedZone& z : zones) {
    if (!(z.kappa > 0.0)) continue;
    z.a_arc.assign(kAccelTable + 1, std::numeric_limits<double>::infinity());
    for (std::size_t k = z.first; k <= z.last; ++k) {
      if (!(info[k].arc.kappa > 0.0)) continue;
      for (int t = 0; t <= kAccelTable; ++t)
        z.a_arc[t] = std::min(z.a_arc[t], arc_tangential_accel(info[k].arc, z.cap * t / kAccelTable, amax));
    }
  }
  return zones;
}

}  // namespace

PlannerOptions PlannerOptions::thermal_gantry() { return PlannerOptions{}; }

PlannerOptions PlannerOptions::xy_table() {
  PlannerOptions o;
  o.max_velocity_mm_per_s = Vector2d(1200.0, 1200.0);
  o.max_acceleration_mm_per_s2 = Vector2d(5000.0, 5000.0);
  o.max_jerk_mm_per_s3 = 200000.0;
  return o;
}

void PlannerOptions::validate() const {
  for (int i = 0; i < 2; ++i) {
    require_field(std::isfinite(max_velocity_mm_per_s[i]) && max_velocity_mm_per_s[i] > 0,
            i == 0 ? "max_velocity_mm_per_s.x" : "max_velocity_mm_per_s.y", max_velocity_mm_per_s[i],
            "must be finite and > 0");
    require_field(std::isfinite(max_acceleration_mm_per_s2[i]) && max_acceleration_mm_per_s2[i] > 0,
            i == 0 ? "max_acceleration_mm_per_s2.x" : "max_acceleration_mm_per_s2.y",
            max_acceleration_mm_per_s2[i], "must be finite and > 0");
  }
  require_field(std::isfinite(max_jerk_mm_per_s3) && max_jerk_mm_per_s3 > 0, "max_jerk_mm_per_s3", max_jerk_mm_per_s3,
          "must be finite and > 0");
  require_field(std::isfinite(path_tolerance_mm) && path_tolerance_mm > 0, "path_tolerance_mm", path_tolerance_mm,
          "must be finite and > 0");
  require_field(std::isfinite(servo_period_s) && servo_period_s > 0 && servo_period_s <= 1.0, "servo_period_s",
          servo_period_s, "must be in (0, 1]");
  require_field(curve_normal_fraction > 0 && curve_normal_fraction < 1, "curve_normal_fraction", curve_normal_fraction,
          "must be in (0, 1)");
}

std::unique_ptr<PlannedTrajectory> plan_stretch_detailed(const Stretch& stretch, const PlannerOptions& o) {
  o.validate();
  validate_stretch(stretch);
  auto traj = std::make_unique<PlannedTrajectory>();

  // Non-degenerate programmed segments.
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < stretch.segments.size(); ++i)
    if (length(stretch.segments[i]) > kMinPieceMm) idx.push_back(i);
  Stretch& path = traj->path_;
  path.cutting = stretch.cutting;
  path.rapid = stretch.rapid;
  if (idx.empty()) {  // nothing moves: a zero-length trajectory at the start point
    Segment s;
    s.start = s.end = stretch.segments.front().start;
    path.segments.push_back(s);
    path.feed_mm_per_s.push_back(stretch.feed_mm_per_s.front());
    path.source_lines.push_back(stretch.source_lines.front());
    traj->piece_s0_.push_back(0.0);
    return traj;
  }

  // 1. Junctions: blend, pass or stop.
  const Junctions junctions = plan_junctions(stretch, idx, o.path_tolerance_mm);
  traj->max_deviation_mm_ = junctions.max_deviation_mm;
  traj->blended_ = junctions.blended;

  // 2. The executed path and the caps of each piece.
  std::vector<PieceInfo> info;
  traj->stops_ = build_executed_path(stretch, idx, junctions, o, path, info);
  double total = 0.0;
  for (const Segment& s : path.segments) {
    traj->piece_s0_.push_back(total);
    total += length(s);
  }
  traj->length_mm_ = total;

  // 3. Zones, node speeds (reverse and forward passes), one profile per zone.
  const std::vector<SpeedZone> zones = make_zones(path, info, traj->piece_s0_, o.max_acceleration_mm_per_s2);
  std::vector<double> node_cap(zones.size() + 1, std::numeric_limits<double>::infinity());
  for (std::size_t k = 1; k < zones.size(); ++k)
    if (info[zones[k].first].stop_before) node_cap[k] = 0.0;
  const std::vector<double> node = internal::node_speeds(zones, node_cap);
  traj->duration_s_ = internal::build_profile(zones, node, traj->phases_);
  for (const ProfilePhase& p : traj->phases_) traj->phase_t0_.push_back(p.t0_s);
  return traj;
}

std::unique_ptr<Trajectory> plan_stretch(const Stretch& stretch, const PlannerOptions& options) {
  return plan_stretch_detailed(stretch, options);
}

void PlannedTrajectory::sample(double t_s, Setpoint& out) const {
  const ProfileState st = profile_state(phases_, phase_t0_, duration_s_, length_mm_, t_s);
  const double s = st.s, v = st.v, a = st.a;
  const auto it = std::upper_bound(piece_s0_.begin(), piece_s0_.end(), s);
  const std::size_t k = it == piece_s0_.begin() ? 0 : static_cast<std::size_t>(it - piece_s0_.begin()) - 1;
  const PathPoint pp = interpolate(path_.segments[k], s - piece_s0_[k]);
  out.position_mm = pp.position_mm;
  out.velocity_mm_per_s = v * pp.tangent;
  out.acceleration_mm_per_s2 = a * pp.tangent + v * v * pp.curvature_per_mm * left_normal(pp.tangent);
}

double PlannedTrajectory::cruise_left_s(double t_s) const {
  if (!(t_s >= 0.0) || t_s >= duration_s_ || phases_.empty()) return 0.0;
  const auto it = std::upper_bound(phase_t0_.begin(), phase_t0_.end(), t_s);
  std::size_t k = it == phase_t0_.begin() ? 0 : static_cast<std::size_t>(it - phase_t0_.begin()) - 1;
  const auto cruising = [](const ProfilePhase& p) { return p.a0_mm_per_s2 == 0.0 && p.jerk_mm_per_s3 == 0.0 && p.v0_mm_per_s > 0.0; };
  if (!cruising(phases_[k])) return 0.0;
  const double v = phases_[k].v0_mm_per_s;
  std::size_t last = k;
  while (last + 1 < phases_.size() && cruising(phases_[last + 1]) && phases_[last + 1].v0_mm_per_s == v) ++last;
  const double phase_left = phases_[last].t0_s + phases_[last].duration_s - t_s;
  // The piece under the tool now.
  const double s = phases_[k].s0_mm + (t_s - phases_[k].t0_s) * v;
  const auto pt = std::upper_bound(piece_s0_.begin(), piece_s0_.end(), s);
  const std::size_t piece = pt == piece_s0_.begin() ? 0 : static_cast<std::size_t>(pt - piece_s0_.begin()) - 1;
  const double piece_end = piece + 1 < piece_s0_.size() ? piece_s0_[piece + 1] : length_mm_;
  return std::max(0.0, std::min(phase_left, (piece_end - s) / v));
}

double time_lower_bound_s(const Stretch& stretch, const PlannerOptions& o) {
  o.validate();
  validate_stretch(stretch);
  const Vector2d& vmax = o.max_velocity_mm_per_s;
  const Vector2d& amax = o.max_acceleration_mm_per_s2;

  // Pieces with relaxed (largest over the piece) caps; `stop_before` at direction jumps.
  std::vector<internal::EnvelopePiece> ps;
  const auto piece = [](double len, double cap, double accel, bool stop) {
    internal::EnvelopePiece p;
    p.length = len, p.cap = cap, p.accel = accel;
    if (stop) p.node_cap2 = 0.0;
    return p;
  };
  bool have_prev = false;
  Vector2d prev_tangent = Vector2d::Zero();
  for (std::size_t i = 0; i < stretch.segments.size(); ++i) {
    const Segment& s = stretch.segments[i];
    const double l = length(s);
    if (l <= kMinPieceMm) continue;
    const double feed = stretch.feed_mm_per_s[i];
    const Vector2d t0 = interpolate(s, 0.0).tangent;
    bool stop = false;
    if (have_prev) stop = std::atan2(std::abs(cross(prev_tangent, t0)), prev_tangent.dot(t0)) > kBoundTangentRad;
    prev_tangent = interpolate(s, l).tangent;
    have_prev = true;
    if (!s.is_arc()) {
      const double ux = std::abs(t0.x()), uy = std::abs(t0.y());
      ps.push_back(piece(l, std::min(feed, axis_cap(vmax, ux, uy)), axis_cap(amax, ux, uy), stop));
      continue;
    }
    const int parts = std::max(1, static_cast<int>(std::ceil(std::abs(s.sweep) / (kPi / 32.0))));
    const double sign = s.sweep >= 0 ? 1.0 : -1.0;
    for (int k = 0; k < parts; ++k) {
      // Radial angle range of this part; the tangent angle is the radial one + sign pi/2.
      const double th0 = s.start_angle + s.sweep * k / parts, th1 = s.start_angle + s.sweep * (k + 1) / parts;
      const double lo = std::min(th0, th1), hi = std::max(th0, th1);
      const double tlo = lo + sign * kPi / 2, thi = hi + sign * kPi / 2;
      const double ux = min_abs_trig(tlo, thi, 0), uy = min_abs_trig(tlo, thi, 1);
      const double nx = min_abs_trig(lo, hi, 0), ny = min_abs_trig(lo, hi, 1);
      const double a_n = axis_cap(amax, nx, ny);
      const double cap = std::min({feed, axis_cap(vmax, ux, uy), std::sqrt(a_n * s.radius)});
      ps.push_back(piece(l / parts, cap, axis_cap(amax, ux, uy), k == 0 && stop));
    }
  }
  return internal::envelope_time_s(ps);
}

}  // namespace machplan::motion
