// The G-code reader's flags, shared by `machplan program`, `machplan run` and `machplan order`:
//   --param NAME=VALUE   a value for a named parameter the program reads but does not set
//                        (QtPlasmaC's _hal[plasmac.cut-feed-rate], _ini[...]); repeatable
//   --spindles N         spindles the machine has ($0 .. $N-1; QtPlasmaC: 3)
//   --lenient            accept a program with no M2 / M30 / closing % (with a warning)
//   --dialect D          linuxcnc, grbl or auto (default): whose reading of G-code
//                        (engine/programs/gcode.h, "Dialects")
#pragma once

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/programs/gcode.h"

namespace machplan::cli {

struct GcodeFlags {
  std::vector<std::string> params;
  int spindles = 1;
  bool lenient = false;
  std::string dialect = "auto";
};

inline void add_gcode_options(CLI::App& cmd, GcodeFlags& f) {
  cmd.add_option("--param", f.params,
                 "NAME=VALUE: value of a named parameter the program reads, e.g. "
                 "'_hal[plasmac.cut-feed-rate]=2500' (repeat for more)");
  cmd.add_option("--spindles", f.spindles, "spindles the machine has: $0 .. $N-1 (default 1, as LinuxCNC)")
      ->check(CLI::Range(1, 100));
  cmd.add_flag("--lenient", f.lenient, "accept a program with no M2, M30 or closing % (warns)");
  cmd.add_option("--dialect", f.dialect,
                 "whose G-code: linuxcnc (as LinuxCNC's rs274 reads it), grbl ('$' lines kept as controller "
                 "commands, no program end needed, '%' lines ignored, G61), or auto (default: grbl when a '$' "
                 "command, a '%' line inside the program or a missing program end shows a GRBL program, with a "
                 "note; else linuxcnc)");
}

// Builds the reader's options; throws InputError("--param", 0, ...) on a malformed NAME=VALUE
// and InputError("--dialect", ...) on an unknown dialect.
inline GcodeOptions gcode_options(const GcodeFlags& f) {
  GcodeOptions o;
  o.spindle_count = f.spindles;
  o.require_program_end = !f.lenient;
  const std::optional<GcodeDialect> dialect = gcode_dialect_from(f.dialect);
  if (!dialect) throw InputError("--dialect", 0, fmt::format("'{}' is not a dialect (linuxcnc, grbl, auto)", f.dialect));
  o.dialect = *dialect;
  for (const std::string& p : f.params) {
    const auto eq = p.rfind('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == p.size())
      throw InputError("--param", 0, fmt::format("'{}' is not NAME=VALUE", excerpt(p)));
    std::string name = p.substr(0, eq);
    if (name.size() > 2 && name[0] == '#' && name[1] == '<' && name.back() == '>')
      name = name.substr(2, name.size() - 3);
    const std::string text = p.substr(eq + 1);
    const std::optional<double> v = parse_finite(text);
    if (!v) throw InputError("--param", 0, fmt::format("'{}': the value '{}' is not a number", excerpt(p), excerpt(text)));
    o.params[name] = *v;
  }
  return o;
}

}  // namespace machplan::cli
