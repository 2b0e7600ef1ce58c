#include "engine/motion/internal/speed_profile.h"

#include <algorithm>
#include <cmath>

namespace machplan::motion {

ProfileState profile_state(const std::vector<ProfilePhase>& phases, const std::vector<double>& phase_t0, double duration_s,
                           double length, double t_s) {
  ProfileState st;
  if (!(t_s > 0.0)) return st;  // also NaN: the start state
  if (t_s >= duration_s || phases.empty()) {
    st.s = length;
    return st;
  }
  const auto it = std::upper_bound(phase_t0.begin(), phase_t0.end(), t_s);
  const std::size_t k = it == phase_t0.begin() ? 0 : static_cast<std::size_t>(it - phase_t0.begin()) - 1;
  const ProfilePhase& p = phases[k];
  const double tau = std::min(t_s - p.t0_s, p.duration_s);
  st.s = p.s0_mm + tau * (p.v0_mm_per_s + tau * (p.a0_mm_per_s2 / 2.0 + tau * p.jerk_mm_per_s3 / 6.0));
  st.v = std::max(0.0, p.v0_mm_per_s + tau * (p.a0_mm_per_s2 + tau * p.jerk_mm_per_s3 / 2.0));
  st.a = p.a0_mm_per_s2 + tau * p.jerk_mm_per_s3;
  st.s = std::clamp(st.s, 0.0, length);
  return st;
}

}  // namespace machplan::motion

namespace machplan::motion::internal {

double pulse_time(double dv, double a, double j) {
  if (dv <= 0.0) return 0.0;
  if (dv <= a * a / j) return 2.0 * std::sqrt(dv / j);
  return dv / a + a / j;
}

double SpeedZone::accel(double v_top) const {
  double a = a_line;
  if (!a_arc.empty()) {
    const double x = cap > 0.0 ? v_top / cap * kAccelTable : 0.0;
    const int k = std::clamp(static_cast<int>(std::ceil(x - 1e-9)), 0, kAccelTable);
    a = std::min(a, a_arc[k]);
  }
  return a;
}

double transition_distance(double v0, double v1, const SpeedZone& z) {
  const double j = z.jerk;
  const double lo = std::min(v0, v1), hi = std::max(v0, v1), m = z.split();
  if (hi <= m || lo >= m) return 0.5 * (lo + hi) * pulse_time(hi - lo, z.accel(hi), j);
  return 0.5 * (lo + m) * pulse_time(m - lo, z.accel(m), j) + 0.5 * (m + hi) * pulse_time(hi - m, z.accel(hi), j);
}

double reachable(double v0, const SpeedZone& z, double cap) {
  if (cap <= v0) return cap;
  if (transition_distance(v0, cap, z) <= z.length) return cap;
  double lo = v0, hi = cap;
  for (int it = 0; it < 100 && hi - lo > 1e-12 * std::max(1.0, hi); ++it) {
    const double mid = 0.5 * (lo + hi);
    (transition_distance(v0, mid, z) <= z.length ? lo : hi) = mid;
  }
  return lo;
}

std::vector<double> node_speeds(const std::vector<SpeedZone>& zones, const std::vector<double>& node_cap) {
  const std::size_t nz = zones.size();
  std::vector<double> node(nz + 1, 0.0);
  for (std::size_t k = 1; k < nz; ++k) node[k] = std::min({node_cap[k], zones[k - 1].cap, zones[k].cap});
  for (std::size_t k = nz; k-- > 1;) node[k] = std::min(node[k], reachable(node[k + 1], zones[k], node[k]));
  for (std::size_t k = 1; k < nz; ++k) node[k] = std::min(node[k], reachable(node[k - 1], zones[k - 1], node[k]));
  return node;
}

namespace {

class ProfileBuilder {
 public:
  explicit ProfileBuilder(std::vector<ProfilePhase>& out) : out_(out) {}
  void anchor(double t, double s, double v) { t_ = t; s_ = s; v_ = v; a_ = 0.0; }
  void phase(double jerk, double dur) {
    if (!(dur > 0.0)) return;
    ProfilePhase p;
    p.t0_s = t_;
    p.duration_s = dur;
    p.s0_mm = s_;
    p.v0_mm_per_s = v_;
    p.a0_mm_per_s2 = a_;
    p.jerk_mm_per_s3 = jerk;
    out_.push_back(p);
    s_ += v_ * dur + a_ * dur * dur / 2.0 + jerk * dur * dur * dur / 6.0;
    v_ += a_ * dur + jerk * dur * dur / 2.0;
    a_ += jerk * dur;
    t_ += dur;
  }
  // One symmetric pulse from v0 to v1 with acceleration <= a.
  void pulse(double v0, double v1, double a, double j) {
    const double dv = std::abs(v1 - v0);
    if (dv <= 0.0) return;
    const double sg = v1 > v0 ? 1.0 : -1.0;
    if (dv <= a * a / j) {
      const double tj = std::sqrt(dv / j);
      phase(sg * j, tj);
      phase(-sg * j, tj);
    } else {
      const double tj = a / j;
      phase(sg * j, tj);
      phase(0.0, dv / a - a / j);
      phase(-sg * j, tj);
    }
    v_ = v1;  // remove rounding: the pulse ends exactly at v1 with zero acceleration
    a_ = 0.0;
  }
  void transition(double v0, double v1, const SpeedZone& z) {
    const double j = z.jerk;
    const double lo = std::min(v0, v1), hi = std::max(v0, v1), m = z.split();
    if (hi <= m || lo >= m) return pulse(v0, v1, z.accel(hi), j);
    if (v1 > v0) {
      pulse(v0, m, z.accel(m), j);
      pulse(m, v1, z.accel(v1), j);
    } else {
      pulse(v0, m, z.accel(v0), j);
      pulse(m, v1, z.accel(m), j);
    }
  }
  double t() const { return t_; }

 private:
  std::vector<ProfilePhase>& out_;
  double t_ = 0.0, s_ = 0.0, v_ = 0.0, a_ = 0.0;
};

}  // namespace

double build_profile(const std::vector<SpeedZone>& zones, const std::vector<double>& node,
                     std::vector<ProfilePhase>& phases) {
  ProfileBuilder pb(phases);
  for (std::size_t k = 0; k < zones.size(); ++k) {
    const SpeedZone& z = zones[k];
    const double v0 = node[k], v1 = node[k + 1];
    auto need = [&](double vp) { return transition_distance(v0, vp, z) + transition_distance(vp, v1, z); };
    double vp = z.cap;
    if (need(vp) > z.length) {
      double lo = std::max(v0, v1), hi = z.cap;
      for (int it = 0; it < 100 && hi - lo > 1e-12 * std::max(1.0, hi); ++it) {
        const double mid = 0.5 * (lo + hi);
        (need(mid) <= z.length ? lo : hi) = mid;
      }
      vp = lo;
    }
    pb.anchor(pb.t(), z.s0, v0);
    pb.transition(v0, vp, z);
    const double cruise = z.length - need(vp);
    if (cruise > 0.0 && vp > 0.0) pb.phase(0.0, cruise / vp);
    pb.transition(vp, v1, z);
  }
  return pb.t();
}

double envelope_time_s(const std::vector<EnvelopePiece>& ps) {
  if (ps.empty()) return 0.0;
  // Node values of V^2 between pieces; 0 at the ends.
  const std::size_t m = ps.size();
  std::vector<double> w(m + 1, 0.0);
  for (std::size_t k = 1; k < m; ++k) w[k] = std::min({ps[k].node_cap2, ps[k - 1].cap * ps[k - 1].cap, ps[k].cap * ps[k].cap});
  for (std::size_t k = m; k-- > 1;) w[k] = std::min(w[k], w[k + 1] + 2.0 * ps[k].accel * ps[k].length);
  for (std::size_t k = 1; k < m; ++k) w[k] = std::min(w[k], w[k - 1] + 2.0 * ps[k - 1].accel * ps[k - 1].length);

  // integral ds / V over each piece, V = min(cap, sqrt(wa + 2 A x), sqrt(wb + 2 A (L - x))).
  double time = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    const EnvelopePiece& p = ps[k];
    const double A = p.accel, L = p.length, c2 = p.cap * p.cap;
    if (!(L > 0.0)) continue;
    if (!std::isfinite(A)) {  // no acceleration limit: the cap all the way
      time += L / p.cap;
      continue;
    }
    const double wa = std::min(w[k], c2), wb = std::min(w[k + 1], c2);
    const double x1 = (c2 - wa) / (2.0 * A), x2 = L - (c2 - wb) / (2.0 * A);
    if (x1 <= x2) {
      time += (p.cap - std::sqrt(wa)) / A + (x2 - x1) / p.cap + (p.cap - std::sqrt(wb)) / A;
    } else {
      const double xm = std::clamp((wb - wa + 2.0 * A * L) / (4.0 * A), 0.0, L);
      const double wm = wa + 2.0 * A * xm;
      time += (std::sqrt(wm) - std::sqrt(wa)) / A + (std::sqrt(wm) - std::sqrt(wb)) / A;
    }
  }
  return time;
}

}  // namespace machplan::motion::internal
