#include "cli/field_flags.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "engine/common/internal/parse.h"

namespace machplan::cli {
namespace {

std::map<const CLI::App*, std::vector<FieldFlag>>& tables() {
  static std::map<const CLI::App*, std::vector<FieldFlag>> t;
  return t;
}

// The innermost subcommand that ran, then its parents up to (not including) `app`.
std::vector<const CLI::App*> ran(const CLI::App& app) {
  std::vector<const CLI::App*> chain;
  const CLI::App* at = &app;
  for (;;) {
    const auto subs = at->get_subcommands();
    if (subs.empty()) break;
    at = subs.front();
    chain.insert(chain.begin(), at);
  }
  return chain;
}

}  // namespace

void field_flags(CLI::App* cmd, std::span<const FieldFlag> table) {
  for (const FieldFlag& f : table)
    MACHPLAN_ASSERT(cmd->get_option_no_throw(f.flag) != nullptr, "'{}' maps field '{}' to '{}', which it does not have",
                    cmd->get_name(), f.field, f.flag);
  auto& t = tables()[cmd];
  t.insert(t.end(), table.begin(), table.end());
}

// The flag `field` maps to in the subcommand that ran (or one it belongs to); empty if none.
std::string flag_of(const std::string& field, const CLI::App& app) {
  for (const CLI::App* cmd : ran(app)) {
    const auto it = tables().find(cmd);
    if (it == tables().end()) continue;
    for (const FieldFlag& f : it->second)
      if (field == f.field) return f.flag;
  }
  return {};
}

InputError for_user(const InputError& e, const CLI::App& app) {
  InputError out = e;
  if (e.is_field())
    if (const std::string flag = flag_of(e.where(), app); !flag.empty()) out = e.renamed(flag);
  if (!e.option().empty())
    if (const std::string flag = flag_of(e.option(), app); !flag.empty()) out = out.with_option(flag);
  return out;
}

Infeasible for_user(const Infeasible& e, const CLI::App& app) {
  if (e.option().empty()) return e;
  const std::string flag = flag_of(e.option(), app);
  return flag.empty() ? e : Infeasible(e.message(), flag);
}

double number_flag(const std::string& flag, const std::string& text) {
  const std::optional<double> v = parse_finite(text);
  if (!v) throw InputError(flag, 0, fmt::format("'{}' is not a number", excerpt(text)));
  return *v;
}

}  // namespace machplan::cli
