// Only the CLI knows flag names. The libraries name the options field a bad value sits in
// (InputError::field("kerf_mm", ...), nested members as "executor.blu_mm"); each subcommand
// declares, next to its flags, which flag sets which field:
//
//   cmd->add_option("--kerf", a->kerf, "...");
//   ...
//   field_flags(cmd, {{"kerf_mm", "--kerf"}, {"executor.blu_mm", "--blu"}});
//
// and main() prints a field error of the subcommand that ran under its flag (for_user), so
// the user reads "--kerf: 1000 is out of range ..." and a library caller "kerf_mm: ...". A
// field no table maps is printed under its own name: never dropped. A refusal that an option
// can lift ("... raise the limit with max_machine_time_s") names the flag the same way.
//
// Names the libraries parse (engine/common/names.h) come back with a note when the user wrote
// an old spelling; accept() prints it as a one-line warning naming the flag.
#pragma once

#include <cstdio>
#include <initializer_list>
#include <span>

#include <CLI/CLI.hpp>

#include "engine/common/error.h"
#include "engine/common/names.h"

namespace machplan::cli {

struct FieldFlag {
  const char* field;  // as the library names it: "kerf_mm", "executor.blu_mm"
  const char* flag;   // "--kerf"
};

// Declares `cmd`'s table. Call it after the options: every flag must be one of cmd's
// (checked: a table naming a flag the command does not have is a bug, MACHPLAN_ASSERT).
void field_flags(CLI::App* cmd, std::span<const FieldFlag> table);

// The finite number `text` given to `flag`; InputError naming the flag and quoting the text.
double number_flag(const std::string& flag, const std::string& text);
inline void field_flags(CLI::App* cmd, std::initializer_list<FieldFlag> table) {
  field_flags(cmd, std::span<const FieldFlag>(table.begin(), table.size()));
}

// `e` as the user of `app` reads it: a field error of the subcommand that ran (or of one it
// belongs to) renamed to the flag its table gives, and the option that lifts a limit
// (InputError::with_option) named by its flag; any other error unchanged.
InputError for_user(const InputError& e, const CLI::App& app);
Infeasible for_user(const Infeasible& e, const CLI::App& app);

// The value of a parsed name; an old spelling prints "machplan: warning: FLAG: NOTE" on stderr.
template <class T>
T accept(const Parsed<T>& parsed, const char* flag) {
  if (!parsed.note.empty()) std::fprintf(stderr, "machplan: warning: %s: %s\n", flag, parsed.note.c_str());
  return parsed.value;
}

}  // namespace machplan::cli
