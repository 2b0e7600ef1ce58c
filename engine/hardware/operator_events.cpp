#include "engine/hardware/operator_events.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"

namespace machplan::hardware {

const char* to_string(OperatorEventRow::Kind k) {
  using K = OperatorEventRow::Kind;
  switch (k) {
    case K::hold: return "hold";
    case K::start: return "start";
    case K::stop: return "stop";
    case K::feed_override: return "feed_override";
    case K::rapid_override: return "rapid_override";
    case K::paused_motion: return "paused_motion";
    case K::paused_motion_speed: return "paused_motion_speed";
    case K::thc: return "thc";
    case K::torch: return "torch";
  }
  return "?";
}

namespace {

using K = OperatorEventRow::Kind;
using text_scan::printable;
using text_scan::trim;

constexpr std::size_t kMaxRows = 100000;

std::vector<std::string_view> fields(std::string_view line) {
  std::vector<std::string_view> f;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = line.find(',', from);
    f.push_back(trim(line.substr(from, comma == std::string_view::npos ? std::string_view::npos : comma - from)));
    if (comma == std::string_view::npos) return f;
    from = comma + 1;
  }
}

bool is_button(K k) { return k == K::hold || k == K::start || k == K::stop; }

OperatorEventRow row_of(const std::vector<std::string_view>& f, const std::string& source, int line) {
  if (f.size() != 3)
    throw InputError(source, line, fmt::format("expected 3 fields (t_s, event, value), found {}", f.size()));
  OperatorEventRow r;
  r.line = line;
  const std::optional<double> t = parse_finite(std::string(f[0]));
  if (!t) throw InputError(source, line, fmt::format("time '{}' is not a number", printable(f[0])));
  if (*t < 0 || *t > 1e7) throw InputError(source, line, fmt::format("time {} s must be in [0, 1e7]", *t));
  r.t_s = *t;
  bool known = f[1] == "recover";  // the older name of paused_motion
  if (known) r.kind = K::paused_motion;
  for (K k : {K::hold, K::start, K::stop, K::feed_override, K::rapid_override, K::paused_motion, K::paused_motion_speed, K::thc,
              K::torch})
    if (f[1] == to_string(k)) r.kind = k, known = true;
  if (!known)
    throw InputError(source, line,
                     fmt::format("unknown event '{}' (events: hold, start, stop, feed_override, rapid_override, paused_motion, "
                                 "paused_motion_speed, thc, torch)",
                                 printable(f[1])));
  const char* name = to_string(r.kind);
  if (is_button(r.kind)) {
    if (!f[2].empty()) throw InputError(source, line, fmt::format("'{}' takes no value, found '{}'", name, printable(f[2])));
    return r;
  }
  if (f[2].empty()) throw InputError(source, line, fmt::format("'{}' needs a value", name));
  const std::optional<double> v = parse_finite(std::string(f[2]));
  if (!v) throw InputError(source, line, fmt::format("{} value '{}' is not a number", name, printable(f[2])));
  r.value = *v;
  const auto range = [&](double lo, double hi, const char* unit) {
    if (r.value < lo || r.value > hi) throw InputError(source, line, fmt::format("{} {}{} must be in [{}, {}]", name, r.value, unit, lo, hi));
  };
  switch (r.kind) {
    case K::feed_override: range(0, 200, " %"); break;
    case K::rapid_override: range(1, 100, " %"); break;
    case K::paused_motion:
      range(-1000, 1000, " mm");
      if (r.value == 0) throw InputError(source, line, "paused_motion 0 mm asks for nothing");
      break;
    case K::paused_motion_speed: range(-1, 1, ""); break;
    case K::thc:
    case K::torch:
      if (r.value != 0 && r.value != 1) throw InputError(source, line, fmt::format("{} {} must be 1 (on) or 0 (off)", name, r.value));
      break;
    default: break;
  }
  return r;
}

// The states the rows make: each button pressed at its time and released kPress_s later.
std::vector<OperatorEvent> states_of(const std::vector<OperatorEventRow>& rows) {
  struct Change {
    double t;
    const OperatorEventRow* row;
    bool press;
  };
  std::vector<Change> changes;
  for (const OperatorEventRow& r : rows) {
    changes.push_back({r.t_s, &r, true});
    if (is_button(r.kind)) changes.push_back({r.t_s + kPress_s, &r, false});
  }
  std::stable_sort(changes.begin(), changes.end(), [](const Change& a, const Change& b) { return a.t < b.t; });
  std::vector<OperatorEvent> out;
  OperatorInputs s;
  for (const Change& c : changes) {
    switch (c.row->kind) {
      case K::hold: s.feed_hold = c.press; break;
      case K::start: s.cycle_start = c.press; break;
      case K::stop: s.stop = c.press; break;
      case K::feed_override: s.feed_override_pct = c.row->value; break;
      case K::rapid_override: s.rapid_override_pct = c.row->value; break;
      case K::paused_motion: s.paused_motion_mm += c.row->value; break;
      case K::paused_motion_speed: s.paused_motion_speed = c.row->value; break;
      case K::thc: s.thc_enabled = c.row->value != 0; break;
      case K::torch: s.torch_enabled = c.row->value != 0; break;
    }
    if (!out.empty() && out.back().at_s == c.t) out.back().inputs = s;
    else out.push_back({c.t, s});
  }
  return out;
}

}  // namespace

OperatorTimeline parse_operator_events(std::string_view text, const std::string& source) {
  OperatorTimeline tl;
  tl.source = source;
  text_scan::LineReader lines(text);
  std::string_view l;
  bool header = false;
  std::vector<double> last_press(3, -1e300);  // hold, start, stop
  while (lines.next(l)) {
    const int line = lines.line_number();
    if (const std::size_t hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
    l = trim(l);
    if (l.empty()) continue;
    const std::vector<std::string_view> f = fields(l);
    if (!header) {
      if (f.size() != 3 || f[0] != "t_s" || f[1] != "event" || f[2] != "value")
        throw InputError(source, line, fmt::format("the first line must be the header 't_s,event,value', found '{}'", printable(l, 60)));
      header = true;
      continue;
    }
    if (tl.rows.size() >= kMaxRows) throw InputError(source, line, "more than 100 000 events");
    OperatorEventRow r = row_of(f, source, line);
    if (!tl.rows.empty() && r.t_s < tl.rows.back().t_s)
      throw InputError(source, line, fmt::format("time {} s goes back (previous event: {} s)", r.t_s, tl.rows.back().t_s));
    if (is_button(r.kind)) {
      double& last = last_press[static_cast<std::size_t>(r.kind)];
      if (r.t_s - last < 2 * kPress_s)
        throw InputError(source, line, fmt::format("'{}' pressed again {:.3f} s after its last press (at least {} s apart)",
                                                   to_string(r.kind), r.t_s - last, 2 * kPress_s));
      last = r.t_s;
    }
    tl.rows.push_back(r);
  }
  if (!header) throw InputError(source, 0, "no header 't_s,event,value'");
  tl.states = states_of(tl.rows);
  return tl;
}

OperatorTimeline read_operator_events(const std::string& path) {
  return parse_operator_events(read_text_file(path, std::size_t{16} << 20), path);
}

}  // namespace machplan::hardware
