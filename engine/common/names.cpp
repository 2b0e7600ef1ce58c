#include "engine/common/names.h"

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan {

Parsed<std::size_t> parse_name(std::span<const Spelling> names, std::string_view text, const char* field,
                               const char* what) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (text == names[i].name) return {i, {}};
  for (std::size_t i = 0; i < names.size(); ++i)
    if (!names[i].old_name.empty() && text == names[i].old_name)
      return {i, fmt::format("'{}' is the old spelling of '{}'", text, names[i].name)};
  throw InputError::field(field, fmt::format("unknown {} '{}' (known: {})", what, excerpt(text), name_list(names)));
}

std::string name_list(std::span<const Spelling> names) {
  std::string all;
  for (const Spelling& s : names) all += fmt::format("{}{}", all.empty() ? "" : ", ", s.name);
  return all;
}

}  // namespace machplan
