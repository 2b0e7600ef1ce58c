// `machplan tune`: tunes a controller's gains on test contours of the simulated machine
// (solvers/tuning/tune.h), or with --acc the adaptive control constraint's gain on Koren's test
// (solvers/tuning/acc_tuning.h, acc_study), and prints the solver's report: the gains and the
// errors before and after. The baselines, the runs and the reports are the solvers'; this
// file parses the flags and prints.
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

// --acc: Koren's test and the tuned fixed and variable gains (solvers/tuning/acc_tuning.h).
void run_acc(const std::string& plot, bool json, const std::string& evaluations, const std::string& time_s,
             const std::string& law) {
  tuning::AccTuningOptions base;
  if (!evaluations.empty()) base.optimizer.max_evaluations = static_cast<int>(whole_number("--evaluations", evaluations, 1, 1000000));
  if (!time_s.empty()) base.max_work_s = number("--time", time_s, 0.01, 86400);
  if (law != "fixed" && law != "variable" && law != "both")
    throw InputError("--acc-law", 0, fmt::format("'{}' is not a law (fixed, variable, both)", excerpt(law)));
  const tuning::AccLaws laws = law == "fixed" ? tuning::AccLaws::fixed : law == "variable" ? tuning::AccLaws::variable : tuning::AccLaws::both;
  const StopOnSignals signals;
  Termination stop(StopOnSignals::stop_token());
  const tuning::AccStudy study = tuning::acc_study(base, laws, stop);
  if (!plot.empty()) tuning::write_acc_plot(plot, "plot", study);
  if (json) {
    nlohmann::json j = to_json(study);
    if (!plot.empty()) j["plot"] = plot;
    print_json(j);
  } else {
    std::printf("%s", study.summary.full_report().c_str());
    if (!plot.empty()) std::printf("picture: %s\n", plot.c_str());
  }
  set_exit_code(study.summary.exit_code());
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
                  fmt::format("test contour: line:ANGLE_DEG:FEED_MM_MIN, circle:RADIUS_MM:FEED_MM_MIN, "
                              "corner:TURN_DEG:FEED_MM_MIN, square:SIDE_MM:FEED_MM_MIN or program:FILE.ngc; may be repeated "
                              "(default {})",
                              tuning::kDefaultTestContour));
  cmd->add_option("--gain", a->gains, "start value of a gain, NAME=VALUE, instead of its default; may be repeated");
  cmd->add_option("--fix", a->fixed, "hold a gain at a value and do not search it, NAME=VALUE; may be repeated");
  cmd->add_option("--objective", a->objective, "contour error to minimise: max (default), rms or itae");
  cmd->add_option("--evaluations", a->evaluations, "evaluation budget of the optimiser (default 600; --acc 150)");
  cmd->add_option("--time", a->time,
                  "deadline of the search, s of work: simulated machine time at its cost on a reference PC, so the "
                  "same inputs give the same gains on any computer (default 25); gains found by then that meet every "
                  "constraint are kept (exit 0, the status says the deadline ended it)");
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
    if (contours.empty()) contours.push_back(tuning::parse_contour(tuning::kDefaultTestContour));
    const std::string db = a->store ? (a->db.empty() ? calibration::default_store_path() : a->db) : "";
    const StopOnSignals signals;
    const tuning::Evaluator ev(o.evaluation, contours);
    tuning::TuneResult r;
    {
      Termination stop(StopOnSignals::stop_token());
      Progress progress;
      const ProgressWatch watch(fmt::format("tuning {}", o.kind), !a->json, progress);
      r = tuning::tune(ev, o, stop, &progress);
    }
    std::int64_t stored = 0;
    if (a->store) {
      if (!r.summary.usable_answer())
        throw Infeasible(fmt::format("the tuning's status is '{}': nothing stored", to_string(r.summary.status)));
      stored = tuning::TuningStore(db).save(r.machine, r.kind, r.gains, r.summary, to_json(r).dump(), who());
    }
    if (!a->plot.empty()) tuning::write_tune_plot(a->plot, "plot", ev, o, r);
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

const Registration reg_tune(57, add_tune);

}  // namespace
}  // namespace machplan::cli
