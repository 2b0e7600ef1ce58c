// `machplan profile FILE.dxf [--json] [--tolerance MM] [--join-tolerance MM] [--units NAME]
// [--flatten-tolerance DEG] [--max-entities N]`:
// the closed contours of a DXF profile and every problem found in the drawing (an open chain
// with the gap between its ends: how far it is from closing; each gap healed, with its size). Exit 2 when the file is malformed or a problem of
// severity error was found (after printing everything).
#include <cstdio>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/programs/dxf.h"

namespace {

nlohmann::json to_json(const machplan::ProfileReadResult& r) {
  using nlohmann::json;
  json out;
  out["units"] = "mm";
  out["source"] = r.source;
  out["mm_per_drawing_unit"] = r.mm_per_unit;
  out["units_stated"] = r.has_insunits;
  out["chain_tolerance_mm"] = r.chain_tolerance_mm;
  out["join_tolerance_mm"] = r.join_tolerance_mm;
  json contours = json::array();
  for (const auto& c : r.contours) {
    json v = json::array();
    for (const auto& p : c.contour.vertices()) v.push_back({p.x(), p.y()});
    const auto box = machplan::bounding_box(c.contour);
    contours.push_back({{"vertices", v},
                        {"bulges", c.contour.bulges()},
                        {"area_mm2", std::abs(c.area_mm2)},
                        {"signed_area_mm2", c.area_mm2},
                        {"orientation", machplan::to_string(machplan::orientation(c.contour))},
                        {"perimeter_mm", c.perimeter_mm},
                        {"bbox_mm", {{box.min().x(), box.min().y()}, {box.max().x(), box.max().y()}}},
                        {"parent", c.parent >= 0 ? json(c.parent) : json(nullptr)},
                        {"holes", c.children},
                        {"depth", c.depth},
                        {"role", c.depth % 2 == 0 ? "outer" : "hole"},
                        {"layer", c.layer},
                        {"handles", c.handles}});
  }
  out["contours"] = contours;
  json problems = json::array();
  for (const auto& p : r.problems) {
    problems.push_back({{"severity", machplan::to_string(p.severity)},
                        {"kind", p.kind},
                        {"handles", p.handles},
                        {"message", p.text()},
                        {"at", p.at ? json::array({p.at->x(), p.at->y()}) : json(nullptr)},
                        {"gap_mm", p.gap_mm ? json(*p.gap_mm) : json(nullptr)}});
  }
  out["problems"] = problems;
  return out;
}

void add_profile(CLI::App& app) {
  auto* cmd = app.add_subcommand("profile", "Read a DXF cutting profile: closed contours, holes and drawing problems");
  auto file = std::make_shared<std::string>();
  auto json_out = std::make_shared<bool>(false);
  auto tolerance = std::make_shared<double>(machplan::DxfOptions{}.chain_tolerance_mm);
  cmd->add_option("file", *file, "DXF drawing (ASCII or binary)")->required();
  cmd->add_flag("--json", *json_out, "Print JSON instead of the readable report");
  cmd->add_option("--tolerance", *tolerance, "Largest gap (mm) still joined when chaining entities")
      ->capture_default_str();
  auto join = std::make_shared<double>(machplan::DxfOptions{}.join_tolerance_mm);
  cmd->add_option("--join-tolerance", *join,
                  "Heal gaps up to this (mm, <= 10; 0: off): open chains whose ends are closer are joined, each join "
                  "reported")
      ->capture_default_str();
  auto units = std::make_shared<std::string>();
  auto flatten = std::make_shared<double>(machplan::DxfOptions{}.flatten_tolerance_deg);
  cmd->add_option("--units", *units,
                  "Unit of a drawing that does not state one ($INSUNITS): mm, cm, m, inch, foot, mil, micron, ...");
  cmd->add_option("--flatten-tolerance", *flatten,
                  "Largest tilt (degrees, <= 5) of an entity's plane from XY still projected onto XY")
      ->capture_default_str();
  auto max_entities = std::make_shared<std::size_t>(machplan::DxfOptions{}.max_entities);
  cmd->add_option("--max-entities", *max_entities,
                  "Most entities a drawing may hold, INSERT copies counted (about 1 s per 100 000)")
      ->capture_default_str();
  static constexpr machplan::cli::FieldFlag kFlags[] = {{"chain_tolerance_mm", "--tolerance"},
                                                         {"flatten_tolerance_deg", "--flatten-tolerance"},
                                                         {"max_entities", "--max-entities"},
                                                         {"assumed_mm_per_unit", "--units"},
                                                         {"join_tolerance_mm", "--join-tolerance"}};
  machplan::cli::field_flags(cmd, kFlags);
  cmd->callback([=] {
    machplan::DxfOptions options;
    options.max_entities = *max_entities;
    options.chain_tolerance_mm = *tolerance;
    options.join_tolerance_mm = *join;
    options.flatten_tolerance_deg = *flatten;
    if (!units->empty()) {
      options.assumed_mm_per_unit = machplan::mm_per_drawing_unit(*units);
      if (options.assumed_mm_per_unit == 0)
        throw machplan::InputError("--units", 0,
                                   fmt::format("'{}' is not a unit machplan knows (mm, cm, dm, m, inch, foot, yard, "
                                               "mil, micron, microinch)",
                                               machplan::excerpt(*units)));
    }
    options.validate();
    auto result = machplan::read_dxf_profile(*file, options);
    // A problem an option settles names the flag that sets it ("... with --units").
    for (auto& p : result.problems)
      for (const auto& f : kFlags)
        if (p.option == f.field) p.option = f.flag;
    if (*json_out)
      machplan::cli::print_json(to_json(result));
    else
      std::fputs(result.report().c_str(), stdout);
    if (result.has_errors()) {
      if (!*json_out) std::fprintf(stderr, "%s: the profile has errors (see above)\n", file->c_str());
      machplan::cli::set_exit_code(2);
    }
  });
}

const machplan::cli::Registration reg_profile(20, add_profile);

}  // namespace
