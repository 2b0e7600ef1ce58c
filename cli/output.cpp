#include "cli/output.h"

#include <cmath>
#include <exception>

#include <cstdio>
#include <filesystem>
#include <system_error>

#include <fmt/format.h>

#include "cli/command.h"
#include "engine/common/error.h"
#include "engine/common/internal/parse.h"

namespace machplan::cli {

namespace {
void say_replaced() {
  std::fprintf(stderr,
               "machplan: warning: the output holds text that is not valid UTF-8 (a file name or a name read from "
               "a file); each invalid byte is replaced by U+FFFD in the JSON\n");
}
}  // namespace

void finish_json(const JsonStream& out) {
  if (out.replaced()) say_replaced();
}

void print_json(const nlohmann::json& doc, int indent) {
  JsonStream out(stdout, indent);
  if (!doc.is_object()) {
    out.value(doc);
  } else {
    out.begin_object();
    for (const auto& [name, v] : doc.items()) {
      if (out.failed()) break;
      out.key(name);
      if (!v.is_array()) {
        out.value(v);
        continue;
      }
      out.begin_array();
      for (const auto& e : v) {
        if (out.failed()) break;
        out.value(e);
      }
      out.end_array();
    }
    out.end_object();
  }
  finish_json(out);
}

void refuse_overwriting_input(const std::string& flag, const std::string& output,
                              std::initializer_list<std::string> inputs) {
  namespace fs = std::filesystem;
  if (output.empty()) return;
  std::error_code ec;
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    // The same file under another name (a link, ../ paths) counts; so does a name that
    // resolves to the same place when the output does not exist yet.
    const bool same = fs::exists(output, ec) ? fs::equivalent(output, input, ec)
                                             : fs::weakly_canonical(output, ec) == fs::weakly_canonical(input, ec);
    if (same)
      throw InputError(flag, 0, fmt::format("'{}' is an input of this command ({}); refusing to overwrite it", output,
                                            input));
  }
}

std::uint64_t seed_of(const std::string& text) {
  std::size_t used = 0;
  unsigned long long s = 0;
  try {
    s = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || text[0] == '-')
    throw InputError("--seed", 0, fmt::format("'{}' is not a whole number >= 0", excerpt(text)));
  return s;
}

CLI::Validator finite_number(double min, bool min_exclusive) {
  const std::string desc = min <= -1e300 ? "FINITE" : min_exclusive ? "POSITIVE" : "NON-NEGATIVE";
  return CLI::Validator(
      [min, min_exclusive](std::string& text) -> std::string {
        const std::optional<double> parsed = parse_finite(text);
        if (!parsed) return fmt::format("'{}' is not a finite number", text);
        const double v = *parsed;
        if (v < min || (min_exclusive && v == min))
          return fmt::format("{} must be {} {}", text, min_exclusive ? "greater than" : "at least", min);
        return {};
      },
      desc);
}

void check_output_folder(const std::string& flag, const std::string& output) {
  namespace fs = std::filesystem;
  if (output.empty()) return;
  std::error_code ec;
  const fs::path parent = fs::path(output).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec))
    throw InputError(flag, 0, fmt::format("cannot write '{}': folder '{}' does not exist", output, parent.string()));
  if (fs::is_directory(output, ec)) throw InputError(flag, 0, fmt::format("'{}' is a folder, not a file", output));
}

}  // namespace machplan::cli
