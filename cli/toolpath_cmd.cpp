// `machplan toolpath FILE [--json]`: reads an APT/CLDATA or CSV tool path and summarises it.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/output.h"
#include "engine/programs/toolpath.h"

namespace {

constexpr double kDegPerRad = 180.0 / M_PI;

void add_toolpath(CLI::App& app) {
  struct Args {
    std::string file;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("toolpath", "Read a CL tool path (APT/CLDATA .cl/.apt/.cls or CSV) and summarise it");
  cmd->add_option("FILE", args->file, "tool-path file")->required();
  cmd->add_flag("--json", args->json, "print the summary as JSON");
  cmd->callback([args] {
    const machplan::ToolPath path = machplan::read_toolpath_file(args->file);
    const machplan::ToolPathSummary s = machplan::summarize(path);
    // What changes the result first, then one line for every statement skipped.
    for (const auto& w : path.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (const std::string skipped = machplan::skipped_summary(path); !skipped.empty())
      std::fprintf(stderr, "note: %s\n", skipped.c_str());
    if (args->json) {
      nlohmann::json j;
      j["source"] = path.source;
      j["part_name"] = path.part_name;
      j["poses"] = s.poses;
      j["rapid_poses"] = s.rapid_poses;
      j["multiaxis"] = path.multiaxis;
      j["min_mm"] = {s.min_mm.x(), s.min_mm.y(), s.min_mm.z()};
      j["max_mm"] = {s.max_mm.x(), s.max_mm.y(), s.max_mm.z()};
      j["tilt_min_deg"] = s.min_tilt_rad * kDegPerRad;
      j["tilt_max_deg"] = s.max_tilt_rad * kDegPerRad;
      j["max_step_mm"] = s.max_step_mm;
      j["max_step_line"] = s.max_step_line;
      j["feed_length_mm"] = s.feed_length_mm;
      j["rapid_length_mm"] = s.rapid_length_mm;
      j["arcs"] = path.arcs.size();
      j["warnings"] = path.warnings;
      j["skipped"] = nlohmann::json::array();
      for (const auto& k : path.skipped)
        j["skipped"].push_back({{"statement", k.statement}, {"count", k.count}, {"first_line", k.first_line}});
      if (path.cutter)
        j["cutter"] = {{"diameter_mm", path.cutter->diameter_mm},
                       {"corner_radius_mm", path.cutter->corner_radius_mm},
                       {"length_mm", path.cutter->length_mm}};
      else
        j["cutter"] = nullptr;
      j["tools"] = nlohmann::json::array();
      for (const auto& t : path.tools) {
        nlohmann::json tj = {{"name", t.name()}, {"line", t.line}, {"poses", t.poses}};
        tj["number"] = t.number >= 0 ? nlohmann::json(t.number) : nlohmann::json(nullptr);
        if (t.cutter)
          tj["cutter"] = {{"diameter_mm", t.cutter->diameter_mm}, {"corner_radius_mm", t.cutter->corner_radius_mm},
                          {"length_mm", t.cutter->length_mm}, {"line", t.cutter->line}};
        if (t.flute_mm > 0) tj["flute_length_mm"] = t.flute_mm;
        if (t.extension_mm > 0) tj["extension_mm"] = t.extension_mm;
        j["tools"].push_back(tj);
      }
      machplan::cli::print_json(j);
      return;
    }
    std::string out = fmt::format("{}: {} poses ({} rapid){}\n", path.source, s.poses, s.rapid_poses,
                                  path.multiaxis ? ", multi-axis" : "");
    // The report read alone (stderr aside) still shows that its figures are not the part's.
    for (const auto& w : path.warnings) out += fmt::format("WARNING: {}\n", w);
    if (!path.part_name.empty()) out += fmt::format("part: {}\n", path.part_name);
    out += fmt::format("tips: x {:.4f} .. {:.4f}, y {:.4f} .. {:.4f}, z {:.4f} .. {:.4f} mm\n", s.min_mm.x(),
                       s.max_mm.x(), s.min_mm.y(), s.max_mm.y(), s.min_mm.z(), s.max_mm.z());
    out += fmt::format("tool axis tilt from +Z: {:.3f} .. {:.3f} deg\n", s.min_tilt_rad * kDegPerRad,
                       s.max_tilt_rad * kDegPerRad);
    out += fmt::format("largest step between tips: {:.4f} mm (ending at line {})\n", s.max_step_mm, s.max_step_line);
    out += fmt::format("path length: {:.3f} mm at feed, {:.3f} mm rapid\n", s.feed_length_mm, s.rapid_length_mm);
    if (!path.arcs.empty()) out += fmt::format("circular moves: {} (poses added along them)\n", path.arcs.size());
    if (path.tools.empty()) out += "tools: none named, no CUTTER\n";
    for (const auto& t : path.tools) {
      out += fmt::format("tool {} (line {}): {} poses", t.name(), t.line, t.poses);
      if (t.cutter)
        out += fmt::format(", diameter {:.4g} mm, corner radius {:.4g} mm, length {:.4g} mm", t.cutter->diameter_mm,
                           t.cutter->corner_radius_mm, t.cutter->length_mm);
      else
        out += ", no CUTTER";
      if (t.flute_mm > 0) out += fmt::format(", flutes {:.4g} mm", t.flute_mm);
      if (t.extension_mm > 0) out += fmt::format(", {:.4g} mm out of the holder", t.extension_mm);
      out += "\n";
    }
    std::fputs(out.c_str(), stdout);
  });
}

const machplan::cli::Registration reg_toolpath(30, add_toolpath);

}  // namespace
