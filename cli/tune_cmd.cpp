// `machplan tune`: tunes a controller's gains on test contours of the simulated machine
// (solvers/tuning/tune.h), or with --acc the adaptive control constraint's gain
// (solvers/tuning/acc_tuning.h), and prints the gains and the errors before and after.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/json/tuning.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "solvers/calibration/store.h"
#include "solvers/common/picture.h"
#include "solvers/tuning/acc_tuning.h"
#include "solvers/tuning/plot.h"
#include "solvers/session/tuning_store.h"
#include "solvers/tuning/tune.h"

namespace machplan::cli {
namespace {

long whole_number(const std::string& flag, const std::string& text, long lo, long hi) {
  std::size_t used = 0;
  long long v = 0;
  try {
    v = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v < lo || v > hi)
    throw InputError(flag, 0, fmt::format("'{}' is not a whole number in [{}, {}]", excerpt(text), lo, hi));
  return static_cast<long>(v);
}

double number(const std::string& flag, const std::string& text, double lo, double hi) {
  const std::optional<double> v = parse_finite(text);
  if (!v || *v < lo || *v > hi)
    throw InputError(flag, 0, fmt::format("'{}' is not a number in [{}, {}]", excerpt(text), lo, hi));
  return *v;
}

std::string who() {
  const char* u = std::getenv("USER");
  return u && *u ? u : "unknown";
}

// --acc: Koren's depth steps with the fixed Kc = 0.5, then the tuned fixed and variable gains.
void run_acc(const std::string& plot, bool json, const std::string& evaluations, const std::string& time_s,
             const std::string& law) {
  tuning::AccTuningOptions base;
  if (!evaluations.empty()) base.optimizer.max_evaluations = static_cast<int>(whole_number("--evaluations", evaluations, 1, 1000000));
  if (!time_s.empty()) base.max_work_s = number("--time", time_s, 0.01, 86400);
  if (law != "fixed" && law != "variable" && law != "both")
    throw InputError("--acc-law", 0, fmt::format("'{}' is not a law (fixed, variable, both)", excerpt(law)));
  const auto steps = turning::koren_depth_steps();
  const double duration = 10.0;
  const auto koren = turning::simulate_acc(base.process, base.acc, steps, duration);
  std::vector<tuning::AccTuningResult> results;
  const StopOnSignals signals;
  Termination stop(StopOnSignals::stop_token());
  for (int vg = 0; vg < 2; ++vg) {
    if ((vg == 0 && law == "variable") || (vg == 1 && law == "fixed")) continue;
    tuning::AccTuningOptions o = base;
    o.acc.variable_gain = vg == 1;
    results.push_back(tuning::tune_acc(o, &stop));
  }
  // The settled feed and force before each depth change (and at the end).
  auto settled = [&](const std::vector<turning::AccSample>& run) {
    nlohmann::json a = nlohmann::json::array();
    std::vector<double> at;
    for (std::size_t i = 1; i < steps.size(); ++i) at.push_back(steps[i].from_s - 0.1);
    at.push_back(duration - 0.1);
    for (double t : at)
      for (const auto& s : run)
        if (std::abs(s.t_s - t) < 1e-6)
          a.push_back({{"t_s", t}, {"depth_mm", s.depth_mm}, {"feed_mm_per_rev", s.feed_mm_per_rev}, {"force_n", s.force_n}});
    return a;
  };
  std::vector<std::vector<turning::AccSample>> tuned_runs;
  for (const auto& r : results) {
    control::AccOptions a = base.acc;
    a.variable_gain = r.variable_gain;
    (a.variable_gain ? a.open_loop_gain : a.kc) = r.gain;
    tuned_runs.push_back(turning::simulate_acc(base.process, a, steps, duration));
  }
  if (!plot.empty()) {
    tuning::Panel force{"cutting force, N", {}}, feed{"feed, mm/rev", {}}, depth{"depth of cut, mm", {}};
    auto add = [&](const std::vector<turning::AccSample>& run, const std::string& name, double r, double g, double b) {
      tuning::Series f{name, r, g, b, {}, {}}, v{name, r, g, b, {}, {}};
      for (const auto& s : run) {
        f.t_s.push_back(s.t_s), f.y.push_back(s.force_n);
        v.t_s.push_back(s.t_s), v.y.push_back(s.feed_mm_per_rev);
      }
      force.series.push_back(f);
      feed.series.push_back(v);
    };
    add(koren, "fixed Kc = 0.5 (Koren)", 0.1, 0.1, 0.8);
    for (std::size_t i = 0; i < results.size(); ++i)
      add(tuned_runs[i],
          fmt::format("tuned {} = {:.3f}", results[i].variable_gain ? "L0 (variable gain)" : "Kc", results[i].gain),
          results[i].variable_gain ? 0.0 : 0.8, results[i].variable_gain ? 0.6 : 0.2, 0.1);
    tuning::Series ref{"F_r = 1500 N", 0.5, 0.5, 0.5, {0.0, duration}, {base.acc.reference_force_n, base.acc.reference_force_n}, true};
    force.series.push_back(ref);
    tuning::Series d{"depth", 0.3, 0.3, 0.3, {}, {}};
    for (const auto& s : koren) d.t_s.push_back(s.t_s), d.y.push_back(s.depth_mm);
    depth.series.push_back(d);
    tuning::write_time_plot(plot, "plot", "Adaptive control constraint: depth-of-cut steps of 2 mm", {force, feed, depth});
  }
  if (json) {
    nlohmann::json j;
    j["koren_fixed_kc_0_5"] = {{"settled", settled(koren)}};
    nlohmann::json t = nlohmann::json::array();
    for (std::size_t i = 0; i < results.size(); ++i) {
      nlohmann::json r = to_json(results[i]);
      r["settled"] = settled(tuned_runs[i]);
      t.push_back(r);
    }
    j["tunings"] = t;
    if (!plot.empty()) j["plot"] = plot;
    print_json(j);
    return;
  }
  std::printf("ACC on the turning model, Koren's test: Kc = 0.5, F_r = 1500 N, T = 0.1 s, depth 2 -> 4 -> 6 mm\n");
  for (const auto& s : settled(koren))
    std::printf("  t %5.1f s  depth %4.1f mm  feed %.3f mm/rev  force %7.1f N\n", s["t_s"].get<double>(),
                s["depth_mm"].get<double>(), s["feed_mm_per_rev"].get<double>(), s["force_n"].get<double>());
  for (const auto& r : results) std::printf("\n%s", r.report().c_str());
  if (!plot.empty()) std::printf("picture: %s\n", plot.c_str());
}

// Which flag sets which field of TuneOptions and AccTuningOptions, and of the Evaluator (built
// here from TuneOptions::evaluation) under its own names, for the error path
// (cli/field_flags.h).
const FieldFlag kTuneFields[] = {
    {"machine", "--machine"},
    {"evaluation.machine", "--machine"},
    {"noise_runs", "--noise-runs"},
    {"evaluation.noise_runs", "--noise-runs"},
    {"contours", "--contour"},
    {"kind", "--controller"},
    {"controller", "--controller"},
    {"objective", "--objective"},
    {"start", "--gain"},
    {"gains", "--gain"},
    {"fixed", "--fix"},
    {"optimizer.max_evaluations", "--evaluations"},
    {"optimizer.max_time_s", "--time"},
    {"db_path", "--db"},
    {"plot", "--plot"},
};

void add_tune(CLI::App& app) {
  struct Args {
    std::string machine, controller, objective = "max", plot, db, evaluations, time, seed, noise_runs, acc_law = "both";
    std::vector<std::string> contours, gains, fixed;
    bool json = false, store = false, acc = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("tune", "Tune servo and contour controller gains, or the adaptive control constraint, with NLopt");
  cmd->add_option("--machine", a->machine, "xy_table, thermal_gantry, or a machine YAML file");
  cmd->add_option("--controller", a->controller, "p, pid, pid_ff, zpetc, ccc, flc");
  cmd->add_option("--contour", a->contours,
                  "test contour: line:ANGLE_DEG:FEED_MM_MIN, circle:RADIUS_MM:FEED_MM_MIN, corner:TURN_DEG:FEED_MM_MIN or "
                  "program:FILE.ngc; may be "
                  "repeated");
  cmd->add_option("--gain", a->gains, "start value of a gain, NAME=VALUE, instead of its default; may be repeated");
  cmd->add_option("--fix", a->fixed, "hold a gain at a value and do not search it, NAME=VALUE; may be repeated");
  cmd->add_option("--objective", a->objective, "contour error to minimise: max (default), rms or itae");
  cmd->add_option("--evaluations", a->evaluations, "evaluation budget of the optimiser (default 600; --acc 150)");
  cmd->add_option("--time", a->time,
                  "deadline of the search, s of work: simulated machine time at its cost on a reference PC, so the "
                  "same inputs give the same gains on any computer (default 25)");
  cmd->add_option("--seed", a->seed, "seed of the simulated machine's noise (default 1)");
  cmd->add_option("--noise-runs", a->noise_runs,
                  "runs of each contour, each under its own noise (seeds SEED, SEED+1, ...); the maximum is taken over "
                  "them (default 3)");
  cmd->add_flag("--json", a->json, "machine-readable output");
  cmd->add_option("--plot", a->plot, "picture (.png or .svg): contour error against time, or with --acc force and feed");
  cmd->add_flag("--store", a->store, "store the tuned gains as the machine's active tuning (used by run --controller tuned)");
  cmd->add_option("--db", a->db, "the store (default $XDG_DATA_HOME/machplan/calibration.db)");
  cmd->add_flag("--acc", a->acc, "tune the adaptive control constraint (turning, Koren's force loop) instead");
  cmd->add_option("--acc-law", a->acc_law, "with --acc: fixed, variable or both (default)");
  field_flags(cmd, kTuneFields);
  cmd->callback([a] {
    if (!a->plot.empty()) {
      if (!is_picture_path(a->plot)) throw InputError("--plot", 0, fmt::format("'{}' must end in .png or .svg", a->plot));
      check_output_folder("--plot", a->plot);
    }
    if (a->acc) {
      if (!a->controller.empty()) throw InputError("--controller", 0, "does not apply to --acc");
      if (!a->contours.empty()) throw InputError("--contour", 0, "does not apply to --acc");
      if (!a->noise_runs.empty()) throw InputError("--noise-runs", 0, "does not apply to --acc");
      if (!a->fixed.empty()) throw InputError("--fix", 0, "does not apply to --acc");
      if (a->store) throw InputError("--store", 0, "does not apply to --acc (the ACC gain belongs to the lathe, not to an XY machine)");
      run_acc(a->plot, a->json, a->evaluations, a->time, a->acc_law);
      return;
    }
    if (a->machine.empty()) throw InputError("--machine", 0, "is required (xy_table, thermal_gantry or a machine file)");
    if (a->controller.empty()) throw InputError("--controller", 0, "is required (p, pid, pid_ff, zpetc, ccc, flc)");
    if (a->contours.empty()) throw InputError("--contour", 0, "at least one test contour is required");
    tuning::TuneOptions o;
    o.evaluation.machine = a->machine;
    o.kind = accept(control::parse_controller_kind(a->controller), "--controller");
    o.objective = accept(tuning::parse_objective(a->objective), "--objective");
    for (const std::string& g : a->gains) control::parse_gain(g, o.start, "start");
    for (const std::string& g : a->fixed) control::parse_gain(g, o.fixed, "fixed");
    if (!a->evaluations.empty()) o.optimizer.max_evaluations = static_cast<int>(whole_number("--evaluations", a->evaluations, 1, 1000000));
    if (!a->time.empty()) o.max_work_s = number("--time", a->time, 0.01, 86400);
    if (!a->seed.empty()) o.evaluation.seed = static_cast<std::uint64_t>(whole_number("--seed", a->seed, 0, 2147483647));
    o.evaluation.noise_runs = a->noise_runs.empty() ? 3 : static_cast<int>(whole_number("--noise-runs", a->noise_runs, 1, 100));
    std::vector<tuning::TestContour> contours;
    for (const std::string& c : a->contours) contours.push_back(tuning::parse_contour(c));
    const std::string db = a->store ? (a->db.empty() ? calibration::default_store_path() : a->db) : "";
    const StopOnSignals signals;
    const tuning::Evaluator ev(o.evaluation, contours);
    tuning::TuneResult r;
    {
      Termination stop(StopOnSignals::stop_token());
      Progress progress;
      const ProgressWatch watch(fmt::format("tuning {}", o.kind), !a->json, progress);
      r = tuning::tune(ev, o, &stop, &progress);
    }
    std::int64_t stored = 0;
    if (a->store) {
      if (!r.summary.done())
        throw Infeasible(fmt::format("the tuning's status is '{}': nothing stored", to_string(r.summary.status)));
      stored = tuning::TuningStore(db).save(r.machine, r.kind, r.gains, "ok", to_json(r).dump(), who());
    }
    if (!a->plot.empty()) {
      // The first contour under the first noise draw, in micrometres.
      tuning::Panel p{fmt::format("contour error, um ({}, seed {})", contours.front().spec, o.evaluation.seed), {}};
      auto base = ev.error_series(0, o.baseline_kind, {});
      auto tuned = ev.error_series(0, r.kind, r.gains);
      for (auto* s : {&base, &tuned})
        for (double& e : s->error_mm) e *= 1000.0;
      p.series.push_back({"baseline: axial P", 0.8, 0.2, 0.1, base.t_s, base.error_mm});
      p.series.push_back({fmt::format("tuned {}", r.kind), 0.1, 0.3, 0.8, tuned.t_s, tuned.error_mm});
      tuning::write_time_plot(a->plot, "plot", fmt::format("machplan tune: {} on {}", r.kind, r.machine), {p});
    }
    if (a->json) {
      nlohmann::json j = to_json(r);
      if (stored) j["stored"] = {{"db", db}, {"tuning_id", stored}};
      if (!a->plot.empty()) j["plot"] = a->plot;
      print_json(j);
    } else {
      std::printf("%s", r.summary.full_report().c_str());
      if (stored) std::printf("stored as tuning %lld, active for %s, in %s\n", static_cast<long long>(stored), r.machine.c_str(), db.c_str());
      if (!a->plot.empty()) std::printf("picture: %s\n", a->plot.c_str());
    }
    set_exit_code(r.summary.exit_code());
  });
}

const Registration reg(57, add_tune);

}  // namespace
}  // namespace machplan::cli
