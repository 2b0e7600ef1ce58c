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
#include <string_view>

#include <fmt/format.h>

namespace machplan {

class InputError : public std::runtime_error {
 public:
  // `where` is a file name, a flag name, or empty. `line` is 1-based; 0 means "no line".
  InputError(std::string where, int line, std::string message)
      : InputError(std::move(where), line, std::move(message), {}, false) {}

  // A bad value in an options struct, named by its field as the struct spells it
  // ("kerf_mm", "supervisor.following_error_mm"). The library knows no flags: the CLI renames
  // a field error to the flag that set the field (cli/field_flags.h), so a user reads
  // "--kerf: ..." and a library caller reads "kerf_mm: ...".
  static InputError field(std::string field_name, std::string message) {
    return InputError(std::move(field_name), 0, std::move(message), {}, true);
  }
  bool is_field() const { return is_field_; }
  // The same message under another name (a flag for a field), no longer a field error.
  InputError renamed(std::string where) const { return InputError(std::move(where), line_, message_, option_, false); }
  // A field error of a member struct as its owner names it: "blu_mm" within "executor" is
  // "executor.blu_mm". Anything else comes back unchanged.
  InputError within(const std::string& member) const {
    return is_field_ ? InputError(member + "." + where_, 0, message_, option_, true) : *this;
  }

  // An input refused by a limit the caller may lift: `field` names the options field that
  // sets it, and what() continues the message with " with FIELD" ("... raise the limit" +
  // " with max_entities"); the CLI names the flag instead (cli/field_flags.h).
  InputError with_option(std::string field) const {
    return InputError(where_, line_, message_, std::move(field), is_field_);
  }
  const std::string& option() const { return option_; }

  const std::string& where() const { return where_; }
  int line() const { return line_; }
  const std::string& message() const { return message_; }

 private:
  InputError(std::string where, int line, std::string message, std::string option, bool is_field)
      : std::runtime_error(compose(where, line, message, option)),
        where_(std::move(where)),
        line_(line),
        message_(std::move(message)),
        option_(std::move(option)),
        is_field_(is_field) {}
  static std::string compose(const std::string& where, int line, const std::string& message,
                             const std::string& option) {
    const std::string text = option.empty() ? message : fmt::format("{} with {}", message, option);
    if (where.empty()) return text;
    if (line > 0) return fmt::format("{}:{}: {}", where, line, text);
    return fmt::format("{}: {}", where, text);
  }
  std::string where_;
  int line_;
  std::string message_;
  std::string option_;
  bool is_field_ = false;
};

// The usual check of an options field: unless `ok`, InputError::field(field, "VALUE RULE"),
// which reads "kerf_mm: -1 must be in [0, 100] mm".
template <class Value>
void require_field(bool ok, const std::string& field, const Value& value, std::string_view rule) {
  if (!ok) throw InputError::field(field, fmt::format("{} {}", value, rule));
}

// Validates `part`, a member of an options struct named `member` there: its field errors
// come out under the owner's names ("executor.blu_mm"), so that the CLI finds the flag.
template <class Part>
void validate_member(const std::string& member, const Part& part) {
  try {
    part.validate();
  } catch (const InputError& e) {
    throw e.within(member);
  }
}

// A piece of the user's text made safe to quote in a message (a YAML value, a G-code word, a
// DXF value, a CSV cell, a flag's value): at most `max_chars` characters of it, then "..."
// when it is longer, so that a 10 MB line is never echoed whole; control characters and
// bytes that are not UTF-8 are written as \xNN. Every message that quotes user text goes
// through here.
inline constexpr std::size_t kExcerptChars = 60;
std::string excerpt(std::string_view text, std::size_t max_chars = kExcerptChars);

class Infeasible : public std::runtime_error {
 public:
  explicit Infeasible(const std::string& message) : Infeasible(message, {}) {}
  // Work refused by a limit the caller may lift (InputError::with_option): what() continues
  // `message` with " with FIELD", FIELD naming the options field that sets the limit.
  Infeasible(const std::string& message, std::string option)
      : std::runtime_error(option.empty() ? message : fmt::format("{} with {}", message, option)),
        message_(message),
        option_(std::move(option)) {}
  const std::string& message() const { return message_; }
  const std::string& option() const { return option_; }

 private:
  std::string message_;
  std::string option_;
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
