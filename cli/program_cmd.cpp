// `machplan program FILE.ngc [--json] [--param NAME=VALUE]... [--spindles N] [--lenient]`:
// interprets a G-code part program and prints its moves (--json, machine coordinates: the
// program's work offsets applied) or a readable summary. Warnings go to stderr.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/field_flags.h"
#include "cli/gcode_flags.h"
#include "cli/output.h"
#include "engine/programs/gcode.h"

namespace {

using machplan::cli::add_gcode_options;
using machplan::cli::gcode_options;

nlohmann::json move_json(const machplan::Move& m) {
  using machplan::Move;
  nlohmann::json j;
  j["kind"] = machplan::to_string(m.kind);
  j["line"] = m.line;
  switch (m.kind) {
    case Move::Kind::rapid:
      j["end"] = {m.end.x(), m.end.y(), m.end.z()};
      break;
    case Move::Kind::line:
      j["end"] = {m.end.x(), m.end.y(), m.end.z()};
      j["feed"] = m.feed_mm_per_min;
      break;
    case Move::Kind::arc:
      j["end"] = {m.end.x(), m.end.y(), m.end.z()};
      j["feed"] = m.feed_mm_per_min;
      j["center"] = {m.center.x(), m.center.y()};
      if (m.plane != Move::Plane::xy) j["plane"] = m.plane == Move::Plane::xz ? "xz" : "yz";
      j["clockwise"] = m.clockwise;
      j["turns"] = m.turns;
      break;
    case Move::Kind::dwell:
      j["seconds"] = m.seconds;
      break;
    case Move::Kind::torch_on:
      j["spindle_speed"] = m.spindle_speed;
      if (m.spindle != 0) j["spindle"] = m.spindle;
      break;
    case Move::Kind::torch_off:
      if (m.spindle != 0) j["spindle"] = m.spindle;
      break;
  }
  if (m.kind == Move::Kind::rapid || m.kind == Move::Kind::line || m.kind == Move::Kind::arc) {
    if (m.path_mode != Move::PathMode::blend) j["path_mode"] = machplan::to_string(m.path_mode);
    else if (m.path_tolerance_mm > 0) j["path_tolerance_mm"] = m.path_tolerance_mm;
  }
  return j;
}

// The program as one JSON object, streamed: the moves and events are written one at a time
// (a long program's document would take about 0.9 KB of memory per move). A failed write
// stops the writing; main() reports it.
void write_json(const machplan::Program& program) {
  machplan::cli::JsonStream out(stdout);
  out.begin_object();
  out.member("units", "mm");
  out.member("coordinates", "machine (work offsets applied)");
  out.member("source", program.source);
  out.member("dialect", machplan::to_string(program.dialect));
  out.member("warnings", program.warnings);
  out.member("start", {program.start.x(), program.start.y(), program.start.z()});
  out.member("ends_with_program_end", program.ends_with_program_end);
  out.key("events");
  out.begin_array();
  for (const machplan::ProgramEvent& e : program.events) {
    if (out.failed()) break;
    nlohmann::json j = {{"kind", machplan::to_string(e.kind)}, {"line", e.line}, {"before_move", e.before_move},
                        {"number", e.number}, {"value", e.value}, {"value2", e.value2}, {"mode", e.mode},
                        {"synchronized", e.synchronized}};
    if (!e.text.empty()) j["text"] = e.text;
    out.value(j);
  }
  out.end_array();
  out.key("moves");
  out.begin_array();
  for (const machplan::Move& m : program.moves) {
    if (out.failed()) break;
    out.value(move_json(m));
  }
  out.end_array();
  out.end_object();
  machplan::cli::finish_json(out);
}

void print_summary(const machplan::Program& program, double rapid_mm_per_min) {
  const auto s = machplan::summarize(program, rapid_mm_per_min);
  // Whole minutes as a double: a long program's time does not fit an int.
  const double minutes = std::floor(s.estimated_seconds / 60.0);
  std::cout << fmt::format(
      "program {}\n"
      "  moves:          {} total: {} rapid, {} line, {} arc, {} dwell, {} torch on\n"
      "  rapid length:   {:.1f} mm\n"
      "  feed length:    {:.1f} mm\n"
      "  bounding box:   X {:.3f} .. {:.3f}  Y {:.3f} .. {:.3f}  Z {:.3f} .. {:.3f} mm\n"
      "  estimated time: {:.1f} s ({:.0f}:{:04.1f} min; rapids at {:g} mm/min, feeds at F, dwells)\n"
      "  other words:    {} kept (tool, coolant, outputs, waits, user M codes)\n",
      program.source, program.moves.size(), s.rapid_count, s.line_count, s.arc_count, s.dwell_count,
      s.torch_on_count, s.rapid_length_mm, s.feed_length_mm, s.min.x(), s.max.x(), s.min.y(), s.max.y(),
      s.min.z(), s.max.z(), s.estimated_seconds, minutes, s.estimated_seconds - 60.0 * minutes, rapid_mm_per_min,
      program.events.size());
}

void add_program(CLI::App& app) {
  struct Args {
    std::string file;
    bool json = false;
    double rapid_mm_per_min = 5000.0;
    machplan::cli::GcodeFlags gcode;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("program", "Interpret a G-code part program (as LinuxCNC or GRBL reads it)");
  cmd->add_option("file", args->file, "G-code file (.ngc)")->required();
  cmd->add_flag("--json", args->json, "Print the canonical moves as JSON (mm, absolute)");
  cmd->add_option("--rapid-mm-per-min", args->rapid_mm_per_min, "Rapid rate for the time estimate")
      ->check(machplan::cli::kFinitePositive);
  add_gcode_options(*cmd, args->gcode);
  machplan::cli::field_flags(cmd, {{"spindle_count", "--spindles"}});
  cmd->callback([args] {
    const machplan::Program program =
        machplan::read_gcode_file(args->file, gcode_options(args->gcode));
    for (const std::string& w : program.warnings) std::cerr << "warning: " << w << "\n";
    if (args->json) write_json(program);
    else print_summary(program, args->rapid_mm_per_min);
  });
}

const machplan::cli::Registration reg_program(10, add_program);

}  // namespace
