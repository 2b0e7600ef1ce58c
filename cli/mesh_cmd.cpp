// `machplan mesh FILE.stl [--json]`: reads an STL and reports its topology, size and verdict:
// exit 0 for a sound solid, 3 for one that is open or mis-oriented (as `check` exits 3 when it
// finds interference), 2 for a file that is not an STL.
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/output.h"
#include "engine/programs/mesh.h"

namespace {

void add_mesh(CLI::App& app) {
  struct Args {
    std::string file;
    bool json = false;
    machplan::StlReadOptions options;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("mesh", "Read an STL (binary or ASCII) and report whether it is a sound solid (exit 3 when it is not)");
  cmd->add_option("FILE", args->file, "STL file")->required();
  cmd->add_flag("--json", args->json, "print the report as JSON");
  cmd->add_option("--scale", args->options.scale_to_mm, "millimetres per file unit (25.4 for inches)")
      ->check(machplan::cli::kFinitePositive)
      ->capture_default_str();
  cmd->add_option("--weld-tolerance", args->options.weld_tolerance_mm,
                  "merge vertices closer than this, mm (0: identical only)")
      ->check(machplan::cli::kFiniteNonNegative & CLI::Range(0.0, machplan::StlReadOptions::kMaxWeldToleranceMm))
      ->capture_default_str();
  machplan::cli::field_flags(cmd, {{"scale_to_mm", "--scale"}, {"weld_tolerance_mm", "--weld-tolerance"}});
  cmd->callback([args] {
    machplan::MeshReport r;
    machplan::read_stl(args->file, &r, args->options);
    if (args->json) {
      nlohmann::json j;
      j["source"] = args->file;
      j["vertices"] = r.vertices;
      j["triangles"] = r.triangles;
      j["edges"] = r.edges;
      j["boundary_edges"] = r.boundary_edges;
      j["non_manifold_edges"] = r.non_manifold_edges;
      j["closed"] = r.closed;
      j["consistently_oriented"] = r.consistently_oriented;
      j["degenerate_triangles"] = r.degenerate_triangles;
      if (r.closed && r.consistently_oriented) {
        j["volume_mm3"] = r.volume_mm3;
        j["outward"] = r.outward;
      } else {
        j["volume_mm3"] = nullptr;
        j["outward"] = nullptr;
      }
      j["min_mm"] = {r.bounds.min().x(), r.bounds.min().y(), r.bounds.min().z()};
      j["max_mm"] = {r.bounds.max().x(), r.bounds.max().y(), r.bounds.max().z()};
      j["sound"] = r.sound();
      j["verdict"] = r.verdict();
      machplan::cli::print_json(j);
    } else {
      std::printf("%s:\n%s", args->file.c_str(), r.brief().c_str());
    }
    if (!r.sound()) machplan::cli::set_exit_code(3);
  });
}

const machplan::cli::Registration reg_mesh(40, add_mesh);

}  // namespace
