// `machplan place` and `machplan check`: workpiece placement on a HexaM-type hexapod or a
// table-tilting 5-axis machine.
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/json/placement_json.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "solvers/placement/report/plot.h"
#include "solvers/placement/search/search.h"

namespace machplan::cli {
namespace {

using namespace machplan::placement;

// No machine table or pad reaches 100 m; larger values are typing errors, and their squares
// overflow the geometry.
constexpr double kMaxPlacementMm = 1e5;

std::vector<double> parse_list(const std::string& text, const std::string& flag, std::size_t count) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    out.push_back(number_flag(flag, item));
  }
  if (count && out.size() != count)
    throw InputError(flag, 0, fmt::format("expects {} comma-separated numbers, got '{}'", count, excerpt(text)));
  if (out.empty()) throw InputError(flag, 0, "expects a comma-separated list of numbers");
  return out;
}

// Prints how the work ended: the full report on stdout, and when it was not done, why on
// stderr (the exit code follows).
void finish(const Summary& s, const std::string& scene, bool json) {
  if (!json) std::fputs(s.full_report().c_str(), stdout);
  if (!s.done()) std::fprintf(stderr, "%s: %s\n", scene.c_str(), s.message.c_str());
}

void add_place(CLI::App& app) {
  auto* cmd = app.add_subcommand("place", "Find where to put the workpiece on the machine (pad or fixture height, x, y, rotation)");
  struct Opts {
    std::string scene, strategy = "optimal", plot, rotations = "0", objective = "automatic";
    int threads = 0;
    double time_gap = 1.0;
    bool json = false, verify = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("SCENE", o->scene, "scene YAML (machine, workpiece, tool path, peripherals)")->required();
  cmd->add_option("--strategy", o->strategy, "paper: the published evasion search (hexapod); optimal: certified best");
  cmd->add_option("--rotations", o->rotations,
                  "workpiece rotations about the table's z: a list (0,90,180,270), a range FROM:TO:STEP (0:360:15), or "
                  "any (every multiple of the scene's search.rotation_step_deg)");
  cmd->add_option("--objective", o->objective,
                  "lowest (pad, then nearest the centre), travel (least linear axis travel) or time (least machining "
                  "time); automatic: lowest on a hexapod, travel on a trunnion")
;
  cmd->add_option("--time-gap", o->time_gap,
                  "time: stop once no setup left can be more than this many per cent faster than the best found "
                  "(default 1; 0: prove the best on the grid)");
  cmd->add_option("--threads", o->threads, "worker threads (0: every core)")->check(CLI::Range(0, 1024));
  cmd->add_option("--plot", o->plot, "write a top and side view (.png or .svg)");
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->add_flag("--dense", o->verify, "also re-check the answer at every pose and every 0.5 mm (slow)");
  // The former name (`check` has always said --dense): still accepted, with a warning.
  cmd->add_flag_callback("--dense-check", [o] {
       o->verify = true;
       std::fputs("machplan place: warning: --dense-check is now --dense\n", stderr);
     })
      ->group("");
  field_flags(cmd, {{"rotations_deg", "--rotations"},
                    {"rotations", "--rotations"},
                    {"objective", "--objective"},
                    {"threads", "--threads"},
                    {"time_gap_pct", "--time-gap"},
                    {"strategy", "--strategy"},
                    {"plot", "--plot"}});
  cmd->callback([o] {
    PlacementOptions po;
    po.strategy = accept(parse_placement_strategy(o->strategy), "--strategy");
    po.threads = o->threads;
    po.time_gap_pct = o->time_gap;
    parse_rotations(o->rotations, po);
    po.objective = parse_objective(o->objective);
    po.validate();
    check_output_folder("--plot", o->plot);
    refuse_overwriting_input("--plot", o->plot, {o->scene});
    const Scene scene = load_scene(o->scene);
    refuse_overwriting_input("--plot", o->plot, {scene.toolpath_file, scene.workpiece_file});
    const StopOnSignals signals;
    Termination term(StopOnSignals::stop_token());
    PlacementResult r;
    {
      Progress progress;
      const ProgressWatch bar("placement search", !o->json, progress);
      r = place(scene, po, term, &progress);
    }
    CheckResult dense;
    if (o->verify && r.summary.done()) {
      Progress progress;
      const ProgressWatch bar("dense re-check", !o->json, progress);
      CheckOptions co;
      co.dense = true;
      dense = check(scene, r.placement, co, term, &progress);
    }
    if (!o->plot.empty() && !r.ended_early())
      write_placement_plot(o->plot, scene, r);
    if (o->json) {
      nlohmann::json j = placement_result_json(scene, r, o->strategy);
      if (o->verify) j["dense_check_free"] = dense.summary.done() && dense.report.free();
      if (!o->plot.empty()) j["plot"] = o->plot;
      print_json(j);
    }
    finish(r.summary, o->scene, o->json);
    if (!o->json && o->verify && r.summary.done())
      std::printf("dense re-check (every pose and every 0.5 mm): %s\n",
                  !dense.summary.done() ? dense.summary.message.c_str() : dense.report.free() ? "free" : "INTERFERES");
    if (!o->json && !o->plot.empty()) std::printf("picture: %s\n", o->plot.c_str());
    if (!r.summary.done()) set_exit_code(r.summary.exit_code());
  });
}

void add_check(CLI::App& app) {
  auto* cmd = app.add_subcommand("check", "Check one workpiece placement for interference, kind by kind");
  struct Opts {
    std::string scene, at;
    double rotation = 0;
    int threads = 0;
    bool json = false, dense = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("SCENE", o->scene, "scene YAML")->required();
  cmd->add_option("--at", o->at, "placement X,Y,PAD in mm")->required();
  cmd->add_option("--rotation", o->rotation, "workpiece rotation about the table's z, degrees")->check(kFinite);
  cmd->add_option("--threads", o->threads, "worker threads (0: every core)")->check(CLI::Range(0, 1024));
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->add_flag("--dense", o->dense, "brute-force re-check at every pose and every 0.5 mm (slow)");
  field_flags(cmd, {{"rotation_deg", "--rotation"}});
  cmd->callback([o] {
    const auto v = parse_list(o->at, "--at", 3);
    if (v[2] < 0) throw InputError("--at", 0, fmt::format("pad height must not be negative, got {}", v[2]));
    for (const double c : v)
      if (std::abs(c) > kMaxPlacementMm)
        throw InputError("--at", 0, fmt::format("{} mm is beyond the {} mm any table or pad can reach", c, kMaxPlacementMm));
    if (std::abs(o->rotation) > 360)
      throw InputError("--rotation", 0, fmt::format("rotation {} deg: must be a finite angle within -360 .. 360", o->rotation));
    const Scene scene = load_scene(o->scene);
    if (v[2] < scene.spoilboard_mm)
      throw InputError("--at", 0, fmt::format("pad {} mm is thinner than the scene's spoilboard ({} mm)", v[2], scene.spoilboard_mm));
    // SIGINT, SIGTERM and SIGHUP end a long check with exit 3, not the process.
    const StopOnSignals signals;
    Termination term(StopOnSignals::stop_token());
    CheckOptions co;
    co.dense = o->dense;
    co.threads = o->threads;
    CheckResult r;
    {
      Progress progress;
      const ProgressWatch bar("dense check", o->dense && !o->json, progress);
      r = check(scene, {v[0], v[1], v[2], o->rotation}, co, term, &progress);
    }
    if (o->json && r.summary.done()) print_json(check_result_json(scene, r));
    finish(r.summary, o->scene, o->json);
    if (!r.summary.done() || !r.report.free()) set_exit_code(3);
  });
}

const Registration reg_place(50, add_place);
const Registration reg_check(51, add_check);

}  // namespace
}  // namespace machplan::cli
