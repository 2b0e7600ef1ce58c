// `machplan consumables show|reset`: a machine's cutting statistics (solvers/session/job_stats.h)
// and the operator's consumable change.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/json/stats.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "solvers/common/store.h"
#include "solvers/session/job_stats.h"

namespace machplan::cli {
namespace {

// A job's figures, after `head` (a label and the job count for totals).
std::string figures_line(const std::string& head, const stats::Figures& f) {
  return fmt::format("{}{:>7} pierces  arc on {:>9.1f} s  cycle {:>9.1f} s  cut {:>10.1f} mm  rapids {:>10.1f} mm  "
                     "probes {:>6} ({} skipped, {:.1f} s)  faults {}\n",
                     head, f.pierces, f.arc_on_s, f.cycle_s, f.cut_mm, f.rapid_mm, f.probes, f.probes_skipped, f.probe_s, f.faults);
}

std::string totals_line(const char* label, const stats::Figures& f) {
  return figures_line(fmt::format("{:<18} {:>6} jobs", label, f.jobs), f);
}

std::string totals_report(const stats::MachineTotals& t, const std::vector<stats::JobRecord>& jobs) {
  std::string out = fmt::format("machine {}\n", t.machine);
  out += t.last_change_utc ? fmt::format("consumables changed {} by {}\n", *t.last_change_utc, t.last_change_who.value_or(""))
                           : "consumables never changed (since the first job)\n";
  out += totals_line("since the change:", t.since_change);
  out += totals_line("lifetime:", t.lifetime);
  for (const stats::JobRecord& j : jobs)
    out += fmt::format("job {} {} {} {}{}\n", j.id, j.started_utc, j.program, j.status, j.fault.empty() ? "" : " (" + j.fault + ")") +
           figures_line("  ", j.figures);
  return out;
}

void add_consumables(CLI::App& app) {
  struct Args {
    std::string machine, db, who;
    long jobs = 5;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto db_path = [a] { return a->db.empty() ? store::default_store_path() : a->db; };
  auto* cmd = app.add_subcommand("consumables", "A machine's cutting statistics, and the consumable change that restarts them");
  cmd->require_subcommand(1);

  auto* show = cmd->add_subcommand("show", "Print a machine's counters: since the last consumable change, lifetime, last jobs");
  show->add_option("--machine", a->machine, "the machine's name (as in its machine file)")->required();
  show->add_option("--db", a->db, "the store (default $XDG_DATA_HOME/machplan/calibration.db)");
  show->add_option("--jobs", a->jobs, "list this many of the newest jobs (default 5)")->check(CLI::Range(0L, 100000L));
  show->add_flag("--json", a->json, "machine-readable output");
  field_flags(show, {{"db_path", "--db"}});
  show->callback([a, db_path] {
    const stats::StatsStore store(db_path());
    const stats::MachineTotals t = store.totals(a->machine);
    const auto jobs = store.jobs(a->machine, a->jobs);
    if (a->json) {
      nlohmann::json j = to_json(t);
      j["jobs"] = nlohmann::json::array();
      for (const auto& r : jobs) j["jobs"].push_back(to_json(r));
      print_json(j);
      return;
    }
    std::printf("%s", totals_report(t, jobs).c_str());
  });

  auto* reset = cmd->add_subcommand("reset", "Record a consumable change: the counters since the change start again");
  reset->add_option("--machine", a->machine, "the machine's name (as in its machine file)")->required();
  reset->add_option("--db", a->db, "the store (default $XDG_DATA_HOME/machplan/calibration.db)");
  reset->add_option("--who", a->who, "who changed them (default $USER)");
  field_flags(reset, {{"db_path", "--db"}});
  reset->callback([a, db_path] {
    if (a->machine.empty()) throw InputError("--machine", 0, "is empty");
    std::string who = a->who;
    if (who.empty()) who = std::getenv("USER") ? std::getenv("USER") : "unknown";
    stats::StatsStore store(db_path());
    store.consumables_changed(a->machine, who);
    std::printf("consumables changed on %s, recorded in %s\n", a->machine.c_str(), store.path().c_str());
  });
}

const Registration reg_consumables(57, add_consumables);

}  // namespace
}  // namespace machplan::cli
