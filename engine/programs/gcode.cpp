// RS274NGC reader. The structure follows LinuxCNC's interpreter: each line is first cleaned
// (comments removed, spaces dropped, lower-cased), then split into words, then checked
// (modal groups, words without a code that uses them), then executed in LinuxCNC's fixed
// order. Geometry checks on arcs are done in program units, as LinuxCNC does them, and the
// result is converted to mm.
#include "engine/programs/gcode.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "engine/common/error.h"
#include "engine/common/text_file.h"

namespace machplan {
namespace {

constexpr double kMmPerInch = 25.4;
constexpr double kMaxNumber = 1e9;
// LinuxCNC's tolerances (interp_internal.hh), in inches; mm values are derived below.
constexpr double kRadiusToleranceInch = 0.00005;
constexpr double kSpiralAbsToleranceInch = 2 * 0.001 * 1.41421356237309504880;
constexpr double kSpiralAbsToleranceMm = 2 * 0.01 * 1.41421356237309504880;
constexpr double kSpiralRelativeTolerance = 0.001;
constexpr double kTiny = 1e-12;

// Codes that LinuxCNC knows and we refuse, with the name of the feature. G codes are keyed by
// ten times their number (G38.2 -> 382).
const std::map<int, const char*>& refused_g_codes() {
  static const std::map<int, const char*> codes = {
      {50, "cubic spline"}, {51, "quadratic spline"}, {52, "NURBS"}, {70, "lathe diameter mode"},
      {80, "lathe radius mode"}, {100, "setting offsets and tool data"}, {180, "XZ plane"},
      {190, "YZ plane"}, {171, "UV plane"}, {181, "WU plane"}, {191, "VW plane"},
      {280, "go to predefined position"}, {281, "setting predefined position"},
      {300, "go to predefined position"}, {301, "setting predefined position"},
      {330, "spindle-synchronised motion"}, {331, "rigid tapping"}, {382, "probing"},
      {383, "probing"}, {384, "probing"}, {385, "probing"}, {410, "cutter radius compensation"},
      {411, "dynamic cutter radius compensation"}, {420, "cutter radius compensation"},
      {421, "dynamic cutter radius compensation"}, {430, "tool length offset"},
      {431, "dynamic tool length offset"}, {432, "additional tool length offset"},
      {520, "local coordinate system offset"}, {530, "machine coordinates"},
      {550, "work coordinate system"}, {560, "work coordinate system"},
      {570, "work coordinate system"}, {580, "work coordinate system"},
      {590, "work coordinate system"}, {591, "work coordinate system"},
      {592, "work coordinate system"}, {593, "work coordinate system"},
      {610, "exact path mode"}, {611, "exact stop mode"}, {640, "path blending"},
      {700, "lathe finishing cycle"}, {710, "lathe roughing cycle"}, {711, "lathe roughing cycle"},
      {720, "lathe roughing cycle"}, {721, "lathe roughing cycle"}, {730, "canned cycle"},
      {740, "canned cycle"}, {760, "threading cycle"}, {810, "canned cycle"}, {820, "canned cycle"},
      {830, "canned cycle"}, {840, "canned cycle"}, {850, "canned cycle"}, {860, "canned cycle"},
      {870, "canned cycle"}, {880, "canned cycle"}, {890, "canned cycle"},
      {920, "coordinate system offset"}, {921, "coordinate system offset"},
      {922, "coordinate system offset"}, {923, "coordinate system offset"},
      {930, "inverse time feed"}, {950, "feed per revolution"}, {960, "constant surface speed"},
      {970, "spindle RPM mode"}, {980, "canned cycle return level"},
      {990, "canned cycle return level"}};
  return codes;
}

const char* refused_m_code(int m) {
  switch (m) {
    case 6: return "tool change";
    case 7: case 8: case 9: return "coolant";
    case 19: return "spindle orientation";
    case 48: case 49: case 50: case 51: case 52: case 53: return "override control";
    case 60: return "pallet change";
    case 61: return "setting the current tool";
    case 62: case 63: case 64: case 65: case 66: case 67: case 68: return "digital and analog I/O";
    case 70: case 71: case 72: case 73: return "saving and restoring modal state";
    case 98: case 99: return "subroutines";
    default: break;
  }
  if (m >= 100 && m <= 199) return "user-defined M code";
  return nullptr;
}

std::string g_name(int g10) {
  return g10 % 10 == 0 ? fmt::format("G{}", g10 / 10) : fmt::format("G{}.{}", g10 / 10, g10 % 10);
}

// Modal group of a supported G code (LinuxCNC's numbering); -1 for codes we do not support.
int g_group(int g10) {
  switch (g10) {
    case 40: return 0;                                   // G4 (non-modal)
    case 0: case 10: case 20: case 30: case 800: return 1;  // motion
    case 170: return 2;                                  // plane
    case 900: case 910: return 3;                        // distance mode
    case 901: case 911: return 4;                        // arc distance mode
    case 940: return 5;                                  // feed mode
    case 200: case 210: return 6;                        // units
    case 400: return 7;                                  // cutter compensation off
    case 490: return 8;                                  // tool length offset off
    case 540: return 12;                                 // coordinate system 1
    default: return -1;
  }
}

int m_group(int m) {
  switch (m) {
    case 0: case 1: case 2: case 30: return 4;
    case 3: case 4: case 5: return 7;
    default: return -1;
  }
}

// One line split into words.
struct Block {
  std::vector<int> g10;       // G codes x 10, in order of appearance
  std::vector<int> m;         // M codes
  std::array<std::optional<double>, 26> words;  // other letters, by 'a'..'z'
  std::optional<double>& w(char c) { return words[static_cast<std::size_t>(c - 'a')]; }
  const std::optional<double>& w(char c) const { return words[static_cast<std::size_t>(c - 'a')]; }
};

class Reader {
 public:
  Reader(const std::string& source, const GcodeOptions& options) : options_(options) {
    program_.source = source;
  }

  Program run(const std::string& text);

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(program_.source, line_, message);
  }

  std::string clean(const std::string& raw) const;
  Block split(const std::string& code) const;
  double read_number(const std::string& code, std::size_t& pos, char letter) const;
  // Returns false when the program ended on this line.
  bool execute(const Block& b);
  void arc(const Block& b, bool clockwise, const Eigen::Vector3d& end_mm);
  void push(Move move) {
    if (program_.moves.size() >= options_.max_moves)
      fail(fmt::format("more than {} moves: the program is too large", options_.max_moves));
    move.line = line_;
    program_.moves.push_back(move);
  }
  double scale() const { return inches_ ? kMmPerInch : 1.0; }

  const GcodeOptions& options_;
  Program program_;
  int line_ = 0;
  // Modal state, as LinuxCNC starts.
  Eigen::Vector3d pos_mm_ = Eigen::Vector3d::Zero();
  bool inches_ = false;
  bool incremental_ = false;
  bool ij_absolute_ = false;
  int motion_g10_ = 0;            // -1 after G80
  double feed_mm_per_min_ = 0.0;
  double spindle_speed_ = 0.0;
};

// Removes comments, spaces and tabs; lower-cases. Refuses nested and unclosed comments.
std::string Reader::clean(const std::string& raw) const {
  std::string out;
  out.reserve(raw.size());
  bool in_comment = false;
  for (char c : raw) {
    if (in_comment) {
      if (c == ')') in_comment = false;
      else if (c == '(') fail("nested comment: '(' inside a comment");
      continue;
    }
    if (c == '(') { in_comment = true; continue; }
    if (c == ';') break;
    if (c == ' ' || c == '\t' || c == '\r') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  if (in_comment) fail("unclosed comment: '(' without ')' on the line");
  return out;
}

double Reader::read_number(const std::string& code, std::size_t& pos, char letter) const {
  const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(letter)));
  if (pos >= code.size()) fail(fmt::format("{} word without a value", L));
  const char c0 = code[pos];
  if (c0 == '[') fail(fmt::format("expressions ([...]) are not supported (in the {} word)", L));
  if (c0 == '#') fail(fmt::format("parameters (#) are not supported (in the {} word)", L));
  if (std::isalpha(static_cast<unsigned char>(c0)))
    fail(fmt::format("{} word without a number (functions and expressions are not supported)", L));
  std::size_t p = pos;
  bool negative = false;
  if (code[p] == '+' || code[p] == '-') {
    negative = code[p] == '-';
    ++p;
    if (p < code.size() && (code[p] == '+' || code[p] == '-'))
      fail(fmt::format("repeated sign in the {} word: unary operators are not supported", L));
    if (p < code.size() && (code[p] == '[' || code[p] == '#'))
      fail(fmt::format("expressions and parameters are not supported (in the {} word)", L));
  }
  double value = 0.0, frac = 0.1;
  bool digits = false, dot = false;
  for (; p < code.size(); ++p) {
    const char c = code[p];
    if (c >= '0' && c <= '9') {
      digits = true;
      if (dot) { value += (c - '0') * frac; frac /= 10.0; }
      else value = value * 10.0 + (c - '0');
    } else if (c == '.' && !dot) {
      dot = true;
    } else {
      break;
    }
  }
  if (!digits) fail(fmt::format("{} word without a number", L));
  if (p < code.size() && code[p] == '.')
    fail(fmt::format("bad number in the {} word: more than one decimal point", L));
  if (!(std::abs(value) <= kMaxNumber))
    fail(fmt::format("number in the {} word is larger than {:g}", L, kMaxNumber));
  pos = p;
  return negative ? -value : value;
}

Block Reader::split(const std::string& code) const {
  Block b;
  std::size_t pos = 0;
  if (pos < code.size() && code[pos] == '/') ++pos;  // block delete is off: the line runs
  if (pos < code.size() && code[pos] == 'n') {       // line number
    ++pos;
    (void)read_number(code, pos, 'n');
  }
  while (pos < code.size()) {
    const char c = code[pos];
    if (c == '#') fail("parameters (#) are not supported");
    if (c == '[') fail("expressions ([...]) are not supported");
    if (c == '%') fail("'%' is only allowed on a line of its own opening and closing the program");
    if (c == '@' || c == '^') fail("polar coordinates (@ and ^ words) are not supported");
    if (c == 'o') fail("O-word subroutines are not supported");
    if (c == 'n') fail("N word (line number) is only allowed at the start of a line");
    if (!std::isalpha(static_cast<unsigned char>(c))) {
      if (std::isprint(static_cast<unsigned char>(c))) fail(fmt::format("bad character '{}'", c));
      fail(fmt::format("bad character (byte 0x{:02x})", static_cast<unsigned>(static_cast<unsigned char>(c))));
    }
    ++pos;
    const double v = read_number(code, pos, c);
    const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    switch (c) {
      case 'g': {
        if (v < 0) fail(fmt::format("negative G code G{:g}", v));
        const double tenfold = v * 10.0;
        const long long g10 = std::llround(tenfold);
        if (std::abs(tenfold - static_cast<double>(g10)) > 1e-4 || g10 > 9999)
          fail(fmt::format("unknown G code G{:g}", v));
        b.g10.push_back(static_cast<int>(g10));
        break;
      }
      case 'm': {
        if (v < 0) fail(fmt::format("negative M code M{:g}", v));
        const long long m = std::llround(v);
        if (std::abs(v - static_cast<double>(m)) > 1e-4) fail(fmt::format("M code M{:g} is not an integer", v));
        if (b.m.size() >= 4) fail("more than 4 M codes on one line");
        b.m.push_back(static_cast<int>(m));
        break;
      }
      case 'x': case 'y': case 'z': case 'i': case 'j': case 'k': case 'r': case 'f': case 's': case 'p':
        if (b.w(c)) fail(fmt::format("multiple {} words on one line", L));
        b.w(c) = v;
        break;
      case 'a': case 'b': case 'c': case 'u': case 'v': case 'w':
        fail(fmt::format("{} axis words are not supported (only X, Y and Z)", L));
      case 't': fail("T words (tool selection) are not supported");
      case 'd': fail("D words (cutter compensation) are not supported");
      case 'h': fail("H words (tool length offsets) are not supported");
      case 'e': fail("E words are not supported (and 'E' is a word letter, not an exponent: write 1000, not 1e3)");
      case 'l': case 'q': fail(fmt::format("{} words are not supported", L));
      default: fail(fmt::format("bad character '{}'", c));
    }
  }
  return b;
}

Program Reader::run(const std::string& text) {
  options_.validate();
  std::size_t start = 0;
  bool percent_mode = false;
  bool ended = false;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++line_;
    std::string raw = text.substr(start, std::min(end - start, options_.max_line_chars + 2));
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    start = end + 1;
    if (raw.size() > options_.max_line_chars)
      fail(fmt::format("line is longer than {} characters", options_.max_line_chars));
    // '%' lines open and close the program.
    const auto first = raw.find_first_not_of(" \t");
    if (first != std::string::npos && raw[first] == '%') {
      if (line_ == 1) { percent_mode = true; continue; }
      if (percent_mode) { ended = true; break; }
    }
    const Block b = split(clean(raw));
    if (!execute(b)) {
      ended = true;
      program_.ends_with_program_end = true;
      break;
    }
  }
  if (!ended && options_.require_program_end)
    fail("file ended with no percent sign or program end (M2 or M30)");
  return std::move(program_);
}

bool Reader::execute(const Block& b) {
  // --- Modal group checks ---------------------------------------------------------------
  std::array<int, 16> g_seen;
  g_seen.fill(-1);
  for (int g : b.g10) {
    int group = g_group(g);
    if (group < 0) {
      const auto& refused = refused_g_codes();
      const auto it = refused.find(g);
      if (it != refused.end()) fail(fmt::format("{} ({}) is not supported", g_name(g), it->second));
      fail(fmt::format("unknown G code {}", g_name(g)));
    }
    if (g_seen[static_cast<std::size_t>(group)] >= 0)
      fail(fmt::format("two G codes from the same modal group on one line: {} and {}",
                       g_name(g_seen[static_cast<std::size_t>(group)]), g_name(g)));
    g_seen[static_cast<std::size_t>(group)] = g;
  }
  std::array<int, 16> m_seen;
  m_seen.fill(-1);
  for (int m : b.m) {
    const int group = m_group(m);
    if (group < 0) {
      if (const char* name = refused_m_code(m)) fail(fmt::format("M{} ({}) is not supported", m, name));
      fail(fmt::format("unknown M code M{}", m));
    }
    if (m_seen[static_cast<std::size_t>(group)] >= 0)
      fail(fmt::format("two M codes from the same modal group on one line: M{} and M{}",
                       m_seen[static_cast<std::size_t>(group)], m));
    m_seen[static_cast<std::size_t>(group)] = m;
  }

  // --- Words without a code that uses them -----------------------------------------------
  const bool has_axis = b.w('x') || b.w('y') || b.w('z');
  const int g_motion = g_seen[1];
  const bool dwell = g_seen[0] == 40;
  if (g_motion == 800 && has_axis) fail("axis words (X, Y, Z) with G80");
  int motion_to_be = -1;  // the motion this line performs
  if (g_motion >= 0 && g_motion != 800) motion_to_be = g_motion;
  else if (g_motion < 0 && has_axis) {
    if (motion_g10_ < 0) fail("axis words (X, Y, Z) without a motion code G0..G3 to use them (motion mode is G80)");
    motion_to_be = motion_g10_;
  }
  const bool is_arc = motion_to_be == 20 || motion_to_be == 30;
  if (b.w('k')) fail(is_arc ? "K word given for an arc in the XY plane" : "K word with no G2 or G3 to use it");
  if (b.w('i') && !is_arc) fail("I word with no G2 or G3 to use it");
  if (b.w('j') && !is_arc) fail("J word with no G2 or G3 to use it");
  if (b.w('r') && !is_arc) fail("R word with no G2 or G3 to use it");
  if (b.w('p') && !is_arc && !dwell) fail("P word with no G2, G3 or G4 to use it");
  if (is_arc) {
    if (b.w('r') && (b.w('i') || b.w('j'))) fail("mixed radius (R) and centre (I, J) format for an arc");
    if (!b.w('r') && !b.w('i') && !b.w('j')) fail("R, I and J words all missing for an arc");
    if (b.w('p')) {
      const double p = *b.w('p');
      if (std::abs(p - std::round(p)) > 1e-4) fail(fmt::format("P word on G2/G3 is not an integer: P{:g}", p));
      if (std::round(p) < 1) fail(fmt::format("P word on G2/G3 must be 1 or greater (number of turns), got P{:g}", p));
      if (std::round(p) > options_.max_arc_turns)
        fail(fmt::format("P{:g} asks for more than {} turns on one arc", p, options_.max_arc_turns));
    }
  }

  // --- Execution, in LinuxCNC's order -------------------------------------------------------
  if (b.w('f')) {
    if (*b.w('f') < 0) fail("negative F word (feed rate)");
    feed_mm_per_min_ = *b.w('f') * scale();
  }
  if (b.w('s')) {
    if (*b.w('s') < 0) fail("negative S word (spindle speed)");
    spindle_speed_ = *b.w('s');
  }
  if (m_seen[7] == 3 || m_seen[7] == 4) {
    Move m;
    m.kind = Move::Kind::torch_on;
    m.spindle_speed = spindle_speed_;
    m.end = pos_mm_;
    push(m);
  } else if (m_seen[7] == 5) {
    Move m;
    m.kind = Move::Kind::torch_off;
    m.end = pos_mm_;
    push(m);
  }
  if (dwell) {
    if (!b.w('p') || *b.w('p') < 0) fail("dwell time missing with G4 (P seconds, 0 or more)");
    Move m;
    m.kind = Move::Kind::dwell;
    m.seconds = *b.w('p');
    m.end = pos_mm_;
    push(m);
  }
  if (g_seen[6] == 200) inches_ = true;
  if (g_seen[6] == 210) inches_ = false;
  if (g_seen[3] == 900) incremental_ = false;
  if (g_seen[3] == 910) incremental_ = true;
  if (g_seen[4] == 901) ij_absolute_ = true;
  if (g_seen[4] == 911) ij_absolute_ = false;
  if (g_motion >= 0) motion_g10_ = g_motion == 800 ? -1 : g_motion;

  if (motion_to_be >= 0) {
    Eigen::Vector3d end = pos_mm_;
    const char axes[3] = {'x', 'y', 'z'};
    for (int a = 0; a < 3; ++a) {
      if (const auto& v = b.w(axes[a])) end[a] = incremental_ ? pos_mm_[a] + *v * scale() : *v * scale();
    }
    if (motion_to_be == 0) {
      Move m;
      m.kind = Move::Kind::rapid;
      m.end = end;
      push(m);
    } else if (motion_to_be == 10) {
      if (feed_mm_per_min_ <= 0) fail("cannot do G1 with zero feed rate");
      Move m;
      m.kind = Move::Kind::line;
      m.end = end;
      m.feed_mm_per_min = feed_mm_per_min_;
      push(m);
    } else {
      if (feed_mm_per_min_ <= 0) fail(fmt::format("cannot make an arc (G{}) with zero feed rate", motion_to_be / 10));
      arc(b, motion_to_be == 20, end);
    }
    pos_mm_ = end;
  }

  // M0 / M1 stop the machine but do not move it; M2 / M30 end the program.
  return !(m_seen[4] == 2 || m_seen[4] == 30);
}

void Reader::arc(const Block& b, bool clockwise, const Eigen::Vector3d& end_mm) {
  // LinuxCNC does this arithmetic in program units; so do we.
  const double s = scale();
  const double radius_tolerance = inches_ ? kRadiusToleranceInch : kRadiusToleranceInch * kMmPerInch;
  const double spiral_abs_tolerance = inches_ ? kSpiralAbsToleranceInch : kSpiralAbsToleranceMm;
  const double x0 = pos_mm_.x() / s, y0 = pos_mm_.y() / s;
  const double x1 = end_mm.x() / s, y1 = end_mm.y() / s;
  double cx = 0, cy = 0;
  if (b.w('r')) {
    const double r = *b.w('r');
    if (x0 == x1 && y0 == y1) fail("current point same as end point of arc (R format cannot make a full circle)");
    const double abs_r = std::abs(r);
    if (abs_r == 0) fail("zero-radius arc: R0");
    const double mid_x = (x0 + x1) / 2.0, mid_y = (y0 + y1) / 2.0;
    double half = std::hypot(mid_x - x1, mid_y - y1);
    if (!(half - abs_r <= radius_tolerance))
      fail(fmt::format("arc radius R{:g} too small to reach end point (half the chord is {:.4f})", r, half));
    if (half / abs_r > 1 - kTiny) half = abs_r;
    const double chord_angle = std::atan2(y1 - y0, x1 - x0);
    const double theta = ((clockwise && r > 0) || (!clockwise && r < 0)) ? chord_angle - M_PI_2 : chord_angle + M_PI_2;
    const double offset = abs_r * std::cos(std::asin(half / abs_r));
    cx = mid_x + offset * std::cos(theta);
    cy = mid_y + offset * std::sin(theta);
  } else {
    const double i = b.w('i').value_or(0.0), j = b.w('j').value_or(0.0);
    // I/J are in program units; with G90.1 they are absolute centre coordinates (no G91
    // offset applies to them).
    cx = ij_absolute_ ? i : x0 + i;
    cy = ij_absolute_ ? j : y0 + j;
    const double r1 = std::hypot(cx - x0, cy - y0);
    const double r2 = std::hypot(cx - x1, cy - y1);
    const auto where = [&] {
      return fmt::format("start=(X{:.4f},Y{:.4f}) center=(X{:.4f},Y{:.4f}) end=(X{:.4f},Y{:.4f}) r1={:.4f} r2={:.4f}",
                         x0, y0, cx, cy, x1, y1, r1, r2);
    };
    if (r1 < radius_tolerance || r2 < radius_tolerance) fail("zero-radius arc: " + where());
    const double abs_err = std::abs(r1 - r2);
    const double rel_err = abs_err / std::max(r1, r2);
    if (abs_err > spiral_abs_tolerance * 100.0 || (rel_err > kSpiralRelativeTolerance && abs_err > spiral_abs_tolerance))
      fail("radius to end of arc differs from radius to start: " + where());
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) fail("arc centre cannot be computed (numbers too large or too small)");
  Move m;
  m.kind = Move::Kind::arc;
  m.end = end_mm;
  m.center = Eigen::Vector2d(cx * s, cy * s);
  m.clockwise = clockwise;
  m.turns = b.w('p') ? static_cast<int>(std::lround(*b.w('p'))) - 1 : 0;
  m.feed_mm_per_min = feed_mm_per_min_;
  push(m);
}

}  // namespace

void GcodeOptions::validate() const {
  if (max_line_chars < 1 || max_line_chars > (1u << 20))
    throw InputError("GcodeOptions", 0, fmt::format("max_line_chars = {} must be in 1..{}", max_line_chars, 1u << 20));
  if (max_moves < 1) throw InputError("GcodeOptions", 0, "max_moves = 0 must be at least 1");
  if (max_arc_turns < 1 || max_arc_turns > 1'000'000)
    throw InputError("GcodeOptions", 0, fmt::format("max_arc_turns = {} must be in 1..1000000", max_arc_turns));
}

Program read_gcode(const std::string& text, const std::string& source_name, const GcodeOptions& options) {
  Reader reader(source_name, options);
  return reader.run(text);
}

Program read_gcode_file(const std::string& path, const GcodeOptions& options) {
  return read_gcode(read_text_file(path), path, options);
}

}  // namespace machplan
