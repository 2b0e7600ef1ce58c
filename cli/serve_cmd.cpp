// `machplan serve [--machine NAME] [--backend sim|hal] [--port P] [--bind ADDR]`: the shop-floor
// panel. One process owns the machine session and serves the page and the JSON + WebSocket API
// (cli/panel/server.h, docs/panel.md) until SIGINT, SIGTERM or SIGHUP, which stop what runs
// in a controlled way and close the server.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/panel/panel.h"
#include "cli/panel/server.h"
#include "engine/common/error.h"

namespace machplan::cli {
namespace {

struct ServeArgs {
  std::string machine = "thermal_gantry", backend = "sim", bind = "127.0.0.1", seed, db, controller, jobs;
  int port = 8090;
  bool allow_remote = false, no_pace = false;
  double max_machine_time_s = motion::RunOptions{}.max_machine_time_s;
  double sim_speed = 1.0;
};

void serve(const ServeArgs& a) {
  panel::PanelOptions po;
  po.session.machine = a.machine;
  po.session.backend.name = a.backend;
  if (!a.seed.empty()) po.session.backend.sim.seed = seed_of(a.seed);
  po.session.store_path = a.db;
  po.session.controller = a.controller.empty() || a.controller == "tuned"
                              ? a.controller
                              : accept(control::parse_controller_kind(a.controller), "--controller");
  po.store_path = a.db;
  po.job_folder = a.jobs;
  po.pace = !a.no_pace;
  po.sim_speed = a.sim_speed;
  po.run.max_machine_time_s = a.max_machine_time_s;
  panel::ServerOptions so;
  so.bind = a.bind;
  so.port = a.port;
  so.allow_remote = a.allow_remote;
  if (a.allow_remote)
    std::fprintf(stderr,
                 "machplan serve: WARNING: --allow-remote: the panel listens on %s; anyone who can reach this address and "
                 "holds the token can command the machine, over plain HTTP (the token crosses the network in clear)\n",
                 a.bind.c_str());
  const StopOnSignals signals;
  const StopToken stop = StopOnSignals::stop_token();
  panel::Panel panel(po);
  panel::Server server(panel, so);
  std::printf("machplan serve: %s on %s, backend %s\n", panel.session().machine().name.c_str(), a.bind.c_str(), a.backend.c_str());
  std::printf("open the panel at %s\n", server.url().c_str());
  std::fflush(stdout);
  while (!stop.stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::fprintf(stderr, "machplan serve: stopping\n");
}

void add_serve(CLI::App& app) {
  auto a = std::make_shared<ServeArgs>();
  auto* cmd = app.add_subcommand("serve", "Serve the shop-floor panel: the machine and its jobs in a browser");
  cmd->add_option("--machine", a->machine, "thermal_gantry (default), xy_table, or a machine YAML file");
  cmd->add_option("--backend", a->backend, "the machine behind the executor: sim (the simulated machine; default) or hal (a machine "
                  "through LinuxCNC's HAL: docs/hal.md)");
  cmd->add_option("--port", a->port, "TCP port (default 8090; 0: any free port, printed)")->check(CLI::Range(0, 65535));
  cmd->add_option("--bind", a->bind, "address to listen on (default 127.0.0.1; another needs --allow-remote)");
  cmd->add_flag("--allow-remote", a->allow_remote,
                "allow --bind to name an address other than loopback (prints a warning: plain HTTP)");
  cmd->add_option("--seed", a->seed, "seed of the simulated machine's noise (default 1)");
  cmd->add_option("--controller", a->controller,
                  "servo controller: p, pid, pid_ff (default), zpetc, ccc, flc, or tuned (the machine's active tuning)");
  cmd->add_option("--db", a->db,
                  "calibration and tuning store, for --controller tuned and the panel's history (default "
                  "$XDG_DATA_HOME/machplan/calibration.db)");
  cmd->add_option("--jobs", a->jobs,
                  "the job folder: programs, material files and profiles named by path are read from here, the bundled "
                  "datasets and the uploads only (default: the current folder)");
  cmd->add_option("--max-machine-time", a->max_machine_time_s,
                  "refuse a job whose estimate exceeds this many seconds of machine time (default 14400: 4 h)")
      ->check(kFinitePositive);
  cmd->add_flag("--no-pace", a->no_pace, "run the simulator as fast as it goes instead of in real time (tests)");
  cmd->add_option("--sim-speed", a->sim_speed,
                  "simulator: simulated seconds per wall-clock second (default 1: real time; tests and demos run faster)")
      ->check(kFinitePositive);
  field_flags(cmd, {{"machine", "--machine"},
                    {"session.machine", "--machine"},
                    {"backend.name", "--backend"},
                    {"session.backend.name", "--backend"},
                    {"controller", "--controller"},
                    {"session.controller", "--controller"},
                    {"bind", "--bind"},
                    {"port", "--port"},
                    {"run.max_machine_time_s", "--max-machine-time"},
                    {"job_folder", "--jobs"},
                    {"sim_speed", "--sim-speed"},
                    {"backend.sim.realtime_speed", "--sim-speed"}});
  cmd->callback([a] { serve(*a); });
}

const Registration reg_serve(64, add_serve);

}  // namespace
}  // namespace machplan::cli
