// `machplan nest PART.dxf[:QTY]... --sheet WxH[:COUNT] [--spacing MM] [--margin MM]
// [--rotations any|none|DEG,DEG,...] [--split] [--json]`: parts from drawings nested on
// sheets by bottom-left fill (solvers/nesting/bottom_left.h), the nest certified on the true
// geometry (solvers/nesting/certificate.h). The report gives per sheet the parts, the used
// length from the left edge, the utilisation of the area used and the remnant; `--json` gives
// every placed copy's transform: a point (x, y) of the drawing lands on the sheet at
// translate + R(rotation) * (x, y). Exit 3 when a copy fits on no sheet (each is named with
// the reason; the rest is still nested) or the certificate fails.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/interrupt.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/programs/gcode_writer.h"
#include "models/cutting/machine_config.h"
#include "solvers/motion/cut_order.h"
#include "solvers/motion/run.h"
#include "solvers/nesting/strip_search.h"
#include "solvers/nesting/nest_job.h"
#include "solvers/nesting/sheet_plot.h"
#include "solvers/nesting/sheet_program.h"

namespace machplan::cli {
namespace {

using nlohmann::json;

// "FILE" or "FILE:QTY" (the last colon, when digits follow it).
std::pair<std::string, int> part_spec(const std::string& s) {
  const std::size_t colon = s.rfind(':');
  if (colon == std::string::npos || colon + 1 == s.size() || s.find_first_not_of("0123456789", colon + 1) != std::string::npos)
    return {s, 1};
  const std::string q = s.substr(colon + 1);
  if (q.size() > 6 || std::stoi(q) < 1)
    throw InputError("part", 0, fmt::format("'{}': the quantity after the colon must be 1 .. 100000", excerpt(s)));
  return {s.substr(0, colon), std::stoi(q)};
}

// "WxH" or "WxH:COUNT": that many sheets alike.
std::vector<nesting::Sheet> sheet_spec(const std::string& s, double margin_mm) {
  double w = 0, h = 0;
  int n = 1, used = 0;
  const bool with_count = std::sscanf(s.c_str(), "%lfx%lf:%d%n", &w, &h, &n, &used) == 3 && used == static_cast<int>(s.size());
  used = 0;
  if (!with_count && !(std::sscanf(s.c_str(), "%lfx%lf%n", &w, &h, &used) == 2 && used == static_cast<int>(s.size())))
    throw InputError("--sheet", 0, fmt::format("'{}' is not WIDTHxHEIGHT[:COUNT] in mm (e.g. 2500x1250:2)", excerpt(s)));
  if (!(w > 0 && h > 0 && w <= 1e5 && h <= 1e5) || n < 1 || n > 1000)
    throw InputError("--sheet", 0, fmt::format("'{}': sizes in (0, 100000] mm and 1 .. 1000 sheets", excerpt(s)));
  nesting::Sheet sheet;
  sheet.width_mm = w, sheet.height_mm = h, sheet.margin_mm = margin_mm;
  return std::vector<nesting::Sheet>(static_cast<std::size_t>(n), sheet);
}

json nest_json(const nesting::NestRequest& r, const nesting::NestResult& n, const nesting::StripSearchStats& search,
               const nesting::Certificate& cert, const Termination& t) {
  json sheets = json::array(), placements = json::array(), unplaced = json::array();
  std::vector<double> area(r.sheets.size(), 0.0);
  std::vector<int> count(r.sheets.size(), 0);
  for (const nesting::Placement& p : n.placements) {
    area[static_cast<std::size_t>(p.sheet)] += r.parts[p.part].area_mm2;
    ++count[static_cast<std::size_t>(p.sheet)];
    placements.push_back({{"file", r.parts[p.part].file},
                          {"copy", p.copy + 1},
                          {"sheet", p.sheet + 1},
                          {"rotation_deg", p.rotation_deg},
                          {"mirrored", p.mirrored},
                          {"translate_mm", {p.translate_mm.x(), p.translate_mm.y()}}});
  }
  for (std::size_t k = 0; k < r.sheets.size(); ++k) {
    if (n.used_length_mm[k] <= 0.0) continue;  // no part on it (as write_programs skips it)
    const nesting::Sheet& sh = r.sheets[k];
    const double used = n.used_length_mm[k];
    sheets.push_back({{"sheet", k + 1},
                      {"width_mm", sh.width_mm},
                      {"height_mm", sh.height_mm},
                      {"margin_mm", sh.margin_mm},
                      {"parts", count[k]},
                      {"used_length_mm", used},
                      {"utilisation", area[k] / (sh.remnant ? sh.remnant->area_mm2 : used * sh.height_mm)},
                      {"remnant_mm", {sh.width_mm - used, sh.height_mm}}});
    if (sh.remnant) {
      sheets.back()["remnant"] = sh.remnant->file;
      sheets.back()["drawn_at_mm"] = {sh.drawn_at.x(), sh.drawn_at.y()};
    }
  }
  for (const nesting::Unplaced& u : n.unplaced)
    unplaced.push_back({{"file", r.parts[u.part].file}, {"copy", u.copy + 1}, {"reason", u.reason}});
  return {{"units", "mm"},       {"spacing_mm", r.spacing_mm}, {"fills", n.fills},
          {"search_s", t.work_s_spent()}, {"search_ended", t.describe()},
          {"strip_search", {{"start_length_mm", search.start_length_mm}, {"shrinks_tried", search.shrinks_tried},
                            {"shrinks_kept", search.shrinks_kept}, {"moves", search.moves},
                            {"collision_tests", search.tests}, {"collision_steps", search.meets_steps}, {"deep_pairs", search.deep_pairs}, {"pole_pairs", search.pole_pairs},
                            {"note", search.note}}},
          {"certified", cert.certified}, {"violations", cert.violations}, {"sheets", sheets},
          {"placements", placements},    {"unplaced", unplaced}};
}

// What the nest's programs are made with, besides SheetProgramOptions.
struct ProgramArgs {
  nesting::SheetProgramOptions sheet;
  GcodeDialect dialect = GcodeDialect::linuxcnc;
  std::string machine, materials;
};

// The header of a sheet's program: the sheet, every part and where it went, the kerf.
std::string program_header(const nesting::NestRequest& r, const nesting::NestResult& n, int k, const nesting::SheetProgram& sp,
                           const nesting::SheetProgramOptions& o) {
  const nesting::Sheet& sh = r.sheets[static_cast<std::size_t>(k)];
  std::string h = fmt::format("sheet {} of {}, {:.0f} x {:.0f} mm, nested by machplan nest; spacing {:g} mm\n", k + 1, r.sheets.size(),
                              sh.width_mm, sh.height_mm, r.spacing_mm);
  if (sh.remnant)
    h += fmt::format("a remnant, {}: X0 Y0 here is X {:.3f} Y {:.3f} of its drawing (the lower-left corner of its box)\n",
                     sh.remnant->file, sh.drawn_at.x(), sh.drawn_at.y());
  for (const nesting::Placement& pl : n.placements)
    if (pl.sheet == k)
      h += fmt::format("{} copy {}: at X {:.3f} Y {:.3f}, turned {:g} deg{}\n", std::filesystem::path(r.parts[pl.part].file).filename().string(),
                       pl.copy + 1, pl.translate_mm.x(), pl.translate_mm.y(), pl.rotation_deg, pl.mirrored ? ", mirrored" : "");
  if (o.kerf_mm <= 0) h += "kerf not compensated: machplan run --kerf WIDTH compensates it\n";
  else if (o.compensate_kerf) h += fmt::format("kerf {:g} mm compensated here: outlines grown and holes shrunk by {:g} mm\n", o.kerf_mm, o.kerf_mm / 2);
  else h += fmt::format("kerf {:g} mm NOT compensated here: run it with machplan run --kerf {:g}\n", o.kerf_mm, o.kerf_mm);
  h += fmt::format("lead-in {} {:g} mm, lead-out {} {:g} mm, overcut {:g} mm; part on the {} of the travel\n", to_string(o.lead_in.shape),
                   o.lead_in.length_mm, to_string(o.lead_out.shape), o.lead_out.length_mm, o.overcut_mm, o.part_on_right ? "right" : "left");
  for (const std::string& w : sp.warnings) h += w + "\n";
  return h + sp.order_summary;
}

// Each sheet's cut program (solvers/nesting/sheet_program.h), written to DIR/sheet_K.ngc; per
// sheet used, its path, cut length, pierces and rapid length, the leads it had to shorten, and
// with a machine the cycle `machplan run` plans for it there.
json write_programs(const nesting::NestRequest& r, const nesting::NestResult& n, const std::string& dir, const ProgramArgs& a) {
  std::optional<cutting::MachineConfig> m;
  if (!a.machine.empty()) m = cutting::load_machine(cutting::find_machine(a.machine));
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw OutputError(dir, ec.message());
  json out = json::array();
  for (int k = 0; k < static_cast<int>(r.sheets.size()); ++k) {
    if (n.used_length_mm[static_cast<std::size_t>(k)] <= 0.0) continue;
    const nesting::Sheet& sh = r.sheets[static_cast<std::size_t>(k)];
    const nesting::SheetProgram sp = nesting::sheet_program(r.parts, n.placements, k, sh, a.sheet);
    const std::string path = (std::filesystem::path(dir) / fmt::format("sheet_{}.ngc", k + 1)).string();
    write_file_atomically(path, write_gcode(sp.program, program_header(r, n, k, sp, a.sheet), a.dialect));
    const ProgramSummary sum = summarize(sp.program);
    const std::string picture = (std::filesystem::path(dir) / fmt::format("sheet_{}.png", k + 1)).string();
    nesting::plot_sheet(picture, r.parts, n.placements, k, sh, sp.program,
                        fmt::format("sheet {}: {:.0f} x {:.0f} mm, used length {:.1f} mm; {} pierces in cut order, rapids dashed", k + 1,
                                    sh.width_mm, sh.height_mm, n.used_length_mm[static_cast<std::size_t>(k)], sum.torch_on_count));
    json sheet = {{"program", path}, {"picture", picture}, {"cut_length_mm", sum.feed_length_mm}, {"pierces", sum.torch_on_count},
                  {"rapid_mm", sum.rapid_length_mm}, {"leads_shortened", sp.shortened}, {"leads_cramped", sp.cramped},
                  {"warnings", sp.warnings}};
    if (m) {
      motion::RunOptions ro;
      ro.session.machine_config = *m;
      ro.materials_path = a.materials;
      ro.gcode.dialect = a.dialect;
      const motion::PlannedRun plan = motion::plan_program(path, ro, *m);
      if (!plan.summary.done()) throw InputError("--machine", 0, fmt::format("sheet {} on {}: {}", k + 1, m->name, plan.summary.message));
      sheet["cycle_s"] = plan.expected_s();
    }
    out.push_back(sheet);
  }
  return out;
}

void print_nest_report(const json& j) {
  std::printf("nest: %zu copies placed on %zu sheet(s), spacing %g mm; best of %d bottom-left fills (%s)\n",
              j["placements"].size(), j["sheets"].size(), j["spacing_mm"].get<double>(), j["fills"].get<int>(),
              j["search_ended"].get<std::string>().c_str());
  if (const json& ss = j["strip_search"]; ss["shrinks_tried"].get<int>() > 0)
    std::printf("  strip search: the last sheet's used length from %.1f to %.1f mm (%d of %d shrinks kept, %lld moves)\n",
                ss["start_length_mm"].get<double>(), j["sheets"].back()["used_length_mm"].get<double>(), ss["shrinks_kept"].get<int>(),
                ss["shrinks_tried"].get<int>(), ss["moves"].get<long long>());
  if (const std::string note = j["strip_search"]["note"]; !note.empty()) std::printf("  strip search not run: %s\n", note.c_str());
  for (const json& s : j["sheets"]) {
    if (s.contains("remnant"))
      std::printf("  sheet %d: the remnant %s: %d parts, %.1f %% of its material, used length %.1f mm of %.0f\n", s["sheet"].get<int>(),
                  s["remnant"].get<std::string>().c_str(), s["parts"].get<int>(), 100.0 * s["utilisation"].get<double>(),
                  s["used_length_mm"].get<double>(), s["width_mm"].get<double>());
    else
      std::printf("  sheet %d: %d parts, used length %.1f mm of %.0f, utilisation %.1f %% of the area used, remnant %.1f x %.1f mm\n",
                  s["sheet"].get<int>(), s["parts"].get<int>(), s["used_length_mm"].get<double>(), s["width_mm"].get<double>(),
                  100.0 * s["utilisation"].get<double>(), s["remnant_mm"][0].get<double>(), s["remnant_mm"][1].get<double>());
    if (s.contains("program"))
      std::printf("    program: %s: cut length %.0f mm, %d pierces, rapids %.0f mm%s\n", s["program"].get<std::string>().c_str(),
                  s["cut_length_mm"].get<double>(), s["pierces"].get<int>(), s["rapid_mm"].get<double>(),
                  s.contains("cycle_s") ? fmt::format(", cycle {:.1f} s planned", s["cycle_s"].get<double>()).c_str() : "");
    if (s.contains("leads_shortened") && s["leads_shortened"].get<int>() + s["leads_cramped"].get<int>() > 0)
      std::printf("    leads shortened for want of room: %d; with less room than the clearance even so: %d\n",
                  s["leads_shortened"].get<int>(), s["leads_cramped"].get<int>());
    if (s.contains("warnings"))
      for (const json& w : s["warnings"]) std::printf("    warning: %s\n", w.get<std::string>().c_str());
  }
  std::printf("  %s\n", j["certified"].get<bool>() ? "certified: every pair of parts at least the spacing apart on the true "
                                                      "lines and arcs, every part inside the usable area"
                                                    : "NOT certified:");
  for (const json& v : j["violations"]) std::printf("    %s\n", v.get<std::string>().c_str());
  for (const json& u : j["unplaced"])
    std::printf("  not placed: %s copy %d: %s\n", u["file"].get<std::string>().c_str(), u["copy"].get<int>(),
                u["reason"].get<std::string>().c_str());
}

struct NestArgs {
  std::vector<std::string> parts;
  std::string sheet, rotations = "any", out;
  std::string lead_in_shape = "arc", lead_out_shape = "line", kerf_by = "program", part_side = "right", dialect = "linuxcnc";
  ProgramArgs program;
  double spacing = 6.0, margin = 10.0, time = 2.0;
  std::uint64_t seed = 1;
  bool split = false, json = false;
};

// The program options from the flags, checked (names and what GRBL cannot say) before the search.
ProgramArgs program_args(const NestArgs& a, const CLI::App* cmd) {
  ProgramArgs p = a.program;
  auto shape = [](const std::string& flag, const std::string& name) {
    if (const auto s = nesting::lead_shape_from(name)) return *s;
    throw InputError(flag, 0, fmt::format("'{}' is not a lead shape: arc or line", excerpt(name)));
  };
  p.sheet.lead_in.shape = shape("--lead-in-shape", a.lead_in_shape);
  p.sheet.lead_out.shape = shape("--lead-out-shape", a.lead_out_shape);
  if (a.kerf_by != "program" && a.kerf_by != "controller")
    throw InputError("--kerf-by", 0, fmt::format("'{}': program or controller", excerpt(a.kerf_by)));
  p.sheet.compensate_kerf = a.kerf_by == "program";
  if (a.part_side != "right" && a.part_side != "left")
    throw InputError("--part-side", 0, fmt::format("'{}': right or left", excerpt(a.part_side)));
  p.sheet.part_on_right = a.part_side == "right";
  if (a.dialect != "linuxcnc" && a.dialect != "grbl")
    throw InputError("--dialect", 0, fmt::format("'{}': linuxcnc or grbl", excerpt(a.dialect)));
  p.dialect = a.dialect == "grbl" ? GcodeDialect::grbl : GcodeDialect::linuxcnc;
  if (p.sheet.material > 0 && cmd->count("--feed") == 0) p.sheet.feed_mm_per_min = kMaterialCutFeed;
  if (p.dialect == GcodeDialect::grbl && p.sheet.material > 0) throw InputError("--material", 0, "GRBL has no M190: drop it or write linuxcnc");
  if (p.dialect == GcodeDialect::grbl && p.sheet.hole_mode > 0)
    throw InputError("--holes", 0, "GRBL has no named parameters for QtPlasmaC's hole rules: drop it or write linuxcnc");
  if (!p.materials.empty() && p.machine.empty()) throw InputError("--materials", 0, "the material file is read with --machine");
  p.sheet.validate();
  return p;
}

// The flags a job file's `program:` section may set (its keys: the flags' names without the
// dashes), and the options field each one sets (for an error to name its line).
constexpr std::pair<const char*, const char*> kProgramKeys[] = {
    {"feed", "feed_mm_per_min"},  {"lead-in", "lead_in.length_mm"}, {"lead-in-shape", ""}, {"lead-out", "lead_out.length_mm"},
    {"lead-out-shape", ""},       {"overcut", "overcut_mm"},        {"clearance", "clearance_mm"}, {"kerf", "kerf_mm"},
    {"kerf-by", ""},              {"part-side", ""},                {"material", "material"},     {"holes", "hole_mode"},
    {"hole-diameter", "hole_diameter_mm"}, {"hole-velocity", "hole_velocity_pct"}, {"hole-overcut", "hole_overcut_mm"},
    {"dialect", ""}};

// A job file's `program:` section, read as if its values were given to the flags: each key sets
// its flag unless the command line gave that flag. A bad value is refused at its line.
void read_program_section(const Yaml& section, NestArgs& a, CLI::App* cmd) {
  std::vector<const char*> keys;
  for (const auto& [key, field] : kProgramKeys) keys.push_back(key);
  section.reject_unknown_keys(keys);
  std::vector<std::pair<const char*, const char*>> set;  // the keys that set their flag
  for (const auto& [key, field] : kProgramKeys) {
    CLI::Option* opt = cmd->get_option(std::string("--") + key);
    if (!section.has(key) || opt->count() > 0) continue;
    set.emplace_back(key, field);
    const Yaml value = section.at(key);
    try {
      opt->add_result(value.string());
      opt->run_callback();
    } catch (const CLI::ParseError&) {
      value.fail(fmt::format("'{}' is not a value --{} takes", excerpt(value.string()), key));
    }
  }
  try {
    (void)program_args(a, cmd);
  } catch (const InputError& e) {
    for (const auto& [key, field] : set)
      if (e.where() == std::string("--") + key || (e.is_field() && e.where() == field)) section.at(key).fail(e.message());
    throw;
  }
}

// The request's spacing: --spacing, else the job file's spacing_mm, else the kerf (--kerf, or the
// job's program: kerf) plus the clearance, so that neighbouring parts' torch paths keep the
// clearance the leads keep; with no kerf given, 6 mm. A spacing longer than every sheet's longer
// side holds no two parts on one sheet: a mistake (mm for cm, a kerf in the wrong field), refused
// (at its line when the job file gave it) rather than nested one part a sheet.
void set_spacing(nesting::NestRequest& r, const NestArgs& a, const CLI::App* cmd, const Yaml* job) {
  const bool flag = cmd->count("--spacing") > 0, from_job = !flag && job && job->has("spacing_mm");
  if (flag) {
    if (!(a.spacing >= 0 && a.spacing <= 1000)) throw InputError("--spacing", 0, fmt::format("{} must be in [0, 1000] mm", a.spacing));
    r.spacing_mm = a.spacing;
  } else if (!from_job) {
    const nesting::SheetProgramOptions& o = a.program.sheet;
    r.spacing_mm = o.kerf_mm > 0 ? o.kerf_mm + o.clearance_mm : a.spacing;
  }
  double longest = 0.0;
  for (const nesting::Sheet& s : r.sheets) longest = std::max({longest, s.width_mm, s.height_mm});
  if (r.spacing_mm <= longest) return;
  const std::string problem =
      fmt::format("a spacing of {:g} mm is longer than every sheet (the longest side is {:g} mm)", r.spacing_mm, longest);
  if (from_job) job->at("spacing_mm").fail(problem);
  throw InputError("--spacing", 0, problem);
}

// The request from a job file, or from the drawings and the flags.
nesting::NestRequest request_of(NestArgs& a, CLI::App* cmd) {
  const bool job = a.parts.size() == 1 && (a.parts[0].ends_with(".yaml") || a.parts[0].ends_with(".yml"));
  if (job) {
    if (!a.sheet.empty()) throw InputError("--sheet", 0, "the job file lists the sheets");
    constexpr std::pair<const char*, const char*> kJobGives[] = {
        {"--margin", "each sheet's margin_mm"}, {"--rotations", "each part's rotations"}, {"--split", "each part's split"}};
    for (const auto& [flag, key] : kJobGives)
      if (cmd->count(flag) > 0) throw InputError(flag, 0, fmt::format("the job file gives {}", key));
    const Yaml root = Yaml::load_file(a.parts[0]);
    nesting::NestRequest r = nesting::read_nest_job(root, std::filesystem::path(a.parts[0]).parent_path().string());
    if (root.has("program")) read_program_section(root.at("program"), a, cmd);
    set_spacing(r, a, cmd, &root);
    return r;
  }
  if (a.sheet.empty()) throw InputError("--sheet", 0, "give the sheets (WIDTHxHEIGHT[:COUNT]), or a job file");
  if (!(a.margin >= 0 && a.margin <= 1000)) throw InputError("--margin", 0, fmt::format("{} must be in [0, 1000] mm", a.margin));
  nesting::NestRequest r;
  r.sheets = sheet_spec(a.sheet, a.margin);
  set_spacing(r, a, cmd, nullptr);
  r.rotations_deg = nesting::rotations_from_text(a.rotations, "--rotations");
  r.any_rotation = a.rotations == "any";
  for (const std::string& s : a.parts) {
    const auto [file, qty] = part_spec(s);
    for (nesting::NestPart& p : nesting::read_nest_parts(file, a.split)) {
      r.parts.push_back(std::move(p));
      r.quantity.push_back(qty);
    }
  }
  return r;
}

void add_nest(CLI::App& app) {
  auto a = std::make_shared<NestArgs>();
  auto* cmd = app.add_subcommand("nest", "Nest parts from DXF drawings on sheets (bottom-left fill, then the strip search; certified)");
  cmd->add_option("parts", a->parts, "a job file JOB.yaml, or DXF drawings, each FILE or FILE:QUANTITY")->required();
  cmd->add_option("--sheet", a->sheet, "the sheets: WIDTHxHEIGHT[:COUNT] in mm, x along the width (no job file)");
  cmd->add_option("--spacing", a->spacing, "least distance between parts, mm (default: the job file's spacing_mm, else --kerf plus --clearance, else 6)")
      ->capture_default_str();
  cmd->add_option("--margin", a->margin, "kept clear along every sheet edge, mm")->capture_default_str();
  cmd->add_option("--rotations", a->rotations, "any (any angle), none, or degrees separated by commas")->capture_default_str();
  cmd->add_option("--time", a->time, "search time, s of nominal work (about the wall clock on 2 cores): the same nest on any machine; 0: one fill")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "seed of the search's restarts")->capture_default_str();
  cmd->add_option("--out", a->out, "write each sheet's cut program here, as sheet_K.ngc (the folder is made)");
  cmd->add_option("--machine", a->program.machine, "with --out: the machine the programs are planned on for their cycle time (a name or a file)");
  cmd->add_option("--materials", a->program.materials, "with --machine: the material file (QtPlasmaC's) the planner reads for --material");
  nesting::SheetProgramOptions& po = a->program.sheet;
  cmd->add_option("--feed", po.feed_mm_per_min, "the cuts' feed in the programs, mm/min (with --material, default: the material's feed)")
      ->capture_default_str();
  cmd->add_option("--lead-in", po.lead_in.length_mm, "how far from the contour the torch pierces, mm (the lead-in's radius or length)")
      ->capture_default_str();
  cmd->add_option("--lead-in-shape", a->lead_in_shape, "arc (a quarter circle, tangent) or line (square to the contour)")->capture_default_str();
  cmd->add_option("--lead-out", po.lead_out.length_mm, "length (line) or radius (arc) of the lead-out into the waste, mm")->capture_default_str();
  cmd->add_option("--lead-out-shape", a->lead_out_shape, "arc or line")->capture_default_str();
  cmd->add_option("--overcut", po.overcut_mm, "cut this far past the start again before leaving the contour, mm")->capture_default_str();
  cmd->add_option("--clearance", po.clearance_mm, "least distance of a lead from any other cut, mm (else the lead is shortened)")
      ->capture_default_str();
  cmd->add_option("--kerf", po.kerf_mm, "kerf width, mm (0: unknown, not compensated)")->capture_default_str();
  cmd->add_option("--kerf-by", a->kerf_by, "program: compensated in the program; controller: written in a comment for run --kerf")
      ->capture_default_str();
  cmd->add_option("--part-side", a->part_side, "right: outlines clockwise, holes counter-clockwise (a clockwise-swirl torch); left")
      ->capture_default_str();
  cmd->add_option("--material", po.material, "QtPlasmaC material number: M190 P N and its wait at the top (0: none)")->capture_default_str();
  cmd->add_option("--holes", po.hole_mode, "QtPlasmaC hole rules #<holes> 0-4 (1 slow small holes, 2 also over cut them; 3, 4 arcs too)")
      ->capture_default_str();
  cmd->add_option("--hole-diameter", po.hole_diameter_mm, "with --holes: holes up to this diameter are small, mm")->capture_default_str();
  cmd->add_option("--hole-velocity", po.hole_velocity_pct, "with --holes: their speed, % of the feed")->capture_default_str();
  cmd->add_option("--hole-overcut", po.hole_overcut_mm, "with --holes 2 or 4: the over cut with the torch off, mm")->capture_default_str();
  cmd->add_option("--dialect", a->dialect, "the programs' G-code: linuxcnc (QtPlasmaC) or grbl")->capture_default_str();
  cmd->add_flag("--split", a->split, "a drawing with several outer contours is one part per contour (else refused)");
  cmd->add_flag("--json", a->json, "print JSON instead of the readable report");
  cmd->callback([a, cmd] {
    nesting::NestRequest r = request_of(*a, cmd);
    const ProgramArgs programs_with = program_args(*a, cmd);  // bad program flags refused before the search
    if (!(a->time >= 0 && a->time <= 86400)) throw InputError("--time", 0, fmt::format("{} must be in [0, 86400] s", a->time));
    Termination t(StopOnSignals::stop_token());
    if (a->time > 0) t.set_deadline(a->time, "nominal search time");
    else t.set_budget(1, "fills");
    nesting::StripSearchStats search;
    nesting::NestProgress progress;
    nesting::NestResult n;
    {
      const ProgressWatch bar("nest", !a->json, progress.share, [&progress] {
        const double mm = progress.last_length_mm.load();
        return mm > 0 ? fmt::format("{} sheet(s), the last used to {:.1f} mm", progress.sheets.load(), mm) : std::string();
      });
      n = nesting::nest(r, t, a->seed, 2, &search, &progress);
    }
    const nesting::Certificate cert = nesting::certify(r.parts, n.placements, r.sheets, r.spacing_mm);
    json j = nest_json(r, n, search, cert, t);
    if (!a->out.empty()) {
      const json programs = write_programs(r, n, a->out, programs_with);
      for (std::size_t k = 0; k < programs.size(); ++k) j["sheets"][k].update(programs[k]);  // both per sheet used, in order
    }
    if (a->json) print_json(j);
    else print_nest_report(j);
    if (!n.unplaced.empty() || !cert.certified) set_exit_code(3);
  });
  field_flags(cmd, {{"feed_mm_per_min", "--feed"}, {"lead_in.length_mm", "--lead-in"}, {"lead_out.length_mm", "--lead-out"},
                    {"overcut_mm", "--overcut"}, {"kerf_mm", "--kerf"}, {"clearance_mm", "--clearance"}, {"material", "--material"},
                    {"hole_mode", "--holes"}, {"hole_diameter_mm", "--hole-diameter"}, {"hole_velocity_pct", "--hole-velocity"},
                    {"hole_overcut_mm", "--hole-overcut"}});
}

const Registration reg_nest(16, add_nest);

}  // namespace
}  // namespace machplan::cli
