// `machplan calibrate record|fit`: calibration sessions (solvers/calibration).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/json/calibration.h"
#include "cli/output.h"
#include "engine/calibration/session_log.h"
#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "solvers/session/machine_session.h"
#include "models/cutting/machine_config.h"
#include "solvers/calibration/fit.h"
#include "engine/common/text_file.h"
#include "solvers/calibration/record.h"
#include "solvers/calibration/store.h"

namespace machplan::cli {
namespace {

int repeats_of(const std::string& text) {
  std::size_t used = 0;
  int r = 0;
  try {
    r = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || r < 1 || r > 1000)
    throw InputError("--repeats", 0, fmt::format("'{}' is not a whole number in 1 .. 1000", excerpt(text)));
  return r;
}

void add_calibrate(CLI::App& app) {
  auto* cal = app.add_subcommand("calibrate", "Calibration sessions: record a session log, fit the axis factors");
  cal->require_subcommand(1);

  struct RecordArgs {
    std::string machine, backend = "sim", seed = "1", out, truth, repeats = "1", speeds, hold;
  };
  auto r = std::make_shared<RecordArgs>();
  auto* rec = cal->add_subcommand("record", "Run the calibration routine on a backend and write the session log");
  rec->add_option("--machine", r->machine, "thermal_gantry, or a machine YAML file (the nominal machine)")->required();
  rec->add_option("--backend", r->backend, "the machine to calibrate: sim (the simulated machine; default) or hal (a machine with velocity-mode "
                  "drives through LinuxCNC's HAL: docs/hal.md)");
  rec->add_option("--seed", r->seed, "seed of the simulated machine's noise and of the ruler's noise (default 1)");
  rec->add_option("--out", r->out, "session log to write (default: standard output)");
  rec->add_option("--repeats", r->repeats, "run the stroke program this many times (default 1, about 21 s)");
  rec->add_option("--speeds", r->speeds,
                  "stroke speeds as fractions of the DAC's full scale, comma-separated (default 0.15,0.3,0.5,0.7)");
  rec->add_option("--hold", r->hold, "seconds each stroke holds its speed (default 1.2)");
  rec->add_option("--sim-truth", r->truth,
                  "sim only: a machine YAML file with the simulated machine's true factors (default: the nominal "
                  "machine)");
  field_flags(rec, {{"machine", "--machine"},
                    {"name", "--backend"},
                    {"backend.name", "--backend"},
                    {"backend", "--backend"},
                    {"speed_fractions", "--speeds"},
                    {"stroke_hold_s", "--hold"}});
  rec->callback([r] {
    const auto nominal = cutting::load_machine(cutting::find_machine(r->machine));
    const auto truth = r->truth.empty() ? nominal : cutting::load_machine(r->truth);
    if (!r->truth.empty() && r->backend != "sim")
      throw InputError("--sim-truth", 0, "applies to the simulated machine only (--backend sim)");
    session::MachineSessionOptions so;
    so.machine_config = truth;
    so.backend.name = r->backend;
    so.backend.sim.seed = seed_of(r->seed);
    session::MachineSession session(std::move(so));
    calibration::RecordOptions o;
    o.seed = seed_of(r->seed);
    o.repeats = repeats_of(r->repeats);
    if (!r->speeds.empty()) {
      o.speed_fractions.clear();
      std::size_t pos = 0;
      while (pos <= r->speeds.size()) {
        const std::size_t comma = std::min(r->speeds.find(',', pos), r->speeds.size());
        o.speed_fractions.push_back(number_flag("--speeds", r->speeds.substr(pos, comma - pos)));
        pos = comma + 1;
      }
    }
    if (!r->hold.empty()) o.stroke_hold_s = number_flag("--hold", r->hold);
    o.validate();
    // SIGINT, SIGTERM and SIGHUP stop the axes and end the session (cancelled: exit 3).
    const StopOnSignals signals;
    Termination stop(StopOnSignals::stop_token());
    Progress progress;
    calibration::Recording rec = [&] {
      const ProgressWatch watch("recording", !r->out.empty(), progress);
      return calibration::record_session(session.backend(), nominal, o, stop, &progress);
    }();
    // Ended early: no session to write (exit 3, saying why).
    if (!rec.summary.done()) throw Infeasible(rec.summary.message);
    calibration::SessionLog& log = rec.log;
    if (!r->truth.empty()) log.comments.push_back(fmt::format("sim truth: {}", r->truth));
    if (r->out.empty()) {
      calibration::write_session_log(std::cout, log);
    } else {
      // Whole or not at all: a full disk leaves no half log (OutputError, exit 4).
      std::ostringstream text;
      calibration::write_session_log(text, log);
      write_file_atomically(r->out, text.str());
      std::printf("session log: %s (%zu samples, %.1f s)\n", r->out.c_str(), log.samples.size(),
                  log.samples.empty() ? 0.0 : log.samples.back().t_s);
    }
  });

  struct FitArgs {
    std::string log, machine;
    bool json = false;
  };
  auto f = std::make_shared<FitArgs>();
  auto* fit = cal->add_subcommand("fit", "Fit encoder scale, feed factor, backlash, lag and latency to a session log");
  fit->add_option("log", f->log, "session log (CSV: t_s,axis,dac,counter,dir,ref_mm)")->required();
  fit->add_option("--machine", f->machine, "thermal_gantry, or a machine YAML file (the nominal machine)")->required();
  fit->add_flag("--json", f->json, "machine-readable output");
  field_flags(fit, {{"machine", "--machine"}});
  fit->callback([f] {
    const auto machine = cutting::load_machine(cutting::find_machine(f->machine));
    const auto log = calibration::read_session_log(f->log);
    // SIGINT, SIGTERM and SIGHUP end the fit after its current iteration (exit 3).
    const StopOnSignals signals;
    Termination term(StopOnSignals::stop_token());
    const auto result = calibration::fit_session(log, machine, {}, term);
    if (f->json) {
      std::printf("%s\n", result.json().c_str());
    } else {
      std::printf("%s", result.summary.full_report().c_str());
    }
    // A fit that does not determine every factor finished, but must not pass for a good one.
    set_exit_code(result.summary.exit_code());
  });
}

const Registration reg_calibrate(55, add_calibrate);

void add_store_commands(CLI::App& app) {
  auto* cal = app.get_subcommand("calibrate");
  struct Args {
    std::string log, machine, db, who, feed;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto db_path = [a] { return a->db.empty() ? calibration::default_store_path() : a->db; };

  auto* apply = cal->add_subcommand("apply", "Fit a session log and store the fit as the machine's active calibration");
  apply->add_option("log", a->log, "session log (CSV)")->required();
  apply->add_option("--machine", a->machine, "thermal_gantry, or a machine YAML file (the nominal machine)")->required();
  apply->add_option("--db", a->db, "calibration store (default $XDG_DATA_HOME/machplan/calibration.db)");
  apply->add_option("--who", a->who, "who ran the session (default $USER)");
  field_flags(apply, {{"machine", "--machine"}, {"db_path", "--db"}});
  apply->callback([a, db_path] {
    const auto machine = cutting::load_machine(cutting::find_machine(a->machine));
    const std::string bytes = read_text_file(a->log);
    const auto log = calibration::read_session_log_text(bytes, a->log);
    const StopOnSignals signals;
    Termination term(StopOnSignals::stop_token());
    const auto fit = calibration::fit_session(log, machine, {}, term);
    std::printf("%s", fit.summary.full_report().c_str());
    std::string who = a->who;
    if (who.empty()) who = std::getenv("USER") ? std::getenv("USER") : "unknown";
    const std::string path = db_path();
    calibration::CalibrationStore store(path);
    const auto id = store.apply(fit, std::filesystem::absolute(a->log).string(), bytes, who);
    std::printf("stored as fit %lld, active for %s, in %s\n", static_cast<long long>(id), fit.machine.c_str(), path.c_str());
  });

  auto* history = cal->add_subcommand("history", "List the stored sessions and fits, newest first");
  history->add_option("--machine", a->machine, "only this machine (its name in the machine file)");
  history->add_option("--db", a->db, "calibration store (default $XDG_DATA_HOME/machplan/calibration.db)");
  history->add_flag("--json", a->json, "machine-readable output");
  field_flags(history, {{"db_path", "--db"}});
  history->callback([a, db_path] {
    calibration::CalibrationStore store(db_path());
    const auto rows = store.history(a->machine);
    if (a->json) {
      nlohmann::json j = nlohmann::json::array();
      for (const auto& f : rows) j.push_back(to_json(f));
      print_json(j);
      return;
    }
    std::printf("%s", calibration::history_report(rows).c_str());
  });

  auto* show = cal->add_subcommand("show", "Print a machine's active calibration and the paper modes' factor for a feed");
  show->add_option("--machine", a->machine, "the machine's name (as in its machine file)")->required();
  show->add_option("--db", a->db, "calibration store (default $XDG_DATA_HOME/machplan/calibration.db)");
  show->add_option("--feed", a->feed, "feed, mm/s: print the open-loop factor for `run --mode paper-open --calibration`");
  field_flags(show, {{"db_path", "--db"}, {"feed_mm_per_s", "--feed"}, {"calibration", "--db"}});
  show->callback([a, db_path] {
    const double feed = a->feed.empty() ? 0.0 : number_flag("--feed", a->feed);  // a bad flag first: exit 2
    calibration::CalibrationStore store(db_path());
    const auto c = store.active(a->machine);
    if (!c) throw Infeasible(fmt::format("no active calibration for '{}' in {}", a->machine, db_path()));
    std::printf("%s", calibration::calibration_report(*c, a->feed.empty() ? std::nullopt : std::optional<double>(feed)).c_str());
  });
}

const Registration reg_store(56, add_store_commands);

}  // namespace
}  // namespace machplan::cli
