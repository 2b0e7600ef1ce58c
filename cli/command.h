// How a `machplan` subcommand plugs into the command line.
//
// Each subcommand lives in its own cli/*.cpp file and registers itself:
//
//   namespace {
//   void add_program(CLI::App& app) {
//     auto* cmd = app.add_subcommand("program", "Interpret a G-code part program");
//     ...
//     cmd->callback([=] { ...; });   // throw InputError on bad input
//   }
//   const machplan::cli::Registration reg(10, add_program);
//   }
//
// The rank orders subcommands in `machplan --help`. Callbacks report bad input by throwing
// machplan::InputError (exit 2) or machplan::Infeasible (exit 3); a command that finished but
// must signal a non-zero status calls set_exit_code().
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace machplan::cli {

using AddCommand = std::function<void(CLI::App&)>;

struct Registration {
  Registration(int rank, AddCommand add);
};

void set_exit_code(int code);

// Number checks for options, applied at parse time (so a bad value exits 2 naming the flag).
// CLI11's own PositiveNumber lets NaN through (NaN <= 0 is false); these refuse NaN and
// infinities by name.
CLI::Validator finite_number(double min, bool min_exclusive);
inline const CLI::Validator kFinite = finite_number(-1e300, false);
inline const CLI::Validator kFinitePositive = finite_number(0.0, true);
inline const CLI::Validator kFiniteNonNegative = finite_number(0.0, false);

// The value of --seed: a whole number >= 0; InputError("--seed", ...) otherwise.
std::uint64_t seed_of(const std::string& text);

}  // namespace machplan::cli
