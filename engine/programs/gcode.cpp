// RS274NGC reader: read_gcode() and its dialects, the program loop and the parameters. The
// reader's parts and how they follow LinuxCNC's interpreter are listed in
// engine/programs/internal/gcode_interp.h.
#include "engine/programs/gcode.h"

#include <algorithm>
#include <cctype>
#include <optional>
#include <string>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/programs/internal/gcode_interp.h"

namespace machplan {
namespace gcode_interp {

double Reader::numbered(int n) const {
  if (n < 1 || n > 5602) throw gcode_expr::SyntaxError(fmt::format("parameter number #{} out of range (1..5602)", n));
  if (n >= 5420 && n <= 5428) return n - 5420 < 3 ? pos_mm_[n - 5420] / scale() : 0.0;
  if (n == 5400) return tool_in_spindle_;
  if (is_length_param(n)) return params_[static_cast<std::size_t>(n)] / scale();
  return params_[static_cast<std::size_t>(n)];
}

bool Reader::exists(const std::string& name) const {
  if (!name.empty() && name[0] == '_') return globals_.count(name) || given_.count(name);
  return frames_.back().locals.count(name) > 0;
}

double Reader::named(const std::string& name) const {
  if (!name.empty() && name[0] == '_') {
    if (auto it = globals_.find(name); it != globals_.end()) return it->second;
    if (auto it = given_.find(name); it != given_.end()) return it->second;
    if (name == "_x" || name == "_y" || name == "_z") return pos_mm_[name[1] - 'x'] / scale();
    if (name == "_metric") return inches_ ? 0.0 : 1.0;
    if (name == "_imperial") return inches_ ? 1.0 : 0.0;
    if (name == "_absolute") return incremental_ ? 0.0 : 1.0;
    if (name == "_incremental") return incremental_ ? 1.0 : 0.0;
    if (name == "_feed") return feed_mm_per_min_ / scale();
    if (name == "_rpm") return spindle_speed_;
    if (name == "_current_tool") return tool_in_spindle_;
    if (name == "_selected_tool") return tool_selected_;
    if (name == "_call_level") return static_cast<double>(frames_.size() - 1);
    if (name == "_line") return line_;
    if (name == "_value" || name == "_value_returned") return 0.0;
    if (name.rfind("_hal[", 0) == 0 || name.rfind("_ini[", 0) == 0)
      throw gcode_expr::SyntaxError(fmt::format(
          "parameter #<{}> has no value: LinuxCNC reads it from the machine's {}; give it a value "
          "(GcodeOptions::params)",
          excerpt(name), name[1] == 'h' ? "HAL pins" : "INI file"));
    throw gcode_expr::SyntaxError(fmt::format("named parameter #<{}> not defined", excerpt(name)));
  }
  if (auto it = frames_.back().locals.find(name); it != frames_.back().locals.end()) return it->second;
  throw gcode_expr::SyntaxError(fmt::format("named parameter #<{}> not defined", excerpt(name)));
}

void Reader::set_parameters(const Block& b) {
  for (const auto& [n, v] : b.set_numbered) {
    params_[static_cast<std::size_t>(n)] = is_length_param(n) ? v * scale() : v;
  }
  for (const auto& [name, v] : b.set_named) {
    if (name[0] == '_') globals_[name] = v;
    else frames_.back().locals[name] = v;
    const auto& reported = options_.reported_params;
    if (std::find(reported.begin(), reported.end(), name) != reported.end()) {
      ProgramEvent e;
      e.kind = ProgramEvent::Kind::parameter;
      e.text = name;
      e.value = v;
      e.mode = inches_ ? 20 : 21;
      event(e);
    }
  }
}

void Reader::system_command(const SourceLine& l) {
  ProgramEvent e;
  e.kind = ProgramEvent::Kind::controller_command;
  e.text = l.text.substr(0, 80);
  event(e);
  if (system_commands_++ == 0) first_system_line_ = l.number;
}

Program Reader::run(const std::string& text) {
  options_.validate();
  const bool closing_percent = read_lines(text);
  match_structure();

  int pc = 0;
  while (pc < static_cast<int>(lines_.size())) {
    const SourceLine& l = lines_[static_cast<std::size_t>(pc)];
    line_ = l.number;
    if (++executed_ > options_.max_executed_lines)
      fail(fmt::format("more than {} lines executed: an endless loop?", options_.max_executed_lines));
    if (!l.error.empty()) fail(l.error);
    if (l.system_command) {
      system_command(l);
      ++pc;
      continue;
    }
    if (l.o != OKind::none) {
      pc = control(pc);
      continue;
    }
    if (!l.magic.empty()) {
      ProgramEvent e;
      e.kind = ProgramEvent::Kind::magic_comment;
      e.text = l.magic;
      e.mode = inches_ ? 20 : 21;
      event(e);
    }
    const Block b = split(l.code);
    set_parameters(b);
    if (!execute(b)) {
      ended_ = true;
      program_.ends_with_program_end = true;
      break;
    }
    ++pc;
  }
  if (!ended_ && closing_percent) ended_ = true;
  if (!ended_ && frames_.size() > 1) fail("file ended inside a subroutine call");
  const bool grbl = program_.dialect == GcodeDialect::grbl;
  if (system_commands_ > 0)
    program_.warnings.push_back(fmt::format("{}:{}: {} GRBL system command line{} ($...) kept as events and otherwise "
                                            "ignored",
                                            program_.source, first_system_line_, system_commands_,
                                            system_commands_ == 1 ? "" : "s"));
  if (realtime_lines_ > 0)
    program_.warnings.push_back(fmt::format("{}:{}: {} GRBL real-time command line{} (?, ~, !) skipped, as a GRBL "
                                            "sender skips them",
                                            program_.source, first_realtime_line_, realtime_lines_,
                                            realtime_lines_ == 1 ? "" : "s"));
  if (!ended_ && !grbl) {
    if (options_.require_program_end) fail("file ended with no percent sign or program end (M2 or M30)");
    program_.warnings.push_back(fmt::format(
        "{}: the program has no end (M2, M30 or a closing %): read to the end of the file", program_.source));
  }
  return std::move(program_);
}

}  // namespace gcode_interp

namespace {

using gcode_interp::Reader;

Program read_as(const std::string& text, const std::string& source_name, const GcodeOptions& options, bool& ended) {
  Reader reader(source_name, options);
  Program p = reader.run(text);
  ended = reader.ended();
  return p;
}

}  // namespace

std::optional<GcodeDialect> gcode_dialect_from(std::string_view name) {
  if (name == "linuxcnc") return GcodeDialect::linuxcnc;
  if (name == "grbl") return GcodeDialect::grbl;
  if (name == "auto") return GcodeDialect::automatic;
  return std::nullopt;
}

void GcodeOptions::validate() const {
  if (max_line_chars < 1 || max_line_chars > (1u << 20))
    throw InputError::field("max_line_chars", fmt::format("{} must be in 1..{}", max_line_chars, 1u << 20));
  if (max_moves < 1) throw InputError::field("max_moves", "0 must be at least 1");
  if (max_arc_turns < 1 || max_arc_turns > 1'000'000)
    throw InputError::field("max_arc_turns", fmt::format("{} must be in 1..1000000", max_arc_turns));
  if (spindle_count < 1 || spindle_count > 100)
    throw InputError::field("spindle_count", fmt::format("{} must be in 1..100", spindle_count));
  if (max_executed_lines < 1) throw InputError::field("max_executed_lines", "0 must be at least 1");
}

Program read_gcode(const std::string& text, const std::string& source_name, const GcodeOptions& options) {
  bool ended = false;
  if (options.dialect != GcodeDialect::automatic) return read_as(text, source_name, options, ended);
  GcodeOptions o = options;
  o.dialect = GcodeDialect::grbl;
  if (const gcode_interp::GrblSign sign = gcode_interp::grbl_sign(text); sign.line > 0) {
    Program p = read_as(text, source_name, o, ended);
    p.warnings.insert(p.warnings.begin(),
                      fmt::format("{}:{}: read as a GRBL program (auto-detected: {}; the linuxcnc dialect reads it "
                                  "as LinuxCNC does)",
                                  source_name, sign.line, sign.what));
    return p;
  }
  o.dialect = GcodeDialect::linuxcnc;
  if (!options.require_program_end) return read_as(text, source_name, o, ended);
  o.require_program_end = false;
  Program p = read_as(text, source_name, o, ended);
  if (ended) return p;
  o.dialect = GcodeDialect::grbl;
  Program g = read_as(text, source_name, o, ended);
  g.warnings.insert(g.warnings.begin(),
                    fmt::format("{}: read as a GRBL program (auto-detected: no program end, M2, M30 or a closing %; "
                                "the linuxcnc dialect reads it as LinuxCNC does)",
                                source_name));
  return g;
}

Program read_gcode_file(const std::string& path, const GcodeOptions& options) {
  std::string text = read_text_file(path);
  // An empty file is a copy or a post-processor that failed, not a program that does nothing
  // (read as one, it would "complete" at once, and with no program end as a GRBL program).
  if (text.empty()) throw InputError(path, 0, "the file is empty (0 bytes): there is no program to read");
  return read_gcode(text, path, options);
}

}  // namespace machplan
