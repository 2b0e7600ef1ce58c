#include "engine/motion/time_optimal.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/interpolator.h"

namespace machplan::motion {
namespace {

using Eigen::Vector2d;
constexpr double kMinPieceMm = 1e-9;      // shorter segments are skipped (as the planner does)
constexpr double kJumpRad = 1e-6;         // tangent jumps above this are stops (as the bound)
constexpr double kAxisEps = 1e-12;        // |u_i| below this: the axis takes no tangential part

// Geometry of one grid point as a step sees it.
struct Local {
  Vector2d u = Vector2d::UnitX();  // unit tangent
  Vector2d c = Vector2d::Zero();   // kappa * left normal: the normal acceleration per unit x
};

// The interval of tangential accelerations allowed at (local, x) by the box amax, [lo, hi];
// lo > hi when empty.
void accel_range(const Local& g, double x, const Vector2d& amax, double& lo, double& hi) {
  lo = -kInf;
  hi = kInf;
  for (int i = 0; i < 2; ++i) {
    const double un = g.u[i], cn = g.c[i] * x;
    if (std::abs(un) <= kAxisEps) {
      if (std::abs(cn) > amax[i] * (1.0 + 1e-12)) lo = kInf, hi = -kInf;
      continue;
    }
    double a = (-amax[i] - cn) / un, b = (amax[i] - cn) / un;
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
}

// Largest x at which the a_t interval is not empty (kInf on a line).
double accel_mvc(const Local& g, const Vector2d& amax) {
  // Each axis bound is linear in x: lo_i = pl + ql x, hi_i = ph + qh x.
  double pl[2], ql[2], ph[2], qh[2];
  bool free_axis[2];
  double cap = kInf;
  for (int i = 0; i < 2; ++i) {
    const double un = g.u[i], cn = g.c[i];
    free_axis[i] = std::abs(un) <= kAxisEps;
    if (free_axis[i]) {
      if (std::abs(cn) > 0.0) cap = std::min(cap, amax[i] / std::abs(cn));
      continue;
    }
    // (-A - c x) / u and (A - c x) / u, ordered: -A / |u| - (c / u) x and A / |u| - (c / u) x.
    pl[i] = -amax[i] / std::abs(un);
    ph[i] = amax[i] / std::abs(un);
    ql[i] = qh[i] = -cn / un;
  }
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      if (free_axis[i] || free_axis[j] || i == j) continue;
      // lo_i(x) <= hi_j(x):  (ql_i - qh_j) x <= ph_j - pl_i
      const double den = ql[i] - qh[j], num = ph[j] - pl[i];
      if (den > 0.0) cap = std::min(cap, num / den);
    }
  return cap;
}

// Speed-squared cap from the feed and the axis speeds at tangent u.
double speed_cap2(const Vector2d& u, double feed, const Vector2d& vmax) {
  double v = feed;
  for (int i = 0; i < 2; ++i)
    if (std::abs(u[i]) > kAxisEps) v = std::min(v, vmax[i] / std::abs(u[i]));
  return v * v;
}

Local local_at(const Segment& s, double at_mm) {
  const PathPoint p = interpolate(s, at_mm);
  Local g;
  g.u = p.tangent;
  g.c = p.curvature_per_mm * Vector2d(-p.tangent.y(), p.tangent.x());
  return g;
}

// One grid step: from node k to node k + 1 along segment `seg` between path lengths a and b
// of that segment.
struct GridStep {
  std::size_t seg = 0;
  double a = 0.0, b = 0.0;
  bool line = false;
  Local g0, g1;       // geometry at the two ends (equal on a line)
  double line_acc = 0.0;  // lines: the constant |a_t| limit
  double cap2 = kInf;     // lines: the constant speed-squared cap
};

}  // namespace

void TimeOptimalOptions::validate() const {
  require_field(std::isfinite(max_step_mm) && max_step_mm > 0, "max_step_mm", max_step_mm, "must be finite and > 0");
  require_field(std::isfinite(max_step_rad) && max_step_rad > 0, "max_step_rad", max_step_rad, "must be finite and > 0");
}

TimeOptimalProfile time_optimal_profile(const Stretch& path, const PlannerOptions& o, const TimeOptimalOptions& opt) {
  o.validate();
  opt.validate();
  validate_stretch(path);
  const Vector2d& vmax = o.max_velocity_mm_per_s;
  const Vector2d& amax = o.max_acceleration_mm_per_s2;

  // Grid: node k sits between steps k-1 and k; mvc[k] is its largest x.
  std::vector<GridStep> steps;
  std::vector<double> mvc{0.0};
  bool have_prev = false;
  Vector2d prev_tangent = Vector2d::Zero();
  for (std::size_t i = 0; i < path.segments.size(); ++i) {
    const Segment& s = path.segments[i];
    const double len = length(s);
    if (len <= kMinPieceMm) continue;
    const double feed = path.feed_mm_per_s[i];
    const Vector2d t0 = interpolate(s, 0.0).tangent;
    if (have_prev && std::atan2(std::abs(cross(prev_tangent, t0)), prev_tangent.dot(t0)) > kJumpRad) mvc.back() = 0.0;
    prev_tangent = interpolate(s, len).tangent;
    const bool first = !have_prev;
    have_prev = true;
    const int n = s.is_arc() ? std::max(1, static_cast<int>(std::ceil(std::max(len / opt.max_step_mm,
                                                                                  std::abs(s.sweep) / opt.max_step_rad))))
                             : 1;
    for (int k = 0; k < n; ++k) {
      GridStep st;
      st.seg = i;
      st.a = len * k / n;
      st.b = len * (k + 1) / n;
      st.line = !s.is_arc();
      st.g0 = local_at(s, st.a);
      st.g1 = s.is_arc() ? local_at(s, st.b) : st.g0;
      if (st.line) {
        st.cap2 = speed_cap2(st.g0.u, feed, vmax);
        st.line_acc = kInf;
        for (int ax = 0; ax < 2; ++ax)
          if (std::abs(st.g0.u[ax]) > kAxisEps) st.line_acc = std::min(st.line_acc, amax[ax] / std::abs(st.g0.u[ax]));
      }
      // The node before this step must respect this step's geometry at its start.
      const double here = std::min(speed_cap2(st.g0.u, feed, vmax), accel_mvc(st.g0, amax));
      if (!(first && k == 0)) mvc.back() = std::min(mvc.back(), here);
      const double there = std::min(speed_cap2(st.g1.u, feed, vmax), accel_mvc(st.g1, amax));
      mvc.push_back(there);
      steps.push_back(st);
    }
  }
  TimeOptimalProfile out;
  if (steps.empty()) {
    out.s_mm = {0.0};
    out.v_mm_per_s = {0.0};
    return out;
  }
  mvc.front() = 0.0;
  mvc.back() = 0.0;

  const std::size_t m = steps.size();
  std::vector<double> x = mvc;
  // Backward pass: the speed must leave room to brake.
  for (std::size_t k = m; k-- > 0;) {
    const GridStep& st = steps[k];
    const double ds = st.b - st.a;
    double dec;
    if (st.line) {
      dec = st.line_acc;
    } else {
      double lo, hi;
      accel_range(st.g1, x[k + 1], amax, lo, hi);
      dec = lo <= hi ? std::max(0.0, -lo) : 0.0;
    }
    x[k] = std::min(x[k], x[k + 1] + 2.0 * ds * dec);
  }
  // Forward pass: the speed must be reachable.
  for (std::size_t k = 0; k < m; ++k) {
    const GridStep& st = steps[k];
    const double ds = st.b - st.a;
    double acc;
    if (st.line) {
      acc = st.line_acc;
    } else {
      double lo, hi;
      accel_range(st.g0, x[k], amax, lo, hi);
      acc = lo <= hi ? std::max(0.0, hi) : 0.0;
    }
    x[k + 1] = std::min(x[k + 1], x[k] + 2.0 * ds * acc);
  }

  // Time.
  out.s_mm.reserve(m + 1);
  out.v_mm_per_s.reserve(m + 1);
  double s_total = 0.0, t = 0.0;
  out.s_mm.push_back(0.0);
  out.v_mm_per_s.push_back(0.0);
  for (std::size_t k = 0; k < m; ++k) {
    const GridStep& st = steps[k];
    const double L = st.b - st.a;
    const double wa = std::max(0.0, x[k]), wb = std::max(0.0, x[k + 1]);
    if (st.line) {
      // V = min(cap, sqrt(wa + 2 A s), sqrt(wb + 2 A (L - s))), integrated exactly.
      const double A = st.line_acc, c2 = std::max({st.cap2, wa, wb});
      const double cap = std::sqrt(c2);
      const double x1 = (c2 - wa) / (2.0 * A), x2 = L - (c2 - wb) / (2.0 * A);
      if (x1 <= x2) {
        t += (cap - std::sqrt(wa)) / A + (x2 - x1) / cap + (cap - std::sqrt(wb)) / A;
      } else {
        const double xm = std::clamp((wb - wa + 2.0 * A * L) / (4.0 * A), 0.0, L);
        const double wm = wa + 2.0 * A * xm;
        t += (std::sqrt(wm) - std::sqrt(wa)) / A + (std::sqrt(wm) - std::sqrt(wb)) / A;
      }
    } else {
      const double vs = std::sqrt(wa) + std::sqrt(wb);
      if (vs > 0.0) t += 2.0 * L / vs;
    }
    s_total += L;
    out.s_mm.push_back(s_total);
    out.v_mm_per_s.push_back(std::sqrt(wb));
  }
  out.time_s = t;
  out.length_mm = s_total;
  return out;
}

double time_optimal_s(const Stretch& path, const PlannerOptions& limits, const TimeOptimalOptions& options) {
  return time_optimal_profile(path, limits, options).time_s;
}

}  // namespace machplan::motion
