// `machplan guard PROFILE.dxf --side outside|inside --tool-radius R --tolerance T --operator
// script.csv|random:N|joystick[:DEVICE]|keys [...]`: hybrid manual / servo-assisted machining
// on the simulated XY table (solvers/guard/guard_run.h): the operator roughs under the guard,
// then, with --finish, the machine contours the offset profile by itself.
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.h"
#include "cli/interrupt.h"
#include "cli/json/guard.h"
#include "cli/field_flags.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "solvers/common/picture.h"
#include "solvers/guard/guard_run.h"

namespace machplan::cli {
namespace {

struct GuardArgs {
  std::string profile, side, tool_radius, tolerance, op, feed, latency_ms, strategy = "predictive", plot, seed, machine = "xy_table",
                                                                  offset = "robust", finish_feed, finish_allowance, backend = "sim";
  bool finish = false, json = false;
};

void add_guard(CLI::App& app) {
  auto a = std::make_shared<GuardArgs>();
  auto* cmd = app.add_subcommand("guard", "Hybrid manual machining: an operator roughs under the guard, the machine finishes");
  cmd->add_option("profile", a->profile, "the part's profile (DXF, closed contours)")->required();
  cmd->add_option("--side", a->side, "outside (keep out of the part) or inside (keep inside a pocket)")->required();
  cmd->add_option("--tool-radius", a->tool_radius, "tool radius R, mm")->required();
  cmd->add_option("--tolerance", a->tolerance, "tolerance T, mm: the band outside the offset profile where the guard stops")
      ->required();
  cmd->add_option("--operator", a->op, "script.csv | random:N | joystick[:DEVICE] | keys")->required();
  cmd->add_option("--feed", a->feed, "operator's speed, mm/s (default 12, the paper's)");
  cmd->add_option("--latency-ms", a->latency_ms,
                  fmt::format("PC-to-controller round trip, ms (default {:g}: reproduces the paper's tables)",
                              executor::kPaperLatencyS * 1000));
  cmd->add_option("--strategy", a->strategy, "paper (ask, compare, stop) or predictive (default)");
  cmd->add_option("--offset", a->offset, "offset method: robust (default) or paper");
  cmd->add_flag("--finish", a->finish, "after roughing, contour the whole offset profile automatically");
  cmd->add_option("--finish-feed", a->finish_feed, "finishing feed, mm/s (default: --feed)");
  cmd->add_option("--finish-allowance", a->finish_allowance,
                  "finish in two passes: first this far off the profile, mm, then on it (the paper's proposal)");
  cmd->add_option("--plot", a->plot, "write the picture of the run (profile, region, strokes, finishing), .png or .svg");
  cmd->add_option("--seed", a->seed, "seed of the random operator and the simulator (default 1)");
  cmd->add_option("--machine", a->machine, "machine name or YAML file (default xy_table)");
  cmd->add_option("--backend", a->backend,
                  "the machine: sim (the simulated table; default) or hal (through LinuxCNC's HAL: docs/hal.md)");
  cmd->add_flag("--json", a->json, "machine-readable output");
  field_flags(cmd, {{"side", "--side"},
                    {"method", "--offset"},
                    {"strategy", "--strategy"},
                    {"region.tool_radius_mm", "--tool-radius"},
                    {"guard.tolerance_mm", "--tolerance"},
                    {"guard.latency_s", "--latency-ms"},
                    {"feed_mm_per_s", "--feed"},
                    {"finish_feed_mm_per_s", "--finish-feed"},
                    {"finish_allowance_mm", "--finish-allowance"},
                    {"op", "--operator"},
                    {"operator", "--operator"},
                    {"machine", "--machine"},
                    {"backend", "--backend"},
                    {"plot", "--plot"}});
  cmd->callback([a] {
    guard::GuardRunOptions o;
    o.machine = a->machine;
    o.backend = a->backend;
    o.region.side = accept(parse_machining_side(a->side), "--side");
    o.region.method = accept(parse_offset_method(a->offset), "--offset");
    o.region.tool_radius_mm = number_flag("--tool-radius", a->tool_radius);
    o.guard.tolerance_mm = number_flag("--tolerance", a->tolerance);
    o.guard.strategy = accept(executor::parse_guard_strategy(a->strategy), "--strategy");
    if (!a->latency_ms.empty()) o.guard.latency_s = number_flag("--latency-ms", a->latency_ms) / 1000.0;
    if (!a->feed.empty()) o.feed_mm_per_s = number_flag("--feed", a->feed);
    o.op = guard::operator_from_string(a->op);
    o.finish = a->finish;
    if (!a->finish_feed.empty()) o.finish_feed_mm_per_s = number_flag("--finish-feed", a->finish_feed);
    if (!a->finish_allowance.empty()) o.finish_allowance_mm = number_flag("--finish-allowance", a->finish_allowance);
    if ((!a->finish_feed.empty() || !a->finish_allowance.empty()) && !a->finish)
      throw InputError(!a->finish_feed.empty() ? "--finish-feed" : "--finish-allowance", 0, "applies with --finish only");
    if (!a->seed.empty()) o.seed = seed_of(a->seed);
    if (o.op.kind == guard::OperatorSpec::Kind::keys && a->json)
      throw InputError("--json", 0, "the keys operator reads the terminal; --json needs a script or random operator");
    o.validate();
    if (!a->plot.empty()) {
      if (!is_picture_path(a->plot)) throw InputError("--plot", 0, fmt::format("'{}' must end in .png or .svg", a->plot));
      refuse_overwriting_input("--plot", a->plot, {a->profile, a->machine, o.op.path});
      check_output_folder("--plot", a->plot);
    }
    if (o.op.kind == guard::OperatorSpec::Kind::keys)
      std::fprintf(stderr, "keys: arrows or w/a/s/d steer, 1..9 set the speed, space stops, q ends roughing\n");
    // SIGINT, SIGTERM and SIGHUP end the session in a controlled way (exit 3), not the process.
    const StopOnSignals signals;
    Termination stop(StopOnSignals::stop_token());
    Progress progress;
    const guard::GuardRunResult r = [&] {
      // Keys and joystick sessions are paced by the operator: no bar.
      const ProgressWatch watch("guard", !a->json && o.op.kind != guard::OperatorSpec::Kind::keys, progress);
      return guard::run_guard_file(a->profile, o, stop, &progress);
    }();
    if (!a->plot.empty()) guard::write_guard_plot(r, a->plot);
    if (a->json) print_json(to_json(r));
    else std::fputs(r.summary.full_report().c_str(), stdout);
    set_exit_code(r.summary.exit_code());
  });
}

const Registration reg_guard(62, add_guard);

}  // namespace
}  // namespace machplan::cli
