#include "solvers/calibration/fit.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <Eigen/Dense>

#include "engine/common/error.h"
#include "engine/control/counter_decoder.h"

namespace machplan::calibration {
namespace {

constexpr int kCounterBits = 16;
enum P { kFeed = 0, kDead, kLag, kLatency, kBacklash, kParams };

inline double val(double x) { return x; }
template <typename J>
double val(const J& j) {
  return j.a;
}
inline double sgn(double x) { return x > 0 ? 1.0 : x < 0 ? -1.0 : 0.0; }

// One axis's samples, prepared for the fit.
struct AxisData {
  std::vector<double> u_mm_per_s;   // commanded speed per row (nominal DAC scale)
  std::vector<double> counts;       // unwrapped signed counts, 0 at the first row
  std::vector<char> valid;          // false: a rejected read (position held from the last good one)
  std::vector<char> dir_negative;
  std::vector<double> ref_counts, ref_mm;
  std::vector<int> lines;
  int rejected = 0;
};

// The model of the header, stepped over one sub-interval of length h with the command u.
template <typename T>
void advance(T& v, T& xm, T& xl, const T& h, double u, const T* p, double max_accel) {
  const T w = p[kFeed] * u;
  const double vs = val(v);
  const T& d = p[kDead];
  const T& tau = p[kLag];
  const T half_gap = 0.5 * p[kBacklash];
  T target;
  bool moving = true;
  if (vs == 0.0) {
    if (std::abs(val(w)) <= val(d)) {
      moving = false;  // friction holds the axis
    } else {
      target = w - d * sgn(val(w));
    }
  } else {
    target = w - d * sgn(vs);
  }
  if (moving) {
    using std::exp;
    T vnew, dx;
    const double gap = val(target) - vs;
    if (max_accel > 0 && std::abs(gap) > max_accel * val(tau)) {
      // The drive's current limit: constant acceleration until the lag takes over again.
      T dv = sgn(gap) * max_accel * h;
      if (std::abs(val(dv)) > std::abs(gap)) dv = target - v;
      vnew = v + dv;
      dx = 0.5 * (v + vnew) * h;
    } else {
      const T a = exp(-h / tau);
      vnew = target + (v - target) * a;
      dx = target * h + (v - target) * tau * (1.0 - a);
    }
    // Friction alone cannot reverse the motion: crossing zero with the drive inside the dead
    // band stops the axis.
    if (vs != 0.0 && sgn(val(vnew)) != sgn(vs) && std::abs(val(w)) <= val(d)) vnew = T(0.0);
    v = vnew;
    xm += dx;
  }
  if (xl < xm - half_gap) xl = xm - half_gap;
  if (xl > xm + half_gap) xl = xm + half_gap;
}

// One stroke: rows begin .. end (inclusive); the axis is at rest at `begin`.
struct StrokeCost {
  const AxisData* data;
  int begin, end;
  int gap_side;  // +1: the motor is b/2 ahead of the load (last motion positive); -1 behind; 0 mid-gap
  double mm_per_count, dt, max_accel;

  template <typename T>
  bool operator()(const T* p, const T* offset, T* r) const {
    const double y0 = mm_per_count * data->counts[begin];
    T v(0.0), xl(y0);
    T xm = xl + 0.5 * gap_side * p[kBacklash];
    const T lt = p[kLatency] / dt;
    const int m = static_cast<int>(std::floor(val(lt)));
    const T f = lt - static_cast<double>(m);
    const T h1 = f * dt, h2 = (1.0 - f) * dt;
    const auto& u = data->u_mm_per_s;
    auto at = [&](int j) { return j < 0 ? 0.0 : u[j]; };
    for (int i = begin + 1; i <= end; ++i) {
      advance(v, xm, xl, h1, at(i - m - 1), p, max_accel);
      advance(v, xm, xl, h2, at(i - m), p, max_accel);
      r[i - begin - 1] = data->valid[i] ? xl + offset[0] - mm_per_count * data->counts[i] : T(0.0);
    }
    return true;
  }
};

struct RefCost {
  double counts, ref_mm;
  template <typename T>
  bool operator()(const T* x0_s, T* r) const {
    r[0] = x0_s[0] + x0_s[1] * counts - ref_mm;
    return true;
  }
};

// (J^T J)^-1 of the problem's blocks, in the order given; false when singular.
// The columns are those of the tangent spaces (a parameter held fixed has none).
bool covariance(ceres::Problem& problem, const std::vector<double*>& blocks, Eigen::MatrixXd& cov, double& sum_sq,
                int& n_res) {
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = false;
  std::vector<double> res;
  ceres::CRSMatrix J;
  double cost = 0;
  if (!problem.Evaluate(eo, &cost, &res, nullptr, &J)) return false;
  const int n_params = J.num_cols;
  Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n_params, n_params);
  sum_sq = 0;
  n_res = 0;
  for (int row = 0; row < J.num_rows; ++row) {
    if (res[row] != 0.0) {
      sum_sq += res[row] * res[row];
      ++n_res;
    }
    for (int a = J.rows[row]; a < J.rows[row + 1]; ++a)
      for (int b = J.rows[row]; b < J.rows[row + 1]; ++b) jtj(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
  }
  // Scale to unit diagonal before inverting so that mm, s and ratios mix without loss.
  Eigen::VectorXd dscale(n_params);
  for (int i = 0; i < n_params; ++i) {
    if (!(jtj(i, i) > 0)) return false;
    dscale[i] = 1.0 / std::sqrt(jtj(i, i));
  }
  const Eigen::MatrixXd scaled = dscale.asDiagonal() * jtj * dscale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
  if (es.info() != Eigen::Success) return false;
  const double lmin = es.eigenvalues().minCoeff(), lmax = es.eigenvalues().maxCoeff();
  if (!(lmin > 1e-12 * lmax)) return false;
  cov = dscale.asDiagonal() * es.eigenvectors() * es.eigenvalues().cwiseInverse().asDiagonal() *
        es.eigenvectors().transpose() * dscale.asDiagonal();
  return true;
}

AxisData prepare(const SessionLog& log, int axis, const axis::AxisPlantParams& nominal, double& dt_out) {
  AxisData d;
  std::vector<const LogSample*> rows;
  for (const auto& s : log.samples)
    if (s.axis == axis) rows.push_back(&s);
  if (rows.size() < 3) return d;
  // Sampling period: the median spacing; the model needs one row per period.
  std::vector<double> gaps;
  for (std::size_t k = 1; k < rows.size(); ++k) gaps.push_back(rows[k]->t_s - rows[k - 1]->t_s);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  const double dt = gaps[gaps.size() / 2];
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const double g = rows[k]->t_s - rows[k - 1]->t_s;
    if (std::abs(g - dt) > 0.02 * dt)
      throw InputError(log.source, rows[k]->line,
                       fmt::format("axis {}: samples {:.6f} s apart where the log's period is {:.6f} s; the fit needs "
                                   "one sample per period",
                                   axis_name(axis), g, dt));
  }
  if (dt_out > 0 && std::abs(dt - dt_out) > 0.02 * dt_out)
    throw InputError(log.source, rows[1]->line,
                     fmt::format("axis {} is sampled every {:.6f} s, the other axis every {:.6f} s", axis_name(axis), dt,
                                 dt_out));
  dt_out = dt;
  const double full_scale = nominal.dac_full_scale_mm_per_s();
  const double q = nominal.mm_per_count();
  // A read further than twice the top speed allows in one period cannot be motion.
  const std::int64_t max_counts = static_cast<std::int64_t>(std::ceil(2.0 * nominal.max_speed_mm_per_s() * dt / q)) + 8;
  std::uint32_t last = rows[0]->counter;
  double pos = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const LogSample& s = *rows[k];
    bool ok = true;
    if (k > 0) {
      const std::int64_t delta = control::down_counter_delta(last, s.counter, s.direction_negative, kCounterBits);
      if (std::llabs(delta) > max_counts) {
        ok = false;
        ++d.rejected;
      } else {
        pos += static_cast<double>(delta);
        last = s.counter;
      }
    }
    d.u_mm_per_s.push_back(static_cast<double>(s.dac) / 2048.0 * full_scale);
    d.counts.push_back(pos);
    d.valid.push_back(ok);
    d.dir_negative.push_back(s.direction_negative);
    d.lines.push_back(s.line);
    if (s.has_ref && ok) {
      d.ref_counts.push_back(pos);
      d.ref_mm.push_back(s.ref_mm);
    }
  }
  return d;
}

double rel(double sigma, double value) { return value != 0 ? sigma / std::abs(value) : HUGE_VAL; }

// Whether the axis was commanded and moved at all (else the reason is added to f).
bool axis_moved(const AxisData& d, AxisFit& f) {
  const int n = static_cast<int>(d.counts.size());
  if (n < 3) {
    f.not_identifiable.push_back("feed_factor: the log has no samples of this axis");
    return false;
  }
  bool commanded = false, moved = false;
  for (int i = 0; i < n; ++i) {
    commanded |= d.u_mm_per_s[i] != 0.0;
    moved |= d.counts[i] != 0.0;
  }
  if (!commanded) {
    f.not_identifiable.push_back("feed_factor: no speed command was ever given to this axis");
    return false;
  }
  if (!moved) {
    f.not_identifiable.push_back("feed_factor: the axis never moved (its counter did not change)");
    return false;
  }
  return true;
}

// Stage 1: the encoder scale from the reference readings (Cauchy loss), the readings' robust
// scatter, outliers and the scale's sigma into f. Returns false (the nominal scale kept, the
// reasons added to f) when the readings do not determine it.
bool fit_encoder_scale(const AxisData& d, const FitOptions& o, AxisFit& f) {
  double& s = f.mm_per_count;
  double ref_lo = HUGE_VAL, ref_hi = -HUGE_VAL;
  for (double c : d.ref_counts) ref_lo = std::min(ref_lo, c), ref_hi = std::max(ref_hi, c);
  const bool scale_ok = d.ref_mm.size() >= 2 && ref_hi - ref_lo >= 100;
  if (!scale_ok) {
    f.not_identifiable.push_back(d.ref_mm.empty()
                                     ? "mm_per_count: the log has no reference readings"
                                     : "mm_per_count: fewer than two reference readings at places 100 counts or more apart");
    f.not_identifiable.push_back("feed_factor: in mm it needs the encoder scale, which the log does not determine");
    return false;
  }
  double xs[2] = {d.ref_mm[0] - s * d.ref_counts[0], s};
  ceres::Problem pr;
  for (std::size_t j = 0; j < d.ref_mm.size(); ++j)
    pr.AddResidualBlock(new ceres::AutoDiffCostFunction<RefCost, 1, 2>(new RefCost{d.ref_counts[j], d.ref_mm[j]}),
                        new ceres::CauchyLoss(o.ruler_cauchy_mm), xs);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &pr, &sum);
  s = xs[1];
  Eigen::MatrixXd cov;
  double ss = 0;
  int nr = 0;
  // The readings' scatter, robustly (a misread ruler must not inflate it): the median
  // absolute residual, scaled to a standard deviation; readings beyond 5 of it are outliers.
  double ruler_ss = 0;
  std::vector<double> absr;
  for (std::size_t j = 0; j < d.ref_mm.size(); ++j) {
    const double r = xs[0] + s * d.ref_counts[j] - d.ref_mm[j];
    ruler_ss += r * r;
    absr.push_back(std::abs(r));
  }
  f.ruler_rms_mm = std::sqrt(ruler_ss / d.ref_mm.size());
  std::nth_element(absr.begin(), absr.begin() + absr.size() / 2, absr.end());
  const double ruler_sigma = std::max(1.4826 * absr[absr.size() / 2], 1e-6);
  for (std::size_t j = 0; j < d.ref_mm.size(); ++j)
    if (std::abs(xs[0] + s * d.ref_counts[j] - d.ref_mm[j]) > 5 * ruler_sigma) ++f.ruler_outliers;
  const double dof = static_cast<double>(d.ref_mm.size()) - 2.0;
  if (dof > 0 && covariance(pr, {xs}, cov, ss, nr)) {
    f.sigma.mm_per_count = std::sqrt(cov(1, 1)) * ruler_sigma * std::sqrt(d.ref_mm.size() / dof);
  } else {
    f.sigma.mm_per_count = HUGE_VAL;
  }
  return true;
}

// What the session holds for the dynamics: where strokes start (at dwells: zero command, axis
// at rest, long enough to cover the latency), how often the command reversed, and the speeds
// held for at least 0.2 s.
struct Strokes {
  int min_dwell = 0;  // periods
  std::vector<int> starts;
  int reversals = 0;
  std::vector<double> levels;
};

Strokes find_strokes(const AxisData& d, double dt, const FitOptions& o) {
  const int n = static_cast<int>(d.counts.size());
  Strokes st;
  st.min_dwell = std::max(3, static_cast<int>(std::lround(o.min_dwell_s / dt)));
  int zero_run = 0;
  for (int i = 0; i < n; ++i) {
    zero_run = d.u_mm_per_s[i] == 0.0 ? zero_run + 1 : 0;
    const bool next_moves = i + 1 < n && d.u_mm_per_s[i + 1] != 0.0;
    if (next_moves && i >= 3 && zero_run >= st.min_dwell && d.valid[i] && d.counts[i] == d.counts[i - 3])
      st.starts.push_back(i);
  }
  int last_sign = 0;
  for (int i = 0; i < n; ++i) {
    const int sg = static_cast<int>(sgn(d.u_mm_per_s[i]));
    if (sg != 0 && last_sign != 0 && sg != last_sign) ++st.reversals;
    if (sg != 0) last_sign = sg;
  }
  int run = 0;
  for (int i = 1; i < n; ++i) {
    run = d.u_mm_per_s[i] == d.u_mm_per_s[i - 1] ? run + 1 : 0;
    if (run == static_cast<int>(0.2 / dt) && d.u_mm_per_s[i] != 0.0) {
      const double a = std::abs(d.u_mm_per_s[i]);
      if (std::none_of(st.levels.begin(), st.levels.end(), [&](double l) { return std::abs(l - a) < 1e-9; }))
        st.levels.push_back(a);
    }
  }
  return st;
}

// Stage 2's problem: the parameters p (started from the nominal machine, the feed factor from
// the distance travelled against the distance commanded), one residual block per stroke with
// its position offset, bounds, and the parameters held fixed (returned) when the data cannot
// move them.
std::vector<int> build_dynamics(ceres::Problem& pr, const AxisData& d, const Strokes& st, double s, double dt,
                                const axis::AxisPlantParams& nom, const FitOptions& o, double* p,
                                std::vector<double>& offsets) {
  const int n = static_cast<int>(d.counts.size());
  const bool dead_band_free = st.levels.size() >= 2;
  const double kv = 1.0 + nom.viscous_friction_ratio;
  double moved_mm = 0, commanded_mm = 0;
  for (int i = 1; i < n; ++i) {
    if (d.valid[i] && d.valid[i - 1]) moved_mm += std::abs(d.counts[i] - d.counts[i - 1]) * s;
    commanded_mm += std::abs(d.u_mm_per_s[i]) * dt;
  }
  p[kFeed] = std::clamp(moved_mm / commanded_mm, 0.05, 5.0);
  p[kDead] = dead_band_free ? nom.coulomb_friction_mm_per_s / kv : 0.0;
  p[kLag] = std::max(nom.velocity_loop_time_constant_s / kv, 2 * dt);
  p[kLatency] = (nom.command_latency_ticks + nom.reading_latency_ticks + 0.5) * dt;
  p[kBacklash] = st.reversals > 0 ? std::max(nom.backlash_mm, 0.01) : 0.0;
  const double max_latency = std::min(0.05, (st.min_dwell - 2) * dt);
  p[kLatency] = std::min(p[kLatency], 0.5 * max_latency);

  const auto& starts = st.starts;
  offsets.assign(starts.size(), 0.0);
  for (std::size_t k = 0; k < starts.size(); ++k) {
    const int b = starts[k];
    const int e = k + 1 < starts.size() ? starts[k + 1] : n - 1;
    if (e <= b) continue;
    bool moved_before = false;
    for (int i = 0; i <= b && !moved_before; ++i) moved_before = d.counts[i] != d.counts[0];
    const int side = !moved_before ? 0 : d.dir_negative[b] ? -1 : +1;
    auto* cost = new ceres::AutoDiffCostFunction<StrokeCost, ceres::DYNAMIC, kParams, 1>(
        new StrokeCost{&d, b, e, side, s, dt, nom.max_acceleration_mm_per_s2}, e - b);
    pr.AddResidualBlock(cost, new ceres::HuberLoss(o.huber_mm * std::sqrt(static_cast<double>(e - b))), p,
                        &offsets[k]);
  }
  pr.SetParameterLowerBound(p, kFeed, 0.01);
  pr.SetParameterUpperBound(p, kFeed, 10.0);
  pr.SetParameterLowerBound(p, kDead, 0.0);
  pr.SetParameterUpperBound(p, kDead, 100.0);
  pr.SetParameterLowerBound(p, kLag, 1e-4);
  pr.SetParameterUpperBound(p, kLag, 2.0);
  pr.SetParameterLowerBound(p, kLatency, 0.0);
  pr.SetParameterUpperBound(p, kLatency, max_latency);
  pr.SetParameterLowerBound(p, kBacklash, 0.0);
  pr.SetParameterUpperBound(p, kBacklash, 10.0);
  std::vector<int> fixed;
  if (!dead_band_free) fixed.push_back(kDead);
  if (st.reversals == 0) fixed.push_back(kBacklash);
  if (!fixed.empty()) pr.SetManifold(p, new ceres::SubsetManifold(kParams, fixed));
  return fixed;
}

// Charges each iteration of the dynamics fit to the Termination (one unit, and the seconds of
// session it integrates once more) and reports it to the progress; aborts the solve when the
// Termination ends.
class FitIterations final : public ceres::IterationCallback {
 public:
  FitIterations(Termination& term, Progress* progress, int max_iterations, double session_s)
      : term_(term), progress_(progress), max_iterations_(max_iterations), session_s_(session_s) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    term_.charge(1, session_s_);
    report_progress(progress_, static_cast<double>(it.iteration + 1) / max_iterations_);
    return term_.should_end() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  Termination& term_;
  Progress* progress_;
  int max_iterations_;
  double session_s_;
};

// Per held command: the steady speed over the second half of each hold of 0.2 s or more, as
// a feed factor with the fitted dead band; and their spread against the one feed factor.
void measure_by_speed(const AxisData& d, double s, double dt, const double* p, AxisFit& f) {
  const int n = static_cast<int>(d.counts.size());
  std::vector<SpeedLevel> lv;
  std::vector<double> dist;  // mm travelled, per level
  int i = 1;
  while (i < n) {
    int j = i;
    while (j + 1 < n && d.u_mm_per_s[j + 1] == d.u_mm_per_s[i]) ++j;
    const double u = d.u_mm_per_s[i];
    if (u != 0.0 && (j - i) * dt >= 0.2) {
      const int a = i + (j - i) / 2, b = j;
      bool ok = true;
      for (int k = a; k <= b && ok; ++k) ok = d.valid[k];
      if (ok) {
        auto it = std::find_if(lv.begin(), lv.end(), [&](const SpeedLevel& l) { return l.command_mm_per_s == u; });
        if (it == lv.end()) {
          lv.push_back({u, 0.0, 0.0});
          dist.push_back(0.0);
          it = lv.end() - 1;
        }
        it->seconds += (b - a) * dt;
        dist[it - lv.begin()] += (d.counts[b] - d.counts[a]) * s;
      }
    }
    i = j + 1;
  }
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (std::size_t k = 0; k < lv.size(); ++k) {
    const double v = dist[k] / lv[k].seconds;
    lv[k].feed_factor = (v + p[kDead] * sgn(lv[k].command_mm_per_s)) / lv[k].command_mm_per_s;
    lo = std::min(lo, lv[k].feed_factor);
    hi = std::max(hi, lv[k].feed_factor);
  }
  std::sort(lv.begin(), lv.end(), [](const auto& x, const auto& y) { return x.command_mm_per_s < y.command_mm_per_s; });
  f.by_speed = lv;
  f.by_speed_spread = lv.size() >= 2 ? (hi - lo) / p[kFeed] : 0.0;
}

// Uncertainties: (J^T J)^-1 over all blocks (the stroke offsets too), scaled by the residual
// variance; the free parameters' block of it. A parameter whose sigma is too large for the
// options is reported as not identifiable.
void fit_uncertainties(ceres::Problem& pr, double* p, std::vector<double>& offsets, const std::vector<int>& fixed,
                       const Strokes& st, bool scale_ok, const FitOptions& o, AxisFit& f) {
  auto problem = [&](const std::string& what) { f.not_identifiable.push_back(what); };
  const bool dead_band_free = st.levels.size() >= 2;
  std::vector<double*> blocks{p};
  for (auto& off : offsets) blocks.push_back(&off);
  const int np = kParams - static_cast<int>(fixed.size()) + static_cast<int>(offsets.size());
  Eigen::MatrixXd cov;
  double ss = 0;
  int nr = 0;
  const bool cov_ok = covariance(pr, blocks, cov, ss, nr);
  int col[kParams];
  for (int i = 0, c = 0; i < kParams; ++i)
    col[i] = std::find(fixed.begin(), fixed.end(), i) != fixed.end() ? -1 : c++;
  f.rms_residual_mm = nr > 0 ? std::sqrt(ss / nr) : 0.0;
  if (!cov_ok) {
    problem("lag_s, latency_s: the data leave the parameters correlated beyond telling apart (singular covariance)");
    return;
  }
  const double var = nr > np ? ss / (nr - np) : 0.0;
  auto sd = [&](int i) { return col[i] < 0 ? 0.0 : std::sqrt(std::max(0.0, cov(col[i], col[i]) * var)); };
  f.sigma.feed_factor = std::hypot(sd(kFeed), f.feed_factor * f.sigma.mm_per_count / f.mm_per_count);
  if (!scale_ok) f.sigma.feed_factor = sd(kFeed);
  f.sigma.dead_band_mm_per_s = dead_band_free ? sd(kDead) : 0.0;
  f.sigma.lag_s = sd(kLag);
  f.sigma.latency_s = sd(kLatency);
  f.sigma.backlash_mm = st.reversals > 0 ? sd(kBacklash) : 0.0;
  if (rel(f.sigma.feed_factor, f.feed_factor) > o.max_relative_sigma)
    problem(fmt::format("feed_factor: sigma {:.3g} is over {:.0f} % of it", f.sigma.feed_factor, 100 * o.max_relative_sigma));
  if (rel(f.sigma.lag_s, f.lag_s) > o.max_relative_sigma * 4)
    problem(fmt::format("lag_s: sigma {:.3g} s is over {:.0f} % of it (too few speed steps?)", f.sigma.lag_s,
                        400 * o.max_relative_sigma));
  if (f.sigma.latency_s > o.max_latency_sigma_s)
    problem(fmt::format("latency_s: sigma {:.3g} s is over {} s", f.sigma.latency_s, o.max_latency_sigma_s));
  if (st.reversals > 0 && f.sigma.backlash_mm > o.max_backlash_sigma_mm)
    problem(fmt::format("backlash_mm: sigma {:.3g} mm is over {} mm", f.sigma.backlash_mm, o.max_backlash_sigma_mm));
  if (scale_ok && rel(f.sigma.mm_per_count, f.mm_per_count) > o.max_relative_sigma)
    problem(fmt::format("mm_per_count: sigma {:.3g} is over {:.0f} % of it", f.sigma.mm_per_count,
                        100 * o.max_relative_sigma));
}

AxisFit fit_axis(const AxisData& d, int axis, const cutting::MachineConfig& machine, double dt, const FitOptions& o,
                 Termination& term, Progress* progress) {
  const auto& nom = machine.axes[axis].plant;
  AxisFit f;
  f.axis = axis_name(axis);
  const int n = static_cast<int>(d.counts.size());
  f.samples = n;
  f.rejected_reads = d.rejected;
  f.references = static_cast<int>(d.ref_mm.size());
  if (!axis_moved(d, f)) return f;

  // Stage 1: encoder scale from the reference readings.
  f.mm_per_count = nom.mm_per_count();
  const bool scale_ok = fit_encoder_scale(d, o, f);
  const double s = f.mm_per_count;

  const Strokes st = find_strokes(d, dt, o);
  if (st.starts.empty()) {
    f.not_identifiable.push_back(
        fmt::format("lag_s: no stroke starts from rest after {:.3f} s of zero command", o.min_dwell_s));
    return f;
  }
  if (st.levels.size() < 2)
    f.not_identifiable.push_back(
        "dead_band_mm_per_s: strokes at fewer than two speeds held 0.2 s or more cannot tell it from the feed factor");
  if (st.reversals == 0) f.not_identifiable.push_back("backlash_mm: the axis never reversed");

  // Stage 2: dynamics.
  ceres::Problem pr;
  double p[kParams];
  std::vector<double> offsets;
  const std::vector<int> fixed = build_dynamics(pr, d, st, s, dt, nom, o, p, offsets);
  f.strokes = static_cast<int>(st.starts.size());
  FitIterations callback(term, progress, o.max_iterations, n * dt);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  so.callbacks.push_back(&callback);
  ceres::Solver::Summary sum;
  ceres::Solve(so, &pr, &sum);
  f.iterations = static_cast<int>(sum.iterations.size());
  if (term.ended()) return f;  // not fitted: the caller says what ended the work
  if (!sum.IsSolutionUsable()) {
    f.not_identifiable.push_back(fmt::format("feed_factor: the solver failed: {}", sum.message));
    return f;
  }
  measure_by_speed(d, s, dt, p, f);
  f.feed_factor = p[kFeed];
  f.dead_band_mm_per_s = p[kDead];
  f.lag_s = p[kLag];
  f.latency_s = p[kLatency];
  f.backlash_mm = p[kBacklash];
  f.fitted = true;
  fit_uncertainties(pr, p, offsets, fixed, st, scale_ok, o, f);
  return f;
}

}  // namespace

void FitOptions::validate() const {
  auto bad = [](const char* field, double v, const char* rule) {
    throw InputError::field(field, fmt::format("{} {}", v, rule));
  };
  if (!(huber_mm > 0 && huber_mm < 100)) bad("huber_mm", huber_mm, "is not in (0, 100) mm");
  if (!(ruler_cauchy_mm > 0 && ruler_cauchy_mm < 100)) bad("ruler_cauchy_mm", ruler_cauchy_mm, "is not in (0, 100) mm");
  if (max_iterations < 1 || max_iterations > 10000) bad("max_iterations", max_iterations, "is not in 1 .. 10000");
  if (!(min_dwell_s > 0 && min_dwell_s < 10)) bad("min_dwell_s", min_dwell_s, "is not in (0, 10) s");
  if (!(max_relative_sigma > 0)) bad("max_relative_sigma", max_relative_sigma, "is not positive");
  if (!(max_backlash_sigma_mm > 0)) bad("max_backlash_sigma_mm", max_backlash_sigma_mm, "is not positive");
  if (!(max_latency_sigma_s > 0)) bad("max_latency_sigma_s", max_latency_sigma_s, "is not positive");
}

namespace {

// One parameter line of the report, marked when the fit could not determine it.
std::string parameter_line(const AxisFit& a, const char* label, const char* name, const std::string& figures) {
  const bool undetermined = std::any_of(a.not_identifiable.begin(), a.not_identifiable.end(), [&](const std::string& p) {
    return p.rfind(name, 0) == 0 || p.find(std::string(", ") + name) != std::string::npos;
  });
  return fmt::format("    {:<13} {}{}\n", label, figures, undetermined ? "   (not identifiable)" : "");
}

std::string full_report(const CalibrationFit& fit) {
  const Summary& sum = fit.summary;
  std::string s =
      fmt::format("calibration fit for {} (period {:.6f} s): {}\n", fit.machine, fit.period_s, to_string(sum.status));
  if (!sum.message.empty()) s += fmt::format("  {}\n", sum.message);
  if (sum.status == Status::infeasible)
    s += "  the figures below are where the solver ended; those marked are not determined by the log\n";
  for (const auto& a : fit.axes) {
    if (!a.fitted) {
      s += fmt::format("  axis {}: not fitted\n", a.axis);
      continue;
    }
    s += fmt::format("  axis {}: {} samples, {} references, {} strokes, {} rejected reads, {} iterations\n", a.axis,
                     a.samples, a.references, a.strokes, a.rejected_reads, a.iterations);
    s += parameter_line(a, "mm_per_count", "mm_per_count", fmt::format("{:.7f} +- {:.2g}", a.mm_per_count, a.sigma.mm_per_count));
    s += parameter_line(a, "feed_factor", "feed_factor", fmt::format("{:.5f} +- {:.2g}", a.feed_factor, a.sigma.feed_factor));
    s += parameter_line(a, "dead band", "dead_band_mm_per_s",
                        fmt::format("{:.4f} +- {:.2g} mm/s", a.dead_band_mm_per_s, a.sigma.dead_band_mm_per_s));
    s += parameter_line(a, "backlash", "backlash_mm", fmt::format("{:.4f} +- {:.2g} mm", a.backlash_mm, a.sigma.backlash_mm));
    s += parameter_line(a, "lag", "lag_s", fmt::format("{:.5f} +- {:.2g} s", a.lag_s, a.sigma.lag_s));
    s += parameter_line(a, "latency", "latency_s", fmt::format("{:.5f} +- {:.2g} s", a.latency_s, a.sigma.latency_s));
    s += fmt::format("    rms residual  {:.4f} mm (ruler {:.4f} mm, {} outlying readings)\n", a.rms_residual_mm,
                     a.ruler_rms_mm, a.ruler_outliers);
    if (!a.by_speed.empty()) {
      s += "    feed factor by commanded speed:";
      for (const auto& l : a.by_speed) s += fmt::format(" {:.1f}: {:.4f}", l.command_mm_per_s, l.feed_factor);
      s += fmt::format(" mm/s (spread {:.2f} %)\n", 100 * a.by_speed_spread);
    }
  }
  if (fit.axes[0].fitted || fit.axes[1].fitted) s += fmt::format("  rms residual {:.4f} mm\n", fit.rms_residual_mm);
  return s;
}

std::string brief_report(const CalibrationFit& fit) {
  const Summary& sum = fit.summary;
  if (sum.done())
    return fmt::format("calibration fit for {}: done, feed factor x {:.5f} y {:.5f}, backlash x {:.4f} y {:.4f} mm, "
                       "rms residual {:.4f} mm",
                       fit.machine, fit.axes[0].feed_factor, fit.axes[1].feed_factor, fit.axes[0].backlash_mm,
                       fit.axes[1].backlash_mm, fit.rms_residual_mm);
  return fmt::format("calibration fit for {}: {}: {}", fit.machine, to_string(sum.status), sum.message);
}

}  // namespace

CalibrationFit fit_session(const SessionLog& log, const cutting::MachineConfig& machine, const FitOptions& o) {
  Termination unlimited;
  return fit_session(log, machine, o, unlimited, nullptr);
}

CalibrationFit fit_session(const SessionLog& log, const cutting::MachineConfig& machine, const FitOptions& o,
                           Termination& term, Progress* progress) {
  o.validate();
  CalibrationFit out;
  out.machine = machine.name;
  double dt = 0;
  std::array<AxisData, 2> data;
  for (int a = 0; a < 2; ++a) data[a] = prepare(log, a, machine.axes[a].plant, dt);
  out.period_s = dt;
  double ss = 0;
  long nr = 0;
  std::vector<std::string> problems;
  for (int a = 0; a < 2; ++a) {
    out.axes[a].axis = axis_name(a);
    if (term.should_end()) continue;
    Progress part(progress, 0.5 * a, 0.5 * (a + 1));
    out.axes[a] = fit_axis(data[a], a, machine, dt, o, term, &part);
    const auto& f = out.axes[a];
    if (f.fitted) {
      const long m = f.samples - f.strokes;
      ss += f.rms_residual_mm * f.rms_residual_mm * m;
      nr += m;
    }
    for (const auto& p : f.not_identifiable) problems.push_back(fmt::format("{}.{}", f.axis, p));
  }
  out.rms_residual_mm = nr > 0 ? std::sqrt(ss / nr) : 0.0;
  if (term.ended()) {
    out.summary.status = status_of(term.reason());
    out.summary.message = fmt::format("the fit did not finish: {}", term.describe());
  } else if (!problems.empty()) {
    out.summary.status = Status::infeasible;
    out.summary.message = fmt::format("{}", fmt::join(problems, "; "));
  }
  out.summary.brief = brief_report(out);
  out.summary.full = full_report(out);
  if (progress) progress->finish();
  return out;
}

AxisFit true_factors(const cutting::MachineConfig& truth, const cutting::MachineConfig& nominal, int axis) {
  const auto& t = truth.axes[axis].plant;
  const auto& n = nominal.axes[axis].plant;
  const double kv = 1.0 + t.viscous_friction_ratio;
  AxisFit f;
  f.axis = axis_name(axis);
  f.fitted = true;
  f.mm_per_count = t.mm_per_count();
  f.feed_factor = t.gain_factor * t.dac_full_scale_mm_per_s() / n.dac_full_scale_mm_per_s() / kv;
  f.dead_band_mm_per_s = t.coulomb_friction_mm_per_s / kv;
  f.lag_s = t.velocity_loop_time_constant_s / kv;
  f.latency_s = (t.command_latency_ticks + t.reading_latency_ticks) * truth.servo_period_s;
  f.backlash_mm = t.backlash_mm;
  return f;
}

std::string CalibrationFit::json() const {
  using nlohmann::json;
  json j;
  j["machine"] = machine;
  j["status"] = to_string(summary.status);
  j["message"] = summary.message;
  j["period_s"] = period_s;
  j["rms_residual_mm"] = rms_residual_mm;
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  for (const auto& a : axes) {
    json x;
    x["fitted"] = a.fitted;
    x["mm_per_count"] = num(a.mm_per_count);
    x["feed_factor"] = num(a.feed_factor);
    x["dead_band_mm_per_s"] = num(a.dead_band_mm_per_s);
    x["backlash_mm"] = num(a.backlash_mm);
    x["lag_s"] = num(a.lag_s);
    x["latency_s"] = num(a.latency_s);
    x["sigma"] = {{"mm_per_count", num(a.sigma.mm_per_count)},   {"feed_factor", num(a.sigma.feed_factor)},
                  {"dead_band_mm_per_s", num(a.sigma.dead_band_mm_per_s)}, {"backlash_mm", num(a.sigma.backlash_mm)},
                  {"lag_s", num(a.sigma.lag_s)},                 {"latency_s", num(a.sigma.latency_s)}};
    x["rms_residual_mm"] = num(a.rms_residual_mm);
    x["ruler_rms_mm"] = num(a.ruler_rms_mm);
    x["ruler_outliers"] = a.ruler_outliers;
    x["samples"] = a.samples;
    x["references"] = a.references;
    x["strokes"] = a.strokes;
    x["rejected_reads"] = a.rejected_reads;
    x["not_identifiable"] = a.not_identifiable;
    x["by_speed_spread"] = num(a.by_speed_spread);
    x["feed_factor_by_speed"] = json::array();
    for (const auto& l : a.by_speed)
      x["feed_factor_by_speed"].push_back(
          {{"command_mm_per_s", l.command_mm_per_s}, {"feed_factor", l.feed_factor}, {"seconds", l.seconds}});
    j["axes"][a.axis] = x;
  }
  return j.dump(2);
}

}  // namespace machplan::calibration
