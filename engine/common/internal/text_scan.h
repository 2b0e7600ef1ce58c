// Small helpers shared by the text readers in engine/programs (tool paths, ASCII STL).
// Internal to the engine: not part of the public reader interfaces.
#pragma once

#include <cctype>
#include <cstddef>
#include <string>
#include <string_view>

#include "engine/common/error.h"

namespace machplan::text_scan {

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

// ASCII case-insensitive comparison.
inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (std::tolower(static_cast<unsigned char>(a[k])) != std::tolower(static_cast<unsigned char>(b[k]))) return false;
  return true;
}

// excerpt() (engine/common/error.h: at most `max` characters, control and non-UTF-8 bytes as
// \xNN) with the readers' shorter default, for tokens quoted inside a line's message.
inline std::string printable(std::string_view s, std::size_t max = 32) { return excerpt(s, max); }

// Splits text into lines at '\n' (a '\r' before it stays in the line; trim() removes it).
// line_number() is the 1-based number of the line last returned.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}

  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t nl = text_.find('\n', pos_);
    const std::size_t end = nl == std::string_view::npos ? text_.size() : nl;
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    ++line_;
    return true;
  }
  int line_number() const { return line_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int line_ = 0;
};

}  // namespace machplan::text_scan
