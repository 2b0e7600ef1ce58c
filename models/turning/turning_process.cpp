#include "models/turning/turning_process.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::turning {
namespace {

void require(bool ok, const std::string& field, double v, const char* rule) {
  require_field(ok, field, v, rule);
}

// A portable standard normal draw (Box-Muller on the engine's raw bits), so that the same seed
// gives the same run with every standard library.
double gaussian(std::mt19937_64& rng) {
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace

void TurningProcess::validate() const {
  require(std::isfinite(ks_n_per_mm) && ks_n_per_mm > 0, "ks_n_per_mm", ks_n_per_mm, "must be > 0");
  require(std::isfinite(beta) && beta > 0 && beta <= 2, "beta", beta, "must be in (0, 2]");
  require(std::isfinite(feed_time_constant_s) && feed_time_constant_s >= 0, "feed_time_constant_s", feed_time_constant_s,
          "must be >= 0");
  require(std::isfinite(force_time_constant_s) && force_time_constant_s >= 0, "force_time_constant_s",
          force_time_constant_s, "must be >= 0");
  require(std::isfinite(force_noise_n) && force_noise_n >= 0, "force_noise_n", force_noise_n, "must be >= 0");
  require(std::isfinite(dt_s) && dt_s > 0 && dt_s <= 0.01, "dt_s", dt_s, "must be in (0, 0.01]");
}

double TurningProcess::static_force_n(double depth_mm, double feed_mm_per_rev) const {
  if (depth_mm <= 0 || feed_mm_per_rev <= 0) return 0.0;
  return ks_n_per_mm * depth_mm * std::pow(feed_mm_per_rev, beta);
}

double TurningProcess::feed_for_force(double depth_mm, double force_n) const {
  if (depth_mm <= 0) return std::numeric_limits<double>::infinity();
  return std::pow(force_n / (ks_n_per_mm * depth_mm), 1.0 / beta);
}

std::vector<AccSample> simulate_acc(const TurningProcess& p, const control::AccOptions& o, const std::vector<DepthChange>& depths,
                                    double duration_s, std::uint64_t seed) {
  p.validate();
  o.validate();
  require(std::isfinite(duration_s) && duration_s > 0 && duration_s <= 3600, "duration_s", duration_s,
          "must be in (0, 3600]");
  for (std::size_t i = 0; i < depths.size(); ++i) {
    require(std::isfinite(depths[i].depth_mm) && depths[i].depth_mm >= 0 && depths[i].depth_mm <= 100, "depth_mm",
            depths[i].depth_mm, "must be in [0, 100]");
    require(std::isfinite(depths[i].from_s) && (i == 0 || depths[i].from_s >= depths[i - 1].from_s), "from_s",
            depths[i].from_s, "must be finite and not before the previous change");
  }
  std::mt19937_64 rng(seed);
  control::AccController ctl(o, p.beta);
  const long steps = std::lround(duration_s / p.dt_s);
  const long per_sample = std::max(1L, std::lround(o.sample_s / p.dt_s));
  std::vector<AccSample> out;
  out.reserve(static_cast<std::size_t>(steps / per_sample + 2));
  double f = 0.0, force = 0.0;  // the feed starts from rest, the tool in air
  double cmd = ctl.feed_mm_per_rev();
  std::size_t next_depth = 0;
  double depth = 0.0;
  const double a_feed = p.feed_time_constant_s > 0 ? 1.0 - std::exp(-p.dt_s / p.feed_time_constant_s) : 1.0;
  const double a_force = p.force_time_constant_s > 0 ? 1.0 - std::exp(-p.dt_s / p.force_time_constant_s) : 1.0;
  for (long k = 0; k <= steps; ++k) {
    const double t = static_cast<double>(k) * p.dt_s;
    while (next_depth < depths.size() && depths[next_depth].from_s <= t + 1e-12) depth = depths[next_depth++].depth_mm;
    if (k % per_sample == 0) {
      const double measured = force + (p.force_noise_n > 0 ? p.force_noise_n * gaussian(rng) : 0.0);
      cmd = ctl.update(measured);
      out.push_back({t, depth, cmd, f, force, measured});
    }
    f += a_feed * (cmd - f);
    force += a_force * (p.static_force_n(depth, f) - force);
  }
  return out;
}

std::vector<DepthChange> koren_depth_steps() { return {{1.0, 2.0}, {4.0, 4.0}, {7.0, 6.0}}; }

AccStepResponse acc_step_response(const std::vector<AccSample>& run, double fr, double from_s, double to_s, double band) {
  AccStepResponse r;
  int push = 0;          // +1: the change pushed the force above F_r; -1 below
  bool crossed = false;  // the force came back across F_r
  double last_out = -1;  // last instant outside the band
  double last_t = from_s;
  double at_change = std::numeric_limits<double>::quiet_NaN();
  for (const AccSample& s : run) {
    if (s.t_s < from_s - 1e-12 || s.t_s > to_s + 1e-12) continue;
    if (std::isnan(at_change)) at_change = s.force_n;
    const double dev = (s.force_n - fr) / fr;
    // The push: the first deviation beyond the band in the direction the force moves from
    // where it was at the change (an engagement from air rises through F_r: not a push below).
    if (push == 0 && std::abs(dev) > band && (s.force_n - at_change) * dev > 0) push = dev > 0 ? 1 : -1;
    if (push != 0 && !crossed && dev * push <= 0) crossed = true;
    if (crossed) r.overshoot = std::max(r.overshoot, -dev * push);
    if (std::abs(dev) > band) last_out = s.t_s;
    r.final_error = std::abs(dev);
    last_t = s.t_s;
  }
  if (last_out < 0) r.settling_s = 0.0;
  else if (last_out >= last_t - 1e-12) r.settling_s = std::numeric_limits<double>::infinity();
  else r.settling_s = last_out - from_s;
  return r;
}

}  // namespace machplan::turning
