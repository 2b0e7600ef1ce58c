// `machplan order PROGRAM [--order optimise|nearest|program] [--output FILE] [--json] ...`:
// reorders a part program's cuts (solvers/motion/cut_order.h: inner contours before the
// contour that holds them, pierce points chosen, the travel between cuts minimised) and writes
// the program as G-code (engine/programs/gcode_writer.h) that LinuxCNC's rs274 reads to the
// same cuts. The G-code goes to --output, or to stdout (the report then goes to stderr).
// Exit 3 when the program cannot be reordered (the report says why; nothing is written).
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.h"
#include "cli/gcode_flags.h"
#include "cli/json/cut_order_json.h"
#include "cli/output.h"
#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/programs/gcode.h"
#include "engine/programs/gcode_writer.h"
#include "solvers/motion/cut_order.h"

namespace machplan::cli {
namespace {

void add_order(CLI::App& app) {
  struct Args {
    std::string program, output, order = "optimise";
    bool json = false;
    int entries = motion::CutOrderOptions{}.entry_candidates;
    double clearance = motion::CutOrderOptions{}.edge_clearance_mm;
    GcodeFlags gcode;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("order", "Reorder a part program's cuts (inner contours first, least travel)");
  cmd->add_option("program", a->program, "G-code part program")->required();
  cmd->add_option("--order", a->order,
                  "optimise (default: inner contours first, pierce points chosen, least travel), nearest (nearest "
                  "neighbour, pierce points as programmed) or program (as written)");
  cmd->add_option("--output,-o", a->output, "write the reordered program here (default: stdout)");
  cmd->add_flag("--json", a->json, "the report as JSON on stdout (needs --output for the program)");
  cmd->add_option("--entries", a->entries, "pierce points tried on each closed cut with a lead-in (0 .. 64, default 12)")
      ->check(CLI::Range(0, 64));
  cmd->add_option("--edge-clearance", a->clearance,
                  "how far a moved pierce point and its lead-in keep from every other cut, mm (default 2)")
      ->check(kFinitePositive);
  add_gcode_options(*cmd, a->gcode);
  cmd->callback([a] {
    motion::CutOrderOptions o;
    const std::optional<motion::CutOrder> order = motion::cut_order_from(a->order);
    if (!order)
      throw InputError("--order", 0, fmt::format("'{}' is not an order (optimise, nearest, program)", a->order));
    o.order = *order;
    o.entry_candidates = a->entries;
    o.edge_clearance_mm = a->clearance;
    if (a->json && a->output.empty())
      throw InputError("--json", 0, "the report goes to stdout: give --output FILE for the program");
    if (!a->output.empty()) {
      refuse_overwriting_input("--output", a->output, {a->program});
      check_output_folder("--output", a->output);
    }
    const Program program = read_gcode_file(a->program, gcode_options(a->gcode));
    const motion::OrderedProgram ordered = motion::order_cuts(program, o);
    const motion::CutOrderReport& r = ordered.report;
    FILE* report = a->output.empty() ? stderr : stdout;
    for (const std::string& w : program.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (r.summary.done()) {
      const std::string text = write_gcode(
          ordered.program, fmt::format("{}: cuts in {} order, written by machplan order\n{}", program.source,
                                       motion::to_string(r.order), r.summary.brief_report()));
      if (a->output.empty()) {
        std::fputs(text.c_str(), stdout);
      } else {
        // The old program stays byte for byte unless the new one is written whole.
        write_file_atomically(a->output, text);
      }
    }
    if (a->json) print_json(cut_order_json(r));
    else std::fputs(r.summary.full_report().c_str(), report);
    set_exit_code(r.summary.exit_code());
  });
}

const Registration reg_order(15, add_order);

}  // namespace
}  // namespace machplan::cli
