// Strict reading of one number from a flag's or a field's text.
#pragma once

#include <cmath>
#include <exception>
#include <optional>
#include <string>

namespace machplan {

// The whole of `text` as one finite number ("12", "-0.5", "1e3"), or nullopt when anything is
// left over, nothing is a number, or the value is NaN or infinite. Callers add the bounds and
// the message naming the flag or field.
inline std::optional<double> parse_finite(const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace machplan
