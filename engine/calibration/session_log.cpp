#include "engine/calibration/session_log.h"

#include <charconv>
#include <cmath>
#include <ostream>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"

namespace machplan::calibration {
namespace {

constexpr std::string_view kHeader = "t_s,axis,dac,counter,dir,ref_mm";

bool parse_double(std::string_view s, double& out) {
  if (s.empty()) return false;
  // from_chars takes no leading '+'; accept it, as spreadsheets write it.
  if (s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(out);
}

bool parse_int(std::string_view s, long long& out) {
  if (s.empty()) return false;
  if (s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

}  // namespace

const char* axis_name(int axis) { return axis == 0 ? "x" : axis == 1 ? "y" : "?"; }

SessionLog read_session_log_text(std::string_view text, const std::string& source) {
  using text_scan::printable;
  using text_scan::trim;
  SessionLog log;
  log.source = source;
  text_scan::LineReader lines(text);
  std::string_view line;
  bool header = false;
  double last_t[kLogAxes] = {0.0, 0.0};
  bool seen[kLogAxes] = {false, false};
  while (lines.next(line)) {
    const int ln = lines.line_number();
    const std::string_view s = trim(line);
    if (s.empty()) continue;
    if (s.front() == '#') {
      log.comments.emplace_back(trim(s.substr(1)));
      continue;
    }
    if (!header) {
      if (s != kHeader)
        throw InputError(source, ln, fmt::format("expected the header '{}', found '{}'", kHeader, printable(s, 60)));
      header = true;
      continue;
    }
    std::string_view f[6];
    int n = 0;
    std::size_t pos = 0;
    while (true) {
      const std::size_t comma = s.find(',', pos);
      if (n == 6) throw InputError(source, ln, "too many fields: a row has 6 (t_s,axis,dac,counter,dir,ref_mm)");
      f[n++] = trim(s.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos));
      if (comma == std::string_view::npos) break;
      pos = comma + 1;
    }
    if (n < 6)
      throw InputError(source, ln,
                       fmt::format("truncated row: {} of 6 fields (t_s,axis,dac,counter,dir,ref_mm; ref_mm may be empty "
                                   "but its comma must be there)",
                                   n));
    LogSample x;
    x.line = ln;
    if (!parse_double(f[0], x.t_s))
      throw InputError(source, ln, fmt::format("t_s '{}' is not a finite number", printable(f[0])));
    if (f[1] == "x" || f[1] == "X") {
      x.axis = 0;
    } else if (f[1] == "y" || f[1] == "Y") {
      x.axis = 1;
    } else {
      throw InputError(source, ln, fmt::format("axis '{}' is not x or y", printable(f[1])));
    }
    long long v = 0;
    if (!parse_int(f[2], v)) throw InputError(source, ln, fmt::format("dac '{}' is not an integer", printable(f[2])));
    if (v < kDacMin || v > kDacMax)
      throw InputError(source, ln, fmt::format("dac {} is outside {} .. {}", v, kDacMin, kDacMax));
    x.dac = static_cast<std::int32_t>(v);
    if (!parse_int(f[3], v))
      throw InputError(source, ln, fmt::format("counter '{}' is not an integer", printable(f[3])));
    if (v < 0 || v >= static_cast<long long>(kCounterModulus))
      throw InputError(source, ln, fmt::format("counter {} is outside 0 .. {}", v, kCounterModulus - 1));
    x.counter = static_cast<std::uint32_t>(v);
    if (!parse_int(f[4], v) || (v != 0 && v != kDirNegative))
      throw InputError(source, ln, fmt::format("dir '{}' is not 0 (positive) or 8 (negative)", printable(f[4])));
    x.direction_negative = v == kDirNegative;
    if (!f[5].empty()) {
      if (!parse_double(f[5], x.ref_mm))
        throw InputError(source, ln, fmt::format("ref_mm '{}' is not a finite number", printable(f[5])));
      x.has_ref = true;
    }
    if (x.t_s < 0) throw InputError(source, ln, fmt::format("t_s {} is negative", x.t_s));
    if (seen[x.axis] && !(x.t_s > last_t[x.axis]))
      throw InputError(source, ln,
                       fmt::format("time goes backwards or stands still on axis {}: t_s {} after {}", axis_name(x.axis),
                                   x.t_s, last_t[x.axis]));
    seen[x.axis] = true;
    last_t[x.axis] = x.t_s;
    log.samples.push_back(x);
  }
  if (!header) throw InputError(source, lines.line_number(), fmt::format("no header line '{}': not a session log", kHeader));
  if (log.samples.empty()) throw InputError(source, lines.line_number(), "the log has a header but no samples");
  return log;
}

SessionLog read_session_log(const std::string& path) { return read_session_log_text(read_text_file(path), path); }

void write_session_log(std::ostream& out, const SessionLog& log) {
  for (const auto& c : log.comments) out << "# " << c << '\n';
  out << kHeader << '\n';
  for (const auto& s : log.samples) {
    out << fmt::format("{:.6f},{},{},{},{},", s.t_s, axis_name(s.axis), s.dac, s.counter,
                       s.direction_negative ? kDirNegative : 0);
    if (s.has_ref) out << fmt::format("{:.7f}", s.ref_mm);
    out << '\n';
  }
}

}  // namespace machplan::calibration
