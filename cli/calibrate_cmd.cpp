// `machplan calibrate record|fit`: calibration sessions (solvers/calibration).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.h"
#include "engine/calibration/session_log.h"
#include "engine/common/error.h"
#include "models/backends/backend_factory.h"
#include "models/cutting/machine_config.h"
#include "solvers/calibration/fit.h"
#include "solvers/calibration/record.h"

namespace machplan::cli {
namespace {

std::uint64_t seed_of(const std::string& text) {
  std::size_t used = 0;
  unsigned long long s = 0;
  try {
    s = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || text[0] == '-')
    throw InputError("--seed", 0, fmt::format("'{}' is not a whole number >= 0", text));
  return s;
}

double number_of(const char* flag, const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v))
    throw InputError(flag, 0, fmt::format("'{}' is not a number", text));
  return v;
}

int repeats_of(const std::string& text) {
  std::size_t used = 0;
  int r = 0;
  try {
    r = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || r < 1 || r > 1000)
    throw InputError("--repeats", 0, fmt::format("'{}' is not a whole number in 1 .. 1000", text));
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
  rec->add_option("--backend", r->backend, "the machine to calibrate: sim (the simulated machine; default)");
  rec->add_option("--seed", r->seed, "seed of the simulated machine's noise and of the ruler's noise (default 1)");
  rec->add_option("--out", r->out, "session log to write (default: standard output)");
  rec->add_option("--repeats", r->repeats, "run the stroke program this many times (default 1, about 21 s)");
  rec->add_option("--speeds", r->speeds,
                  "stroke speeds as fractions of the DAC's full scale, comma-separated (default 0.15,0.3,0.5,0.7)");
  rec->add_option("--hold", r->hold, "seconds each stroke holds its speed (default 1.2)");
  rec->add_option("--sim-truth", r->truth,
                  "sim only: a machine YAML file with the simulated machine's true factors (default: the nominal "
                  "machine)");
  rec->callback([r] {
    const auto nominal = cutting::load_machine(cutting::find_machine(r->machine));
    const auto truth = r->truth.empty() ? nominal : cutting::load_machine(r->truth);
    if (!r->truth.empty() && r->backend != "sim")
      throw InputError("--sim-truth", 0, "applies to the simulated machine only (--backend sim)");
    backends::BackendOptions bo;
    bo.name = r->backend;
    bo.sim.seed = seed_of(r->seed);
    auto backend = backends::make_backend(truth, bo);
    calibration::RecordOptions o;
    o.seed = bo.sim.seed;
    o.repeats = repeats_of(r->repeats);
    if (!r->speeds.empty()) {
      o.speed_fractions.clear();
      std::size_t pos = 0;
      while (pos <= r->speeds.size()) {
        const std::size_t comma = std::min(r->speeds.find(',', pos), r->speeds.size());
        o.speed_fractions.push_back(number_of("--speeds", r->speeds.substr(pos, comma - pos)));
        pos = comma + 1;
      }
    }
    if (!r->hold.empty()) o.stroke_hold_s = number_of("--hold", r->hold);
    try {
      o.validate();
    } catch (const InputError& e) {
      const std::string flag = e.where() == "speed_fractions" ? "--speeds" : e.where() == "stroke_hold_s" ? "--hold" : e.where();
      throw InputError(flag, 0, e.message());
    }
    auto log = calibration::record_session(*backend, nominal, o);
    if (!r->truth.empty()) log.comments.push_back(fmt::format("sim truth: {}", r->truth));
    if (r->out.empty()) {
      calibration::write_session_log(std::cout, log);
    } else {
      std::ofstream f(r->out);
      if (!f) throw InputError("--out", 0, fmt::format("cannot write '{}'", r->out));
      calibration::write_session_log(f, log);
      f.close();
      if (!f) throw InputError("--out", 0, fmt::format("writing '{}' failed", r->out));
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
  fit->callback([f] {
    const auto machine = cutting::load_machine(cutting::find_machine(f->machine));
    const auto log = calibration::read_session_log(f->log);
    const auto result = calibration::fit_session(log, machine);
    if (f->json) {
      std::printf("%s\n", result.json().c_str());
    } else {
      std::printf("%s", result.report().c_str());
    }
    // A fit that does not determine every factor finished, but must not pass for a good one.
    if (result.status != calibration::CalibrationFit::Status::ok) set_exit_code(3);
  });
}

const Registration reg(55, add_calibrate);

}  // namespace
}  // namespace machplan::cli
