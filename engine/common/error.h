// Errors that machplan reports to its user.
//
// Three levels, as in Drake:
//   * MACHPLAN_ASSERT  - an internal invariant; a failure is a bug in machplan (throws
//                        InternalError, never aborts the process).
//   * InputError       - bad user input: a file, a flag, a configuration key. It carries the
//                        place ("FILE:LINE" or "--flag") and what is wrong, and what() reads
//                        "FILE:LINE: message". The CLI prints it and exits with code 2.
//   * Infeasible       - the input is well formed but the job cannot be done at all (for
//                        example a workpiece that no placement can machine). Exit code 3.
//
// A solver that finds no answer returns a status in its result; it does not throw.
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace machplan {

class InputError : public std::runtime_error {
 public:
  // `where` is a file name, a flag name, or empty. `line` is 1-based; 0 means "no line".
  InputError(std::string where, int line, std::string message)
      : std::runtime_error(compose(where, line, message)),
        where_(std::move(where)),
        line_(line),
        message_(std::move(message)) {}

  // A bad value in an options struct, named by its field as the struct spells it
  // ("kerf_mm", "supervisor.following_error_mm"). The library knows no flags: the CLI renames
  // a field error to the flag that set the field (cli/field_flags.h), so a user reads
  // "--kerf: ..." and a library caller reads "kerf_mm: ...".
  static InputError field(std::string field_name, std::string message) {
    InputError e(std::move(field_name), 0, std::move(message));
    e.is_field_ = true;
    return e;
  }
  bool is_field() const { return is_field_; }
  // The same message under another name (a flag for a field), no longer a field error.
  InputError renamed(std::string where) const { return InputError(std::move(where), line_, message_); }

  const std::string& where() const { return where_; }
  int line() const { return line_; }
  const std::string& message() const { return message_; }

 private:
  static std::string compose(const std::string& where, int line, const std::string& message) {
    if (where.empty()) return message;
    if (line > 0) return fmt::format("{}:{}: {}", where, line, message);
    return fmt::format("{}: {}", where, message);
  }
  std::string where_;
  int line_;
  std::string message_;
  bool is_field_ = false;
};

class Infeasible : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace machplan

#define MACHPLAN_ASSERT(cond, ...)                                                        \
  do {                                                                                    \
    if (!(cond))                                                                          \
      throw ::machplan::InternalError(::fmt::format("{}:{}: internal check '{}' failed. ", \
                                                    __FILE__, __LINE__, #cond) +          \
                                      ::fmt::format(__VA_ARGS__));                        \
  } while (0)
