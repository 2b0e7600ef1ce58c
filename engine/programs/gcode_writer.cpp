#include "engine/programs/gcode_writer.h"

#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

// A number with at most 6 decimals, trailing zeros (and a trailing point) dropped.
std::string num(double v) {
  if (std::abs(v) < 5e-7) v = 0.0;
  std::string s = fmt::format("{:.6f}", v);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

// Text safe inside a comment: no parentheses, no line breaks.
std::string comment_text(const std::string& text) {
  std::string out;
  for (char c : text) out.push_back(c == '(' ? '[' : c == ')' ? ']' : (c == '\n' || c == '\r') ? ' ' : c);
  return out;
}

class Writer {
 public:
  Writer(const Program& p, GcodeDialect d) : p_(p), grbl_(d == GcodeDialect::grbl), at_(p.start) {}

  std::string run(const std::string& header) {
    std::istringstream lines(header);
    for (std::string l; std::getline(lines, l);) out_ += fmt::format("({})\n", comment_text(l));
    out_ += grbl_ ? "G21 G90 G94\n" : "G21 G90 G91.1 G94\n";
    std::size_t e = 0;
    for (std::size_t i = 0; i < p_.moves.size(); ++i) {
      for (; e < p_.events.size() && p_.events[e].before_move <= i; ++e) event(p_.events[e]);
      move(p_.moves[i]);
    }
    for (; e < p_.events.size(); ++e) event(p_.events[e]);
    out_ += "M2\n";
    return std::move(out_);
  }

 private:
  void line(const std::string& code, int source_line) {
    out_ += code;
    if (source_line != last_line_ && source_line > 0) out_ += fmt::format(" (from line {})", source_line);
    last_line_ = source_line;
    out_ += "\n";
  }

  // InputError for what GRBL has no word for.
  void no_grbl(int source_line, const std::string& what) const {
    if (grbl_) throw InputError(p_.source, source_line, fmt::format("GRBL has no {}: write it in the linuxcnc dialect", what));
  }

  void path_mode(const Move& m) {
    if (grbl_) return;
    if (m.path_mode == mode_ && m.path_tolerance_mm == tolerance_) return;
    mode_ = m.path_mode;
    tolerance_ = m.path_tolerance_mm;
    switch (mode_) {
      case Move::PathMode::exact_path: out_ += "G61\n"; break;
      case Move::PathMode::exact_stop: out_ += "G61.1\n"; break;
      case Move::PathMode::blend:
        out_ += tolerance_ > 0 ? fmt::format("G64 P{}\n", num(tolerance_)) : std::string("G64\n");
        break;
    }
  }

  std::string xyz(const Eigen::Vector3d& end) const {
    std::string s = fmt::format(" X{} Y{}", num(end.x()), num(end.y()));
    if (std::abs(end.z() - at_.z()) > 5e-7) s += fmt::format(" Z{}", num(end.z()));
    return s;
  }

  void move(const Move& m) {
    switch (m.kind) {
      case Move::Kind::rapid:
        path_mode(m);
        line("G0" + xyz(m.end), m.line);
        at_ = m.end;
        break;
      case Move::Kind::line:
        path_mode(m);
        line("G1" + xyz(m.end) + feed(m), m.line);
        at_ = m.end;
        break;
      case Move::Kind::arc: arc(m); break;
      case Move::Kind::dwell: line(fmt::format("G4 P{}", num(m.seconds)), m.line); break;
      case Move::Kind::torch_on:
        line(fmt::format("{}M3 S{}", spindle(m), num(m.spindle_speed)), m.line);
        break;
      case Move::Kind::torch_off: line(fmt::format("{}M5", spindle(m)), m.line); break;
    }
  }

  std::string spindle(const Move& m) const {
    if (m.spindle != 0) no_grbl(m.line, "spindle numbers ($n M3)");
    return m.spindle == 0 ? std::string() : fmt::format("${} ", m.spindle);
  }

  std::string feed(const Move& m) {
    if (m.feed_mm_per_min == feed_) return "";
    feed_ = m.feed_mm_per_min;
    if (feed_ == kMaterialCutFeed) {
      no_grbl(m.line, "material feed (F#<_hal[plasmac.cut-feed-rate]>)");
      return " F#<_hal[plasmac.cut-feed-rate]>";
    }
    return fmt::format(" F{}", num(feed_));
  }

  void arc(const Move& m) {
    path_mode(m);
    if (m.plane != plane_) {
      plane_ = m.plane;
      out_ += plane_ == Move::Plane::xy ? "G17\n" : plane_ == Move::Plane::xz ? "G18\n" : "G19\n";
    }
    // The centre is in the plane's axis order; its offsets from the start, by axis letter.
    std::string centre;
    switch (m.plane) {
      case Move::Plane::xy:
        centre = fmt::format(" I{} J{}", num(m.center.x() - at_.x()), num(m.center.y() - at_.y()));
        break;
      case Move::Plane::xz:
        centre = fmt::format(" I{} K{}", num(m.center.y() - at_.x()), num(m.center.x() - at_.z()));
        break;
      case Move::Plane::yz:
        centre = fmt::format(" J{} K{}", num(m.center.x() - at_.y()), num(m.center.y() - at_.z()));
        break;
    }
    const std::string f = feed(m);
    std::string end = fmt::format(" X{} Y{}", num(m.end.x()), num(m.end.y()));
    if (std::abs(m.end.z() - at_.z()) > 5e-7 || m.plane != Move::Plane::xy) end += fmt::format(" Z{}", num(m.end.z()));
    if (m.turns > 0) no_grbl(m.line, "arcs of several turns (P on G2 / G3)");
    const std::string turns = m.turns > 0 ? fmt::format(" P{}", m.turns + 1) : std::string();
    line(fmt::format("{}{}{}{}{}", m.clockwise ? "G2" : "G3", end, centre, turns, f), m.line);
    at_ = m.end;
  }

  void event(const ProgramEvent& e) {
    using K = ProgramEvent::Kind;
    if (grbl_ && e.kind == K::controller_command) return line(e.text, e.line);
    if (grbl_ && e.kind != K::coolant && e.kind != K::program_stop && e.kind != K::magic_comment)
      no_grbl(e.line, fmt::format("word for a {} event", to_string(e.kind)));
    switch (e.kind) {
      case K::tool_select: line(fmt::format("T{}", e.number), e.line); break;
      case K::tool_change: line(fmt::format("M61 Q{}", e.number), e.line); break;
      case K::tool_length_offset: line(e.number < 0 ? "G49" : fmt::format("G43 H{}", e.number), e.line); break;
      case K::coolant: line(fmt::format("M{}", e.number), e.line); break;
      case K::feed_override:
        line(e.number >= 50 ? fmt::format("M{} P{}", e.number, num(e.value)) : fmt::format("M{}", e.number), e.line);
        break;
      case K::digital_output:
        line(fmt::format("M{} P{}", e.synchronized ? (e.value != 0 ? 62 : 63) : (e.value != 0 ? 64 : 65), e.number),
             e.line);
        break;
      case K::analog_output: line(fmt::format("M{} E{} Q{}", e.synchronized ? 67 : 68, e.number, num(e.value)), e.line); break;
      case K::wait_input: line(fmt::format("M66 P{} L{} Q{}", e.number, e.mode, num(e.value)), e.line); break;
      case K::user_m_code:
        line(fmt::format("M{} P{}{}", e.number, num(e.value), e.value2 != 0 ? " Q" + num(e.value2) : std::string()), e.line);
        break;
      case K::program_stop: line(fmt::format("M{}", e.number), e.line); break;
      case K::controller_command: line(fmt::format("(controller command: {})", comment_text(e.text)), e.line); break;
      case K::parameter: line(fmt::format("#<{}> = {}", e.text, num(e.value)), e.line); break;
      case K::magic_comment: line(fmt::format("({})", comment_text(e.text)), e.line); break;
    }
  }

  const Program& p_;
  bool grbl_ = false;
  std::string out_;
  Eigen::Vector3d at_;
  double feed_ = -1.0;
  Move::Plane plane_ = Move::Plane::xy;
  Move::PathMode mode_ = Move::PathMode::blend;
  double tolerance_ = 0.0;
  int last_line_ = 0;
};

}  // namespace

std::string write_gcode(const Program& program, const std::string& header, GcodeDialect dialect) {
  return Writer(program, dialect).run(header);
}

}  // namespace machplan
