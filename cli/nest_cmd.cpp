// `machplan nest PART.dxf[:QTY]... --sheet WxH[:COUNT] [--spacing MM] [--margin MM]
// [--rotations any|none|DEG,DEG,...] [--split] [--json]`: parts from drawings nested on
// sheets by bottom-left fill (solvers/nesting/bottom_left.h), the nest certified on the true
// geometry (solvers/nesting/certificate.h). The report gives per sheet the parts, the used
// length from the left edge, the utilisation of the area used and the remnant; `--json` gives
// every placed copy's transform: a point (x, y) of the drawing lands on the sheet at
// translate + R(rotation) * (x, y). Exit 3 when a copy fits on no sheet (each is named with
// the reason; the rest is still nested) or the certificate fails.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
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
                      {"utilisation", area[k] / (used * sh.height_mm)},
                      {"remnant_mm", {sh.width_mm - used, sh.height_mm}}});
  }
  for (const nesting::Unplaced& u : n.unplaced)
    unplaced.push_back({{"file", r.parts[u.part].file}, {"copy", u.copy + 1}, {"reason", u.reason}});
  return {{"units", "mm"},       {"spacing_mm", r.spacing_mm}, {"fills", n.fills},
          {"search_s", t.work_s_spent()}, {"search_ended", t.describe()},
          {"strip_search", {{"start_length_mm", search.start_length_mm}, {"shrinks_tried", search.shrinks_tried},
                            {"shrinks_kept", search.shrinks_kept}, {"moves", search.moves},
                            {"collision_tests", search.tests}, {"deep_pairs", search.deep_pairs}, {"pole_pairs", search.pole_pairs},
                            {"note", search.note}}},
          {"certified", cert.certified}, {"violations", cert.violations}, {"sheets", sheets},
          {"placements", placements},    {"unplaced", unplaced}};
}

// Each sheet's cut program, its cuts ordered as `machplan order` orders them, written to
// DIR/sheet_K.ngc; per sheet used, its path, cut length, pierces and rapid length, and with a
// machine the cycle `machplan run` plans for it there.
json write_programs(const nesting::NestRequest& r, const nesting::NestResult& n, const std::string& dir,
                    const nesting::SheetProgramOptions& o, const std::string& machine) {
  std::optional<cutting::MachineConfig> m;
  if (!machine.empty()) m = cutting::load_machine(cutting::find_machine(machine));
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw OutputError(dir, ec.message());
  json out = json::array();
  for (int k = 0; k < static_cast<int>(r.sheets.size()); ++k) {
    if (n.used_length_mm[static_cast<std::size_t>(k)] <= 0.0) continue;
    const Program p = nesting::sheet_program(r.parts, n.placements, k, o);
    const motion::OrderedProgram ordered = motion::order_cuts(p, {});
    const nesting::Sheet& sh = r.sheets[static_cast<std::size_t>(k)];
    std::string header = fmt::format("sheet {} of {}, {:.0f} x {:.0f} mm, nested by machplan nest; spacing {:g} mm\n", k + 1,
                                     r.sheets.size(), sh.width_mm, sh.height_mm, r.spacing_mm);
    for (const nesting::Placement& pl : n.placements)
      if (pl.sheet == k)
        header += fmt::format("{} copy {}: at X {:.3f} Y {:.3f}, turned {:g} deg\n", std::filesystem::path(r.parts[pl.part].file).filename().string(),
                              pl.copy + 1, pl.translate_mm.x(), pl.translate_mm.y(), pl.rotation_deg);
    header += "kerf not compensated here: machplan run --kerf WIDTH compensates it\n";
    header += ordered.report.summary.done() ? ordered.report.summary.brief_report() : "cuts in the nest's order: " + ordered.report.summary.message;
    const std::string path = (std::filesystem::path(dir) / fmt::format("sheet_{}.ngc", k + 1)).string();
    const Program& written = ordered.report.summary.done() ? ordered.program : p;
    write_file_atomically(path, write_gcode(written, header));
    const ProgramSummary sum = summarize(written);
    const std::string picture = (std::filesystem::path(dir) / fmt::format("sheet_{}.png", k + 1)).string();
    nesting::plot_sheet(picture, r.parts, n.placements, k, sh, written,
                        fmt::format("sheet {}: {:.0f} x {:.0f} mm, used length {:.1f} mm; {} pierces in cut order, rapids dashed", k + 1,
                                    sh.width_mm, sh.height_mm, n.used_length_mm[static_cast<std::size_t>(k)], sum.torch_on_count));
    json sheet = {{"program", path}, {"picture", picture}, {"cut_length_mm", sum.feed_length_mm},
                  {"pierces", sum.torch_on_count}, {"rapid_mm", sum.rapid_length_mm}};
    if (m) {
      motion::RunOptions ro;
      ro.session.machine_config = *m;
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
    std::printf("  sheet %d: %d parts, used length %.1f mm of %.0f, utilisation %.1f %% of the area used, remnant %.1f x %.1f mm\n",
                s["sheet"].get<int>(), s["parts"].get<int>(), s["used_length_mm"].get<double>(), s["width_mm"].get<double>(),
                100.0 * s["utilisation"].get<double>(), s["remnant_mm"][0].get<double>(), s["remnant_mm"][1].get<double>());
    if (s.contains("program"))
      std::printf("    program: %s: cut length %.0f mm, %d pierces, rapids %.0f mm%s\n", s["program"].get<std::string>().c_str(),
                  s["cut_length_mm"].get<double>(), s["pierces"].get<int>(), s["rapid_mm"].get<double>(),
                  s.contains("cycle_s") ? fmt::format(", cycle {:.1f} s planned", s["cycle_s"].get<double>()).c_str() : "");
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
  std::string sheet, rotations = "any", out, machine;
  double feed = 2000.0, lead_in = 5.0;
  double spacing = 6.0, margin = 10.0, time = 2.0;
  std::uint64_t seed = 1;
  bool split = false, json = false;
};

// The request from a job file, or from the drawings and the flags.
nesting::NestRequest request_of(const NestArgs& a) {
  const bool job = a.parts.size() == 1 && (a.parts[0].ends_with(".yaml") || a.parts[0].ends_with(".yml"));
  if (job) {
    if (!a.sheet.empty()) throw InputError("--sheet", 0, "the job file lists the sheets");
    return nesting::read_nest_job(a.parts[0]);
  }
  if (a.sheet.empty()) throw InputError("--sheet", 0, "give the sheets (WIDTHxHEIGHT[:COUNT]), or a job file");
  if (!(a.margin >= 0 && a.margin <= 1000)) throw InputError("--margin", 0, fmt::format("{} must be in [0, 1000] mm", a.margin));
  if (!(a.spacing >= 0 && a.spacing <= 1000)) throw InputError("--spacing", 0, fmt::format("{} must be in [0, 1000] mm", a.spacing));
  nesting::NestRequest r;
  r.sheets = sheet_spec(a.sheet, a.margin);
  r.spacing_mm = a.spacing;
  r.rotations_deg = nesting::rotations_from_text(a.rotations, "--rotations");
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
  cmd->add_option("--spacing", a->spacing, "least distance between parts, mm (the kerf plus a clearance)")->capture_default_str();
  cmd->add_option("--margin", a->margin, "kept clear along every sheet edge, mm")->capture_default_str();
  cmd->add_option("--rotations", a->rotations, "any (every 45 deg), none, or degrees separated by commas")->capture_default_str();
  cmd->add_option("--time", a->time, "search time, s of nominal work (about the wall clock on 2 cores): the same nest on any machine; 0: one fill")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "seed of the search's restarts")->capture_default_str();
  cmd->add_option("--out", a->out, "write each sheet's cut program here, as sheet_K.ngc (the folder is made)");
  cmd->add_option("--machine", a->machine, "with --out: the machine the programs are planned on for their cycle time (a name or a file)");
  cmd->add_option("--feed", a->feed, "the cuts' feed in the programs, mm/min")->capture_default_str();
  cmd->add_option("--lead-in", a->lead_in, "length of the straight lead-in from the waste side, mm")->capture_default_str();
  cmd->add_flag("--split", a->split, "a drawing with several outer contours is one part per contour (else refused)");
  cmd->add_flag("--json", a->json, "print JSON instead of the readable report");
  cmd->callback([a] {
    nesting::NestRequest r = request_of(*a);
    if (!(a->time >= 0 && a->time <= 86400)) throw InputError("--time", 0, fmt::format("{} must be in [0, 86400] s", a->time));
    Termination t(StopOnSignals::stop_token());
    if (a->time > 0) t.set_deadline(a->time, "nominal search time");
    else t.set_budget(1, "fills");
    nesting::StripSearchStats search;
    const nesting::NestResult n = nesting::nest(r, t, a->seed, 2, &search);
    const nesting::Certificate cert = nesting::certify(r.parts, n.placements, r.sheets, r.spacing_mm);
    json j = nest_json(r, n, search, cert, t);
    if (!a->out.empty()) {
      if (!(a->feed > 0 && a->feed <= 100000)) throw InputError("--feed", 0, fmt::format("{} must be in (0, 100000] mm/min", a->feed));
      if (!(a->lead_in >= 0 && a->lead_in <= 100)) throw InputError("--lead-in", 0, fmt::format("{} must be in [0, 100] mm", a->lead_in));
      const json programs = write_programs(r, n, a->out, {a->feed, a->lead_in}, a->machine);
      for (std::size_t k = 0; k < programs.size(); ++k) j["sheets"][k].update(programs[k]);  // both per sheet used, in order
    }
    if (a->json) print_json(j);
    else print_nest_report(j);
    if (!n.unplaced.empty() || !cert.certified) set_exit_code(3);
  });
}

const Registration reg_nest(16, add_nest);

}  // namespace
}  // namespace machplan::cli
