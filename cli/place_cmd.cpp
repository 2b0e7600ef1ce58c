// `machplan place` and `machplan check`: workpiece placement on the HexaM-type machine.
#include <cmath>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/parse.h"
#include "solvers/placement/plot.h"
#include "solvers/placement/search.h"

namespace machplan::cli {
namespace {

using namespace machplan::placement;


// No machine table or pad reaches 100 m; larger values are typing errors, and their squares
// overflow the geometry.
constexpr double kMaxPlacementMm = 1e5;

double finite_or(double v, double big = 1e9) { return std::isfinite(v) ? v : big; }

nlohmann::json finding_json(const Finding& f) {
  nlohmann::json j{{"interferes", f.interferes}, {"clearance_mm", finite_or(f.clearance_mm)}, {"where", f.what}};
  if (f.pose >= 0) j["pose_index"] = f.pose, j["interval_fraction"] = f.t;
  return j;
}

nlohmann::json report_json(const CheckReport& r) {
  nlohmann::json kinds, clear;
  for (int k = 0; k < kKindCount; ++k) {
    kinds[kind_name(static_cast<Kind>(k))] = finding_json(r.kinds[k]);
    clear[kind_name(static_cast<Kind>(k))] = finite_or(r.kinds[k].clearance_mm);
  }
  return {{"placement",
           {{"x_mm", r.placement.x_mm}, {"y_mm", r.placement.y_mm}, {"pad_mm", r.placement.pad_mm},
            {"rotation_deg", r.placement.rotation_deg}}},
          {"free", r.free()},
          {"min_clearance_mm", clear},
          {"interference", kinds},
          {"stroke_margin_mm", finite_or(r.stroke_margin_mm)},
          {"joint_margin_deg", finite_or(r.joint_margin_deg)}};
}

nlohmann::json counts_json(const CheckCounts& c, std::size_t poses) {
  return {{"tool_poses", poses},
          {"stretches", c.stretches},
          {"exact_pose_queries", c.exact_queries},
          {"interpolated_poses", c.interpolated_poses},
          {"stretches_proven_by_bound", c.proven_by_bound}};
}

std::string clearance_text(double v) { return std::isfinite(v) ? fmt::format("{:8.2f} mm", v) : "   >= safe"; }

void print_report(const CheckReport& r, double safe) {
  std::printf("  %-22s %-12s %-11s %s\n", "kind", "verdict", "clearance", "where");
  for (int k = 0; k < kKindCount; ++k) {
    const Finding& f = r.kinds[k];
    std::string where = f.what;
    if (f.pose >= 0) where += fmt::format(" (tool-path index {}{})", f.pose, f.t > 0 ? fmt::format(" +{:.2f}", f.t) : "");
    std::printf("  %-22s %-12s %s  %s\n", kind_name(static_cast<Kind>(k)), f.interferes ? "INTERFERES" : "free",
                clearance_text(f.clearance_mm).c_str(), where.c_str());
  }
  std::printf("  slider stroke margin %.1f mm, joint cone margin %.1f deg, safe distance %.1f mm\n", r.stroke_margin_mm,
              r.joint_margin_deg, safe);
}

std::vector<double> parse_list(const std::string& text, const std::string& flag, std::size_t count) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const std::optional<double> v = parse_finite(item);
    if (!v) throw InputError(flag, 0, fmt::format("'{}' is not a number", excerpt(item)));
    out.push_back(*v);
  }
  if (count && out.size() != count)
    throw InputError(flag, 0, fmt::format("expects {} comma-separated numbers, got '{}'", count, excerpt(text)));
  if (out.empty()) throw InputError(flag, 0, "expects a comma-separated list of numbers");
  return out;
}

void add_place(CLI::App& app) {
  auto* cmd = app.add_subcommand("place", "Find where to put the workpiece on the HexaM-type machine (pad height, x, y)");
  struct Opts {
    std::string scene, strategy = "optimal", plot, rotations = "0";
    bool json = false, verify = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("SCENE", o->scene, "scene YAML (machine, workpiece, tool path, peripherals)")->required();
  cmd->add_option("--strategy", o->strategy, "paper: the published evasion search; optimal: lowest pad then nearest "
                                             "the centre, certified");
  cmd->add_option("--rotations", o->rotations, "workpiece rotations about z to try (optimal), e.g. 0,90,180,270");
  cmd->add_option("--plot", o->plot, "write a top and side view (.png or .svg)");
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->add_flag("--dense", o->verify, "also re-check the answer at every pose and every 0.5 mm (slow)");
  // The former name (`check` has always said --dense): still accepted, with a warning.
  cmd->add_flag_callback("--dense-check", [o] {
       o->verify = true;
       std::fputs("machplan place: warning: --dense-check is now --dense\n", stderr);
     })
      ->group("");
  field_flags(cmd, {{"rotations_deg", "--rotations"}, {"strategy", "--strategy"}, {"plot", "--plot"}});
  cmd->callback([o] {
    PlacementOptions po;
    po.strategy = accept(parse_placement_strategy(o->strategy), "--strategy");
    po.rotations_deg = parse_list(o->rotations, "--rotations", 0);
    po.validate();
    check_output_folder("--plot", o->plot);
    refuse_overwriting_input("--plot", o->plot, {o->scene});
    const Scene scene = load_scene(o->scene);
    refuse_overwriting_input("--plot", o->plot, {scene.toolpath_file, scene.workpiece_file});
    const StopOnSignals signals;
    po.stop = StopOnSignals::stop_token();
    auto bar = std::make_shared<ProgressBar>("placement search", !o->json);
    po.progress = [bar](double f) { bar->update(f); };
    const PlacementResult r = place(scene, po);
    bar.reset();
    bool dense_free = true;
    if (o->verify && r.status == PlacementStatus::found) {
      Checker checker(scene, r.placement.rotation_deg, StopOnSignals::stop_token());
      ProgressBar dense_bar("dense re-check", !o->json);
      dense_free = checker.dense_check(r.placement, 0.5, [&dense_bar](double f) { dense_bar.update(f); }).free();
    }
    if (!o->plot.empty() && r.status != PlacementStatus::cancelled) write_placement_plot(o->plot, scene, r);
    if (o->json) {
      nlohmann::json j = report_json(r.report);
      j["status"] = to_string(r.status);
      j["message"] = r.message;
      j["strategy"] = o->strategy;
      j["verified"] = r.verified;
      if (o->verify) j["dense_check_free"] = dense_free;
      j["checks"] = counts_json(r.counts, scene.tips_mm.size());
      j["checks"]["placements_examined"] = r.placements_examined;
      j["checks"]["certifications"] = r.certifications;
      j["seconds"] = r.seconds;
      if (!r.trail.empty()) {
        nlohmann::json t = nlohmann::json::array();
        for (const auto& p : r.trail) t.push_back({p.x_mm, p.y_mm, p.pad_mm});
        j["trail"] = t;
      }
      if (!o->plot.empty()) j["plot"] = o->plot;
      machplan::cli::print_json(j);
    } else {
      std::printf("machplan place %s (strategy %s, %zu tool poses, safe distance %.1f mm)\n", o->scene.c_str(),
                  o->strategy.c_str(), scene.tips_mm.size(), scene.safe_distance_mm);
      if (r.status == PlacementStatus::found) {
        std::printf("placement: x %.2f mm, y %.2f mm, pad %.1f mm, rotation %.0f deg  (%s)\n", r.placement.x_mm,
                    r.placement.y_mm, r.placement.pad_mm, r.placement.rotation_deg, r.message.c_str());
        std::printf("certified free over the whole path: %s%s\n", r.verified ? "yes" : "NO",
                    o->verify ? (dense_free ? "; dense re-check: free" : "; dense re-check: INTERFERES") : "");
      } else {
        std::printf("%s\n", r.message.c_str());
      }
      if (r.status != PlacementStatus::cancelled) print_report(r.report, scene.safe_distance_mm);
      std::printf("checks: %ld placements examined%s, %ld exact pose queries, %ld interpolated poses, %ld tree nodes "
                  "(%ld proven by bound)\n",
                  r.placements_examined,
                  o->strategy == "optimal" ? fmt::format(" ({} certified over the whole path)", r.certifications).c_str() : "",
                  r.counts.exact_queries, r.counts.interpolated_poses, r.counts.stretches,
                  r.counts.proven_by_bound);
      std::printf("time: %.3f s\n", r.seconds);
      if (!o->plot.empty()) std::printf("picture: %s\n", o->plot.c_str());
    }
    if (r.status == PlacementStatus::unavoidable || r.status == PlacementStatus::no_placement) {
      std::fprintf(stderr, "%s: cannot be machined on this machine: %s\n", o->scene.c_str(), r.message.c_str());
      set_exit_code(3);
    } else if (r.status == PlacementStatus::cancelled) {
      std::fprintf(stderr, "%s: placement search stopped (signal) before an answer\n", o->scene.c_str());
      set_exit_code(3);
    } else if (r.status != PlacementStatus::found) {
      set_exit_code(1);
    }
  });
}

void add_check(CLI::App& app) {
  auto* cmd = app.add_subcommand("check", "Check one workpiece placement for interference, kind by kind");
  struct Opts {
    std::string scene, at;
    double rotation = 0;
    bool json = false, dense = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("SCENE", o->scene, "scene YAML")->required();
  cmd->add_option("--at", o->at, "placement X,Y,PAD in mm")->required();
  cmd->add_option("--rotation", o->rotation, "workpiece rotation about z, degrees")->check(kFinite);
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->add_flag("--dense", o->dense, "brute-force re-check at every pose and every 0.5 mm (slow)");
  field_flags(cmd, {{"rotation_deg", "--rotation"}});
  cmd->callback([o] {
    const auto v = parse_list(o->at, "--at", 3);
    if (v[2] < 0) throw InputError("--at", 0, fmt::format("pad height must not be negative, got {}", v[2]));
    for (const double c : v)
      if (std::abs(c) > kMaxPlacementMm)
        throw InputError("--at", 0, fmt::format("{} mm is beyond the {} mm any table or pad can reach", c, kMaxPlacementMm));
    validate_rotation_deg(o->rotation, "rotation_deg");
    const Scene scene = load_scene(o->scene);
    // SIGINT, SIGTERM and SIGHUP end a long check with exit 3 (Cancelled), not the process.
    const StopOnSignals signals;
    Checker checker(scene, o->rotation, StopOnSignals::stop_token());
    const Placement p{v[0], v[1], v[2], o->rotation};
    const auto region = placement_region(scene, o->rotation);
    const bool on_table = region.contains(Eigen::Vector2d(p.x_mm, p.y_mm));
    ProgressBar bar("dense check", o->dense && !o->json);
    const CheckReport r = o->dense ? checker.dense_check(p, 0.5, [&bar](double f) { bar.update(f); }) : checker.report(p);
    bar.done();
    if (o->json) {
      nlohmann::json j = report_json(r);
      j["on_table"] = on_table;
      j["checks"] = counts_json(checker.counts(), scene.tips_mm.size());
      j["method"] = o->dense ? "dense" : "certified";
      machplan::cli::print_json(j);
    } else {
      std::printf("machplan check %s at x %.2f, y %.2f, pad %.1f mm: %s\n", o->scene.c_str(), p.x_mm, p.y_mm, p.pad_mm,
                  r.free() && on_table ? "FREE" : "INTERFERENCE");
      if (!on_table) std::printf("  the workpiece overhangs the table\n");
      print_report(r, scene.safe_distance_mm);
    }
    if (!r.free() || !on_table) set_exit_code(3);
  });
}

const Registration reg_place(50, add_place);
const Registration reg_check(51, add_check);

}  // namespace
}  // namespace machplan::cli
