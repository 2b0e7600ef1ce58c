#include "solvers/tuning/acc_tuning.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::tuning {

void AccTuningOptions::validate() const {
  validate_member("process", process);
  validate_member("acc", acc);
  if (base_depths_mm.empty()) throw InputError::field("base_depths_mm", "is empty");
  for (double d : base_depths_mm)
    if (!(d > 0 && d <= 50)) throw InputError::field("base_depths_mm", fmt::format("{} mm is out of range (0, 50]", d));
  if (!(depth_step_mm > 0 && depth_step_mm <= 50))
    throw InputError::field("depth_step_mm", fmt::format("{} mm is out of range (0, 50]", depth_step_mm));
  if (!(settle_before_step_s > 0 && window_s > 0 && settle_before_step_s + window_s <= 600))
    throw InputError::field("window_s", "settling and window times must be > 0 and together <= 600 s");
  if (!(band > 0 && band < 0.5)) throw InputError::field("band", fmt::format("{} must be in (0, 0.5)", band));
  if (!(max_overshoot >= 0 && max_overshoot < 1))
    throw InputError::field("max_overshoot", fmt::format("{} must be in [0, 1)", max_overshoot));
  if (!(gain_min > 0 && gain_min < gain_max && gain_max <= 10))
    throw InputError::field("gain_min", fmt::format("[{}, {}] must satisfy 0 < min < max <= 10", gain_min, gain_max));
  validate_member("optimizer", optimizer);
}

AccScore score_acc_gain(const AccTuningOptions& o, double gain) {
  control::AccOptions acc = o.acc;
  (acc.variable_gain ? acc.open_loop_gain : acc.kc) = gain;
  AccScore s;
  const double engage = 0.5, step_at = engage + o.settle_before_step_s, end = step_at + o.window_s;
  for (double a : o.base_depths_mm) {
    const auto run =
        turning::simulate_acc(o.process, acc, {{engage, a}, {step_at, a + o.depth_step_mm}}, end);
    turning::AccStepResponse r = turning::acc_step_response(run, acc.reference_force_n, step_at, end, o.band);
    s.worst_settling_s = std::max(s.worst_settling_s, std::isfinite(r.settling_s) ? r.settling_s : 2.0 * o.window_s);
    s.worst_overshoot = std::max(s.worst_overshoot, r.overshoot);
    s.steps.push_back(r);
  }
  return s;
}

AccTuningResult tune_acc(const AccTuningOptions& o, Termination& termination) {
  o.validate();
  AccTuningResult out;
  out.variable_gain = o.acc.variable_gain;
  out.start_gain = std::clamp(o.acc.variable_gain ? o.acc.open_loop_gain : o.acc.kc, o.gain_min, o.gain_max);
  out.before = score_acc_gain(o, out.start_gain);
  Problem p;
  p.parameters = {{o.acc.variable_gain ? "open_loop_gain" : "kc", o.gain_min, o.gain_max, out.start_gain, true}};
  p.constraint_count = 1;
  Termination work(termination);
  work.set_deadline(o.max_work_s, "work (evaluations at the reference cost)");
  p.evaluate = [&](const std::vector<double>& x, std::vector<double>& g) {
    const AccScore s = score_acc_gain(o, x[0]);
    work.charge(1, kAccWorkPerEvaluation_s);
    // Overshoot scaled so that 1 unit is the limit (plus a floor, so a zero limit is usable).
    g[0] = (s.worst_overshoot - o.max_overshoot) / std::max(o.max_overshoot, 0.005);
    return s.worst_settling_s;
  };
  out.optimizer = optimize(p, o.optimizer, work);
  out.gain = out.optimizer.x[0];
  out.after = score_acc_gain(o, out.gain);
  Summary& s = out.summary;
  s.status = out.optimizer.stopped() ? status_of(out.optimizer.ended_by) : out.optimizer.feasible ? Status::done : Status::infeasible;
  s.usable = usable_when_ended(out.optimizer, s.status);
  if (!s.done()) s.message = out.optimizer.stopped() ? stop_message(work.describe(), s.usable, "gain") : "no gain met the overshoot limit";
  s.brief = fmt::format("ACC {} gain: {} ({:.4f})", out.variable_gain ? "variable" : "fixed", status_text(s), out.gain);
  s.full = out.report();
  return out;
}

std::vector<AccSettled> AccStudy::settled(const std::vector<turning::AccSample>& run) const {
  std::vector<double> at;
  for (std::size_t i = 1; i < steps.size(); ++i) at.push_back(steps[i].from_s - 0.1);
  at.push_back(duration_s - 0.1);
  std::vector<AccSettled> out;
  for (double t : at)
    for (const auto& s : run)
      if (std::abs(s.t_s - t) < 1e-6) out.push_back({t, s.depth_mm, s.feed_mm_per_rev, s.force_n});
  return out;
}

AccStudy acc_study(const AccTuningOptions& base, AccLaws laws, Termination& termination) {
  base.validate();
  AccStudy st;
  st.steps = turning::koren_depth_steps();
  st.reference_force_n = base.acc.reference_force_n;
  st.koren = turning::simulate_acc(base.process, base.acc, st.steps, st.duration_s);
  for (const bool variable : {false, true}) {
    if ((variable && laws == AccLaws::fixed) || (!variable && laws == AccLaws::variable)) continue;
    AccTuningOptions o = base;
    o.acc.variable_gain = variable;
    st.tunings.push_back(tune_acc(o, termination));
    control::AccOptions tuned = base.acc;
    tuned.variable_gain = variable;
    (variable ? tuned.open_loop_gain : tuned.kc) = st.tunings.back().gain;
    st.tuned_runs.push_back(turning::simulate_acc(base.process, tuned, st.steps, st.duration_s));
  }
  Summary& s = st.summary;
  for (const AccTuningResult& r : st.tunings)
    if (!r.summary.done()) {
      s = r.summary;
      break;
    }
  s.brief = fmt::format("ACC on Koren's test: {} law{} tuned, {}", st.tunings.size(), st.tunings.size() == 1 ? "" : "s",
                        status_text(s));
  s.full = fmt::format("ACC on the turning model, Koren's test: Kc = {:g}, F_r = {:g} N, T = {:g} s, depth 2 -> 4 -> 6 mm\n",
                       base.acc.kc, base.acc.reference_force_n, base.acc.sample_s);
  for (const AccSettled& a : st.settled(st.koren))
    s.full += fmt::format("  t {:5.1f} s  depth {:4.1f} mm  feed {:.3f} mm/rev  force {:7.1f} N\n", a.t_s, a.depth_mm,
                          a.feed_mm_per_rev, a.force_n);
  for (const AccTuningResult& r : st.tunings) {
    s.full += '\n';  // (not "\n" + report(): g++ 12 warns falsely of an overlapping copy there)
    s.full += r.report();
  }
  return st;
}

std::string AccTuningResult::report() const {
  const char* name = variable_gain ? "L0 (variable gain)" : "Kc (fixed gain)";
  std::string s = fmt::format("ACC gain tuning, {}: {}\n", name, status_text(summary));
  s += fmt::format("  before  gain {:.4f}: worst settling {:.2f} s, worst overshoot {:.1f} %\n", start_gain,
                   before.worst_settling_s, 100 * before.worst_overshoot);
  s += fmt::format("  after   gain {:.4f}: worst settling {:.2f} s, worst overshoot {:.1f} %\n", gain, after.worst_settling_s,
                   100 * after.worst_overshoot);
  s += optimizer.report();
  return s;
}

}  // namespace machplan::tuning
