#include "solvers/tuning/tune.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::tuning {

void TuneOptions::validate() const {
  validate_member("evaluation", evaluation);
  validate_member("optimizer", optimizer);
  if (kind.empty()) throw InputError::field("kind", "names no controller");
  control::parse_controller_kind(kind, "kind");
  control::parse_controller_kind(baseline_kind, "baseline_kind");
}

std::vector<double> constraint_values(const Evaluation& e, const EvaluationOptions& o, double following_limit_mm) {
  std::vector<double> g(5, -1.0);
  if (o.constraints) {
    g[0] = std::isfinite(e.margin_residual) ? e.margin_residual / o.max_residual - 1.0 : 1e3;
    g[1] = std::isfinite(e.overshoot) ? e.overshoot / o.max_overshoot - 1.0 : 1e3;
  }
  g[2] = (e.saturation_share - o.max_saturation_share) / o.max_saturation_share;
  g[3] = following_limit_mm > 0 ? e.max_following_error_mm / following_limit_mm - 1.0 : -1.0;
  g[4] = e.faulted ? 1.0 : -1.0;
  return g;
}

namespace {

double following_limit(const Evaluator& ev) {
  const auto& o = ev.options();
  if (o.following_error_limit_mm > 0) return o.following_error_limit_mm;
  return std::min(ev.plant().servo[0].following_error_limit_mm, ev.plant().servo[1].following_error_limit_mm);
}

}  // namespace

Comparison compare(const Evaluation& baseline, const Evaluation& tuned) {
  Comparison c;
  double b2 = 0.0, t2 = 0.0;
  std::size_t bn = 0, tn = 0;
  for (std::size_t i = 0; i < baseline.contours.size() && i < tuned.contours.size(); ++i) {
    const ContourScore& b = baseline.contours[i];
    const ContourScore& t = tuned.contours[i];
    if (b.faulted || b.samples == 0) {
      c.faulted.push_back(fmt::format("{}: {}", b.contour, b.faulted ? b.fault : "no samples"));
      continue;
    }
    if (t.faulted || t.samples == 0) {  // the tuned gains did not complete it: nothing to compare
      c.faulted.push_back(fmt::format("{}: tuned gains {}", t.contour, t.faulted ? "faulted: " + t.fault : "gave no samples"));
      continue;
    }
    c.contours.push_back(b.contour);
    c.baseline_max_mm = std::max(c.baseline_max_mm, b.max_mm);
    c.tuned_max_mm = std::max(c.tuned_max_mm, t.max_mm);
    b2 += b.rms_mm * b.rms_mm * static_cast<double>(b.samples);
    t2 += t.rms_mm * t.rms_mm * static_cast<double>(t.samples);
    bn += b.samples;
    tn += t.samples;
  }
  c.baseline_rms_mm = bn ? std::sqrt(b2 / static_cast<double>(bn)) : 0.0;
  c.tuned_rms_mm = tn ? std::sqrt(t2 / static_cast<double>(tn)) : 0.0;
  return c;
}

namespace {

// How the tuning ended; its reports.
void summarize(TuneResult& r) {
  Summary& s = r.summary;
  s.status = r.optimizer.stopped() ? status_of(r.optimizer.ended_by) : !r.optimizer.feasible ? Status::infeasible : Status::done;
  s.usable = usable_when_ended(r.optimizer, s.status);
  if (s.status == Status::infeasible) s.message = "no gains met the constraints; the least violating are shown";
  else if (!s.done())
    s.message = stop_message(r.optimizer.local.stop_reason.empty() ? r.optimizer.global.stop_reason : r.optimizer.local.stop_reason,
                             s.usable, "gains");
  s.brief = fmt::format("tuning {} on {}: {}", r.kind, r.machine, status_text(s));
  if (r.improvement.any())
    s.brief += fmt::format(", max contour error {:.4f} -> {:.4f} mm ({:.2f}x)", r.improvement.baseline_max_mm,
                           r.improvement.tuned_max_mm, r.improvement.max_ratio());
  s.full = r.report();
}

}  // namespace

TuneResult tune(const Evaluator& ev, const TuneOptions& o, Termination& termination, Progress* progress) {
  o.validate();
  TuneResult r;
  r.machine = ev.machine().name;
  r.kind = o.kind;
  r.objective = o.objective;
  r.specs = control::gain_specs(o.kind, ev.plant());
  for (const auto& s : r.specs) r.start_gains[s.name] = s.default_value;
  for (const auto& [name, value] : o.start) {
    if (!r.start_gains.count(name))
      throw InputError::field("start", fmt::format("controller '{}' has no gain '{}'", o.kind, excerpt(name)));
    r.start_gains[name] = value;
  }
  for (const auto& [name, value] : o.fixed) {
    if (!r.start_gains.count(name))
      throw InputError::field("fixed", fmt::format("controller '{}' has no gain '{}'", o.kind, excerpt(name)));
    if (o.start.count(name))
      throw InputError::field("fixed", fmt::format("gain '{}' is both fixed and given a start", excerpt(name)));
    r.start_gains[name] = value;
  }
  r.fixed = o.fixed;
  const double flimit = following_limit(ev);

  bool model_moved = false;  // a feed-forward gain starts at the drive model's value, not its default
  if (o.physical_feed_forward) {
    const auto& pl = ev.plant();
    double g = 1.0, lag = 0.0, tau = 0.0;
    for (int i = 0; i < control::kAxes; ++i) {
      g = std::min(g, pl.gain_factor[i] > 0 ? pl.gain_factor[i] : 1.0);
      tau = std::max(tau, pl.drive_time_constant_s[i]);
      lag = std::max(lag, pl.drive_time_constant_s[i] + (pl.command_latency_ticks[i] + pl.reading_latency_ticks[i]) * pl.period_s);
    }
    double coulomb = 0.0, backlash = 0.0;  // the machine file's Coulomb friction (as speed, mm/s) and backlash
    for (const auto& a : ev.machine().axes) {
      coulomb = std::max(coulomb, a.plant.coulomb_friction_mm_per_s);
      backlash = std::max(backlash, a.plant.backlash_mm);
    }
    for (auto& s : r.specs) {
      double model = s.default_value;  // the drive model's value of a feed-forward gain
      if (s.name == "velocity_ff") model = 1.0 / g;
      if (s.name == "friction_ff_mm_per_s") model = coulomb;
      if (s.name == "backlash_ff_mm") model = backlash;
      if (s.name == "acceleration_ff_s" && lag > 0) model = tau;
      double cap = s.max_value;
      if (s.name == "velocity_ff" || s.name == "friction_ff_mm_per_s" || s.name == "backlash_ff_mm") cap = o.ff_margin * model;
      if (s.name == "acceleration_ff_s" && lag > 0) cap = o.ff_margin * lag;
      s.max_value = std::max(s.min_value, std::min(s.max_value, std::max(cap, s.default_value)));
      // The search starts from the drive model's own feed-forward (unless the caller gave a
      // start): the exact cancellation of a first-order drive with the machine file's friction
      // and backlash, which a local search then only has to refine.
      if (o.model_start && !o.start.count(s.name) && !o.fixed.count(s.name) && r.start_gains.count(s.name)) {
        r.start_gains[s.name] = std::clamp(model, s.min_value, s.max_value);
        model_moved = model_moved || r.start_gains[s.name] != s.default_value;
      }
    }
  }
  r.start_from = !o.start.empty() || !o.fixed.empty() ? (model_moved ? "given gains, drive-model feed-forward" : "given gains")
                                                      : (model_moved ? "drive-model feed-forward" : "defaults");
  r.baseline = ev.evaluate(o.baseline_kind, {});
  r.start = ev.evaluate(o.kind, r.start_gains);
  // The objective is scaled by the baseline's, or the start's where the baseline faulted (a
  // faulted run's figures are not measurements).
  const Evaluation& ref = r.baseline.faulted && !r.start.faulted ? r.start : r.baseline;
  const double scale = std::max(ref.value(o.objective), 1e-9);
  // The deadline in work and the evaluation budget (a hard cap), under the caller's stop.
  Termination work(termination);
  work.set_deadline(o.max_work_s, "work (simulated machine time at the reference cost)");
  Problem p;
  std::vector<std::string> searched;  // the gains the optimiser moves, in its order
  for (const auto& s : r.specs) {
    if (o.fixed.count(s.name)) continue;
    Parameter q;
    q.name = s.name;
    q.lo = s.min_value;
    q.hi = s.max_value;
    q.start = std::clamp(r.start_gains.at(s.name), s.min_value, s.max_value);
    q.log_scale = s.log_scale && s.min_value > 0;
    p.parameters.push_back(q);
    searched.push_back(s.name);
  }
  p.constraint_count = 5;
  const auto gains_of = [&](const std::vector<double>& x) {
    control::Gains g = r.start_gains;  // the fixed gains as they are
    for (std::size_t i = 0; i < x.size(); ++i) g[searched[i]] = x[i];
    return g;
  };
  int done = 0;
  p.evaluate = [&](const std::vector<double>& x, std::vector<double>& g) {
    const Evaluation e = ev.evaluate(o.kind, gains_of(x));
    work.charge(1, e.machine_s * kWorkPerMachineSecond);
    g = constraint_values(e, o.evaluation, flimit);
    report_progress(progress, std::min(1.0, ++done / static_cast<double>(o.optimizer.max_evaluations)));
    return e.value(o.objective) / scale;
  };
  if (p.parameters.empty()) {
    r.gains = r.start_gains;
    r.tuned = r.start;
    r.optimizer.feasible = true;
    r.improvement = compare(r.baseline, r.tuned);
    summarize(r);
    return r;
  }
  r.optimizer = optimize(p, o.optimizer, work);
  r.gains = gains_of(r.optimizer.x);
  r.tuned = ev.evaluate(o.kind, r.gains);
  r.improvement = compare(r.baseline, r.tuned);
  if (o.fresh_check && !r.optimizer.stopped()) {
    EvaluationOptions fo = ev.options();
    fo.seed += static_cast<std::uint64_t>(fo.noise_runs);
    fo.constraints = false;  // only the contour errors are compared here
    const Evaluator fresh(fo, ev.contours());
    r.fresh_seed = fo.seed;
    r.fresh_baseline = fresh.evaluate(o.baseline_kind, {});
    r.fresh_tuned = fresh.evaluate(o.kind, r.gains);
    r.fresh_improvement = compare(r.fresh_baseline, r.fresh_tuned);
  }
  summarize(r);
  return r;
}

std::string TuneResult::report() const {
  std::string s = fmt::format("tuning {} on {} ({} contour error): {}\n", kind, machine, to_string(objective),
                              status_text(summary));
  if (!summary.done() && !summary.message.empty()) s += fmt::format("  {}\n", summary.message);
  s += "  gains\n";
  for (const auto& sp : specs) {
    const auto it = gains.find(sp.name);
    const auto st = start_gains.find(sp.name);
    if (fixed.count(sp.name)) {
      s += fmt::format("    {:<28} {:>12.6g}   (fixed)\n", sp.name, fixed.at(sp.name));
      continue;
    }
    s += fmt::format("    {:<28} {:>12.6g}   (start {:.6g}, box [{:.6g}, {:.6g}])\n", sp.name,
                     it != gains.end() ? it->second : sp.default_value, st != start_gains.end() ? st->second : sp.default_value,
                     sp.min_value, sp.max_value);
  }
  // A faulted run has no contour error to show: its fault is shown instead.
  const auto line = [](const std::string& what, const Evaluation& e) {
    if (!e.faulted)
      return fmt::format("  {:<38} max {:8.4f} mm  rms {:8.4f} mm  itae {:10.4g} mm s^2\n", what, e.max_mm, e.rms_mm, e.itae_mm_s2);
    std::string t = fmt::format("  {:<38} FAULTED on", what);
    for (const ContourScore& c : e.contours)
      if (c.faulted) t += fmt::format(" {} ({})", c.contour, c.fault);
    return t + "\n";
  };
  s += line("baseline (axial P)", baseline);
  s += line(fmt::format("start ({}, {})", kind, start_from), start);
  s += line("tuned", tuned);
  const auto improvement_text = [](const Comparison& c) {
    std::string t;
    if (!c.faulted.empty()) t += fmt::format(" (left out, a run did not complete: {})", fmt::join(c.faulted, "; "));
    return t;
  };
  if (improvement.any() && improvement.tuned_max_mm > 0)
    s += fmt::format("  improvement on the baseline: max {:.2f}x, rms {:.2f}x{}\n", improvement.max_ratio(),
                     improvement.rms_ratio(), improvement_text(improvement));
  else if (!improvement.any())
    s += fmt::format("  no improvement figure: baseline and tuned gains completed none of the contours together{}\n",
                     improvement_text(improvement));
  if (fresh_seed > 0 && fresh_improvement.any() && fresh_improvement.tuned_max_mm > 0) {
    s += fmt::format("  under noise it was not tuned on (seeds from {}): baseline max {:.4f} mm, tuned max {:.4f} mm: "
                     "max {:.2f}x, rms {:.2f}x{}\n",
                     fresh_seed, fresh_improvement.baseline_max_mm, fresh_improvement.tuned_max_mm, fresh_improvement.max_ratio(),
                     fresh_improvement.rms_ratio(), improvement_text(fresh_improvement));
  }
  s += fmt::format("  {:<38} step overshoot {:.1f} %, margin wobble {:.2f} %, saturation {:.2f} %, "
                   "following error {:.3f} mm\n",
                   "constraints (tuned)",
                   100 * tuned.overshoot, 100 * tuned.margin_residual, 100 * tuned.saturation_share,
                   tuned.max_following_error_mm);
  for (const ContourScore& c : tuned.contours)
    s += fmt::format("    {:<36} max {:8.4f} mm  rms {:8.4f} mm  (max at {:.3f} s, X {:.3f} Y {:.3f}, line {}){}\n",
                     c.contour, c.max_mm, c.rms_mm, c.max_at_s, c.max_at_x_mm, c.max_at_y_mm, c.max_at_line,
                     c.faulted ? "  FAULT: " + c.fault : "");
  s += optimizer.report();
  return s;
}

}  // namespace machplan::tuning
