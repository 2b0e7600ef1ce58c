// Names a user types for enumerated values: run modes, controller kinds, guard strategies,
// machining sides, offset methods, objectives. Each enum has one table of spellings, next to
// the enum, and one parser built on parse_name(); the table gives each value one canonical
// spelling (what to_string() prints, what the README writes) and, where an older release
// wrote it differently, that old spelling, still accepted.
//
//   constexpr Spelling kModeNames[] = {{"planned"}, {"paper-open", "paper_open"}, ...};
//   Parsed<Mode> parse_mode(std::string_view text) {
//     const auto p = parse_name(kModeNames, text, "mode", "mode");
//     return {static_cast<Mode>(p.value), p.note};
//   }
//
// The library never prints: an old spelling comes back with a note ("'paper_open' is the old
// spelling of 'paper-open'"), and the caller shows it (the CLI as a warning naming the flag).
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace machplan {

struct Spelling {
  std::string_view name;            // canonical
  std::string_view old_name = {};   // an older spelling still accepted; empty: none
};

template <class T>
struct Parsed {
  T value{};
  std::string note;  // empty, or why the text was accepted although not canonical
};

// The index in `names` of `text` (canonical or old spelling; an old one sets the note).
// Anything else throws InputError::field(field, "unknown WHAT 'TEXT' (known: a, b, c)").
Parsed<std::size_t> parse_name(std::span<const Spelling> names, std::string_view text, const char* field,
                               const char* what);

// "a, b, c": the canonical spellings, for messages and help texts.
std::string name_list(std::span<const Spelling> names);

}  // namespace machplan
