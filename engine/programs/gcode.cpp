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
#include "engine/programs/gcode_expr.h"

namespace machplan {
namespace {

constexpr double kMmPerInch = 25.4;
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
      {80, "lathe radius mode"}, {171, "UV plane"}, {181, "WU plane"}, {191, "VW plane"},
      {330, "spindle-synchronised motion"}, {331, "rigid tapping"}, {382, "probing"},
      {383, "probing"}, {384, "probing"}, {385, "probing"}, {410, "cutter radius compensation"},
      {411, "dynamic cutter radius compensation"}, {420, "cutter radius compensation"},
      {421, "dynamic cutter radius compensation"}, {431, "dynamic tool length offset"},
      {432, "additional tool length offset"},
      {700, "lathe finishing cycle"}, {710, "lathe roughing cycle"}, {711, "lathe roughing cycle"},
      {720, "lathe roughing cycle"}, {721, "lathe roughing cycle"}, {740, "left-hand tapping cycle"},
      {760, "threading cycle"}, {840, "tapping cycle"}, {860, "boring cycle with spindle stop"},
      {870, "back boring cycle"}, {880, "boring cycle with manual retract"},
      {930, "inverse time feed"}, {950, "feed per revolution"}, {960, "constant surface speed"}};
  return codes;
}

const char* refused_m_code(int m) {
  switch (m) {
    case 19: return "spindle orientation";
    case 60: return "pallet change";
    case 70: case 71: case 72: case 73: return "saving and restoring modal state";
    case 98: case 99: return "subroutines (M98/M99, Fanuc style)";
    default: break;
  }
  return nullptr;
}

std::string g_name(int g10) {
  return g10 % 10 == 0 ? fmt::format("G{}", g10 / 10) : fmt::format("G{}.{}", g10 / 10, g10 % 10);
}

// Modal group of a supported G code (LinuxCNC's numbering); -1 for codes we do not support.
int g_group(int g10) {
  switch (g10) {
    case 40: case 100: case 280: case 281: case 300: case 301: case 520: case 530: case 920: case 921: case 922:
    case 923:
      return 0;                                           // non-modal
    case 0: case 10: case 20: case 30: case 730: case 800: case 810: case 820: case 830: case 850:
    case 890: return 1;                                   // motion
    case 170: case 180: case 190: return 2;               // plane
    case 900: case 910: return 3;                         // distance mode
    case 901: case 911: return 4;                         // arc distance mode
    case 940: return 5;                                   // feed mode
    case 200: case 210: return 6;                         // units
    case 400: return 7;                                   // cutter compensation off
    case 430: case 490: return 8;                         // tool length offset
    case 980: case 990: return 10;                        // canned cycle return mode
    case 540: case 550: case 560: case 570: case 580: case 590: case 591: case 592: case 593: return 12;
    case 610: case 611: case 640: return 13;              // path control
    case 970: return 14;                                  // spindle RPM mode
    default: return -1;
  }
}

int m_group(int m) {
  switch (m) {
    case 0: case 1: case 2: case 30: return 4;
    case 62: case 63: case 64: case 65: case 66: case 67: case 68: return 5;
    case 6: case 61: return 6;
    case 3: case 4: case 5: return 7;
    case 7: case 8: case 9: return 8;
    case 48: case 49: case 50: case 51: case 52: case 53: return 9;
    default: break;
  }
  if (m >= 100 && m <= 199) return 10;
  return -1;
}

bool is_cycle(int g10) { return g10 == 730 || (g10 >= 810 && g10 <= 890); }

// Control-flow keyword of an O-word line.
enum class OKind { none, sub, endsub, call, do_, while_, endwhile, if_, elseif, else_, endif, repeat, endrepeat,
                   return_, break_, continue_ };

OKind o_kind_of(const std::string& word) {
  static const std::pair<const char*, OKind> words[] = {
      {"sub", OKind::sub},         {"endsub", OKind::endsub},     {"call", OKind::call},
      {"do", OKind::do_},          {"while", OKind::while_},      {"endwhile", OKind::endwhile},
      {"if", OKind::if_},          {"elseif", OKind::elseif},     {"else", OKind::else_},
      {"endif", OKind::endif},     {"repeat", OKind::repeat},     {"endrepeat", OKind::endrepeat},
      {"return", OKind::return_},  {"break", OKind::break_},      {"continue", OKind::continue_}};
  for (const auto& [w, k] : words)
    if (word == w) return k;
  return OKind::none;
}

// One source line as read before execution.
struct SourceLine {
  int number = 0;
  std::string code;   // cleaned: no comments, no blanks, lower case
  std::string error;  // a cleaning error, reported when the line runs
  // O-word lines
  OKind o = OKind::none;
  std::string label;
  std::size_t rest = 0;     // position in `code` after the keyword
  int partner = -1;         // sub -> endsub, while -> endwhile, do -> its closing while,
                            // repeat -> endrepeat, if/elseif/else -> next clause or endif,
                            // closing lines -> their opening line, break/continue/return -> the
                            // opening line of their construct
  int endif = -1;           // if / elseif / else: the endif
  bool closes_do = false;   // a "while" that ends a do-loop
  std::string o_error;      // a structure error, reported when the line runs
  // GRBL dialect: a system command line ($H, $X, $J=...), kept as written (trimmed).
  bool system_command = false;
  std::string text;
  // GcodeOptions::report_magic_comments: the text of a comment "(o=...)" on the line.
  std::string magic;
};

// One line split into words.
struct Block {
  std::vector<int> g10;       // G codes x 10, in order of appearance
  std::vector<int> m;         // M codes
  std::array<std::optional<double>, 26> words;  // other letters, by 'a'..'z'
  std::optional<int> spindle;                   // $n
  std::vector<std::pair<int, double>> set_numbered;
  std::vector<std::pair<std::string, double>> set_named;
  std::optional<double>& w(char c) { return words[static_cast<std::size_t>(c - 'a')]; }
  const std::optional<double>& w(char c) const { return words[static_cast<std::size_t>(c - 'a')]; }
};

// The G and M codes of a block by modal group, and what the block does with them.
struct Codes {
  std::array<int, 16> g;  // G code x 10 per modal group (LinuxCNC's numbering), -1 when none
  std::array<int, 16> m;  // M code per modal group, -1 when none
  bool has_axis = false;      // X, Y or Z given
  bool g0_uses_axes = false;  // a non-modal code that takes the axis words (G10, G28, G30, G52, G92)
  int motion = -1;            // the motion the line performs (G code x 10), -1 for none
  bool is_arc = false, cycle = false;
  Move::Plane plane = Move::Plane::xy;  // the plane for this line
};

constexpr char kAxes[3] = {'x', 'y', 'z'};

// A subroutine call in progress.
struct Frame {
  int return_pc = 0;
  std::array<double, 30> saved{};  // the caller's #1..#30
  std::map<std::string, double> locals;
  std::map<int, long long> repeats;  // repeat line -> passes left
};

constexpr int kMaxCallDepth = 50;
constexpr int kFirstG28Param = 5161;   // #5161..#5169: the G28 position (machine coordinates)
constexpr int kFirstG30Param = 5181;   // #5181..#5189: the G30 position
constexpr int kFirstG92Param = 5211;   // #5211..#5219: G92 offsets, #5210: G92 in effect
constexpr int kCoordSystemParam = 5220;
constexpr int kFirstG5xParam = 5221;   // #5221 + 20 (n - 1) + axis: G54..G59.3 offsets

// Parameters that hold lengths (kept in mm, read and written in the program's units): the G28
// and G30 positions, the G92 offsets and the G54..G59.3 offsets (X, Y, Z, A, B, C, U, V, W).
bool is_length_param(int n) {
  return (n >= 5161 && n <= 5169) || (n >= 5181 && n <= 5189) || (n >= 5211 && n <= 5219) ||
         (n >= 5221 && n <= 5390 && (n - 5221) % 20 < 9);
}

class Reader : public gcode_expr::Parameters {
 public:
  Reader(const std::string& source, const GcodeOptions& options) : options_(options), params_(5603, 0.0) {
    program_.source = source;
    params_[kCoordSystemParam] = 1;
    for (const auto& [k, v] : options.params) {
      std::string key;
      for (char c : k)
        if (c != ' ' && c != '\t') key.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
      given_[key] = v;
    }
    frames_.emplace_back();
    program_.dialect = options.dialect == GcodeDialect::grbl ? GcodeDialect::grbl : GcodeDialect::linuxcnc;
    // GRBL has one path mode, G61 (exact path, with its junction deviation at corners).
    if (program_.dialect == GcodeDialect::grbl) path_mode_ = Move::PathMode::exact_path;
  }

  // Whether the program ended with M2, M30 or a closing '%' (after run()).
  bool ended() const { return ended_; }

  Program run(const std::string& text);

  // gcode_expr::Parameters
  double numbered(int n) const override;
  double named(const std::string& name) const override;
  bool exists(const std::string& name) const override;

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(program_.source, line_, message);
  }

  bool read_lines(const std::string& text);
  std::string clean(const std::string& raw, std::string& error) const;
  void scan_o_word(SourceLine& l) const;
  void match_structure();
  Block split(const std::string& code);
  double value_at(const std::string& code, std::size_t& pos);
  // An O-word line being run: the value after its keyword, and the lines it names.
  class OWord {
   public:
    OWord(Reader& r, const SourceLine& l) : r_(r), l_(l), pos_(l.rest) {}
    const SourceLine& line() const { return l_; }
    // The [condition] or [value] after the keyword (or the next call argument).
    std::optional<double> value(bool required, const char* what);
    void nothing_after() const;
    // Line i of the file; i < 0 (the construct has no end line) is an error.
    const SourceLine& line_of(int i) const;
    // The end line of an O-word construct, which must exist when the flow jumps to it.
    int end_of(int partner) const;
    bool more() const { return pos_ < l_.code.size(); }
    bool at_bracket() const { return more() && l_.code[pos_] == '['; }
    std::size_t pos() const { return pos_; }

   private:
    Reader& r_;
    const SourceLine& l_;
    std::size_t pos_;
  };

  // Runs an O-word line; returns the next line index.
  int control(int pc);
  int subroutine(OWord& o, int pc);
  int loop(OWord& o, int pc);
  int conditional(OWord& o, int pc);
  // A GRBL system command line: kept as an event.
  void system_command(const SourceLine& l);
  // Returns false when the program ended on this line.
  bool execute(const Block& b);
  Codes modal_groups(const Block& b);
  void check_words(const Block& b, Codes& c);
  void check_arc_words(const Block& b, const Codes& c);
  int integer_word(const Block& b, char c, const char* what) const;
  void feed_speed_tool(const Block& b, const Codes& c);
  void inputs_outputs(const Block& b, const Codes& c);
  void tool_and_spindle(const Block& b, const Codes& c);
  void other_m_codes(const Block& b, const Codes& c);
  void modes(const Block& b, const Codes& c);
  void set_coordinate_system(const Block& b);
  void offsets(const Block& b, const Codes& c);
  void g92_off_or_restore(int g0);
  void motion(const Block& b, const Codes& c);
  bool program_stop(const Codes& c);
  void set_parameters(const Block& b);
  void arc(const Block& b, bool clockwise, const Eigen::Vector3d& end_prog_mm);
  void cycle(const Block& b, int g10, int previous_motion);
  void push(Move move) {
    if (program_.moves.size() >= options_.max_moves)
      fail(fmt::format("more than {} moves: the program is too large", options_.max_moves));
    move.line = line_;
    if (move.kind == Move::Kind::rapid || move.kind == Move::Kind::line || move.kind == Move::Kind::arc) {
      move.path_mode = path_mode_;
      move.path_tolerance_mm = path_tolerance_mm_;
      move.end += offset();
      if (move.kind == Move::Kind::arc) move.center += plane_pair(offset());
    } else {
      move.end = machine_position();
    }
    program_.moves.push_back(move);
  }
  void straight(Move::Kind kind, const Eigen::Vector3d& end_prog_mm) {
    if (kind == Move::Kind::line && feed_mm_per_min_ <= 0)
      fail(is_cycle(motion_g10_) ? "cannot feed with zero feed rate (canned cycle)"
                                 : "cannot do G1 with zero feed rate");
    Move m;
    m.kind = kind;
    m.end = end_prog_mm;
    if (kind == Move::Kind::line) m.feed_mm_per_min = feed_mm_per_min_;
    push(m);
    pos_mm_ = end_prog_mm;
  }
  void event(ProgramEvent e) {
    e.line = line_;
    e.before_move = program_.moves.size();
    program_.events.push_back(e);
  }
  double scale() const { return inches_ ? kMmPerInch : 1.0; }
  // Total work offset (G5x + G92), mm: machine = program + offset.
  Eigen::Vector3d offset() const { return g5x_mm_ + (g92_on_ ? g92_mm_ : Eigen::Vector3d::Zero()); }
  Eigen::Vector3d machine_position() const { return pos_mm_ + offset(); }
  // Changes the offsets keeping the tool where it is on the machine.
  template <class F>
  void change_offsets(F&& f) {
    const Eigen::Vector3d machine = machine_position();
    f();
    pos_mm_ = machine - offset();
  }
  // (first, second) axes of the current plane, as in LinuxCNC's ARC_FEED.
  Eigen::Vector2d plane_pair(const Eigen::Vector3d& p) const {
    switch (plane_) {
      case Move::Plane::xy: return {p.x(), p.y()};
      case Move::Plane::xz: return {p.z(), p.x()};
      case Move::Plane::yz: return {p.y(), p.z()};
    }
    return {p.x(), p.y()};
  }
  int g5x_param(int system, int axis) const { return kFirstG5xParam + 20 * (system - 1) + axis; }
  void load_g5x() {
    const int sys = static_cast<int>(params_[kCoordSystemParam]);
    for (int a = 0; a < 3; ++a) g5x_mm_[a] = params_[static_cast<std::size_t>(g5x_param(sys, a))];
  }

  const GcodeOptions& options_;
  Program program_;
  std::vector<SourceLine> lines_;
  std::map<std::string, int> subs_;  // label -> line index of "sub"
  int line_ = 0;
  std::size_t executed_ = 0;
  bool ended_ = false;
  std::size_t system_commands_ = 0;  // GRBL '$' lines met
  int first_system_line_ = 0;

  // Parameters. Offsets (#5211.., #5221..) are kept in mm.
  std::vector<double> params_;
  std::map<std::string, double> globals_;
  std::map<std::string, double> given_;
  std::vector<Frame> frames_;

  // Modal state, as LinuxCNC starts. pos_mm_ is in program coordinates (offsets removed).
  Eigen::Vector3d pos_mm_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d g5x_mm_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d g92_mm_ = Eigen::Vector3d::Zero();
  bool g92_on_ = false;
  bool inches_ = false;
  bool incremental_ = false;
  bool ij_absolute_ = false;
  Move::Plane plane_ = Move::Plane::xy;
  int motion_g10_ = 0;            // 800 after G80
  double feed_mm_per_min_ = 0.0;
  double spindle_speed_ = 0.0;
  int tool_selected_ = 0, tool_in_spindle_ = 0;
  Move::PathMode path_mode_ = Move::PathMode::blend;
  double path_tolerance_mm_ = 0.0;
  bool retract_r_plane_ = true;   // G99 (LinuxCNC starts with it); false: G98
  // Canned cycles: sticky R, Z, Q (program units), P (s), and the height before the series.
  double cycle_r_ = 0.0, cycle_z_ = 0.0, cycle_q_ = 0.0, cycle_p_s_ = 0.0, cycle_initial_z_ = 0.0;
  bool cycle_series_ = false;
};

// ---------------------------------------------------------------------------------------------
// Parameters

double Reader::numbered(int n) const {
  if (n < 1 || n > 5602) throw gcode_expr::SyntaxError(fmt::format("parameter number #{} out of range (1..5602)", n));
  if (n >= 5420 && n <= 5428) return n - 5420 < 3 ? pos_mm_[n - 5420] / scale() : 0.0;
  if (n == 5400) return tool_in_spindle_;
  if (is_length_param(n)) return params_[static_cast<std::size_t>(n)] / scale();
  return params_[static_cast<std::size_t>(n)];
}

bool Reader::exists(const std::string& name) const {
  if (!name.empty() && name[0] == '_') return globals_.count(name) || given_.count(name);
  return frames_.back().locals.count(name) > 0;
}

double Reader::named(const std::string& name) const {
  if (!name.empty() && name[0] == '_') {
    if (auto it = globals_.find(name); it != globals_.end()) return it->second;
    if (auto it = given_.find(name); it != given_.end()) return it->second;
    if (name == "_x" || name == "_y" || name == "_z") return pos_mm_[name[1] - 'x'] / scale();
    if (name == "_metric") return inches_ ? 0.0 : 1.0;
    if (name == "_imperial") return inches_ ? 1.0 : 0.0;
    if (name == "_absolute") return incremental_ ? 0.0 : 1.0;
    if (name == "_incremental") return incremental_ ? 1.0 : 0.0;
    if (name == "_feed") return feed_mm_per_min_ / scale();
    if (name == "_rpm") return spindle_speed_;
    if (name == "_current_tool") return tool_in_spindle_;
    if (name == "_selected_tool") return tool_selected_;
    if (name == "_call_level") return static_cast<double>(frames_.size() - 1);
    if (name == "_line") return line_;
    if (name == "_value" || name == "_value_returned") return 0.0;
    if (name.rfind("_hal[", 0) == 0 || name.rfind("_ini[", 0) == 0)
      throw gcode_expr::SyntaxError(fmt::format(
          "parameter #<{}> has no value: LinuxCNC reads it from the machine's {}; give it a value "
          "(GcodeOptions::params)",
          excerpt(name), name[1] == 'h' ? "HAL pins" : "INI file"));
    throw gcode_expr::SyntaxError(fmt::format("named parameter #<{}> not defined", excerpt(name)));
  }
  if (auto it = frames_.back().locals.find(name); it != frames_.back().locals.end()) return it->second;
  throw gcode_expr::SyntaxError(fmt::format("named parameter #<{}> not defined", excerpt(name)));
}

void Reader::set_parameters(const Block& b) {
  for (const auto& [n, v] : b.set_numbered) {
    params_[static_cast<std::size_t>(n)] = is_length_param(n) ? v * scale() : v;
  }
  for (const auto& [name, v] : b.set_named) {
    if (name[0] == '_') globals_[name] = v;
    else frames_.back().locals[name] = v;
    const auto& reported = options_.reported_params;
    if (std::find(reported.begin(), reported.end(), name) != reported.end()) {
      ProgramEvent e;
      e.kind = ProgramEvent::Kind::parameter;
      e.text = name;
      e.value = v;
      e.mode = inches_ ? 20 : 21;
      event(e);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Reading lines

// The inside of the first comment "(o=...)" of a raw line (blanks before "o=" allowed), or "".
std::string magic_comment(const std::string& raw) {
  for (std::size_t open = raw.find('('); open != std::string::npos; open = raw.find('(', open + 1)) {
    const std::size_t close = raw.find(')', open);
    if (close == std::string::npos) return {};
    std::size_t k = open + 1;
    while (k < close && (raw[k] == ' ' || raw[k] == '\t')) ++k;
    if (k + 1 < close && (raw[k] == 'o' || raw[k] == 'O') && raw[k + 1] == '=') return raw.substr(open + 1, close - open - 1);
  }
  return {};
}

// Removes comments, spaces and tabs; lower-cases. Nested and unclosed comments set `error`.
std::string Reader::clean(const std::string& raw, std::string& error) const {
  std::string out;
  out.reserve(raw.size());
  bool in_comment = false;
  for (char c : raw) {
    if (in_comment) {
      if (c == ')') in_comment = false;
      else if (c == '(' && error.empty()) error = "nested comment: '(' inside a comment";
      continue;
    }
    if (c == '(') { in_comment = true; continue; }
    if (c == ';') break;
    if (c == ' ' || c == '\t' || c == '\r') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  if (in_comment && error.empty()) error = "unclosed comment: '(' without ')' on the line";
  return out;
}

// Recognises "[/][nNNN]o<label> keyword" and fills l.o, l.label, l.rest.
void Reader::scan_o_word(SourceLine& l) const {
  const std::string& s = l.code;
  std::size_t p = 0;
  if (p < s.size() && s[p] == '/') ++p;
  if (p < s.size() && s[p] == 'n') {
    ++p;
    while (p < s.size() && (std::isdigit(static_cast<unsigned char>(s[p])) || s[p] == '.')) ++p;
  }
  if (p >= s.size() || s[p] != 'o') return;
  ++p;
  if (p < s.size() && s[p] == '<') {
    const std::size_t close = s.find('>', p);
    if (close == std::string::npos) {
      l.o_error = "O-word name not terminated: '>' missing";
      l.o = OKind::call;  // any kind: the error is reported when the line runs
      return;
    }
    l.label = s.substr(p, close - p + 1);
    p = close + 1;
  } else {
    std::size_t q = p;
    while (q < s.size() && std::isdigit(static_cast<unsigned char>(s[q]))) ++q;
    if (q == p) {
      l.o_error = "O word without a number or <name>";
      l.o = OKind::call;
      return;
    }
    l.label = std::to_string(std::stoll(s.substr(p, std::min<std::size_t>(q - p, 15))));
    p = q;
  }
  std::size_t q = p;
  while (q < s.size() && std::isalpha(static_cast<unsigned char>(s[q]))) ++q;
  const std::string word = s.substr(p, q - p);
  l.o = o_kind_of(word);
  l.rest = q;
  if (l.o == OKind::none) {
    l.o = OKind::call;
    l.o_error = word.empty() ? fmt::format("O-word o{} without a keyword (sub, call, while, if, ...)", l.label)
                             : fmt::format("unknown O-word keyword '{}'", excerpt(word));
  }
}

// Pairs the O-word lines of the whole file (LinuxCNC finds them by searching the file).
void Reader::match_structure() {
  std::vector<int> open;
  const auto top_is = [&](OKind k, const std::string& label) {
    return !open.empty() && lines_[static_cast<std::size_t>(open.back())].o == k &&
           lines_[static_cast<std::size_t>(open.back())].label == label;
  };
  for (int i = 0; i < static_cast<int>(lines_.size()); ++i) {
    SourceLine& l = lines_[static_cast<std::size_t>(i)];
    if (l.o == OKind::none || !l.o_error.empty()) continue;
    const auto close = [&](OKind opener, const char* what) {
      if (!top_is(opener, l.label)) {
        l.o_error = fmt::format("{} o{} with no matching opening line", what, l.label);
        return -1;
      }
      const int o = open.back();
      open.pop_back();
      return o;
    };
    switch (l.o) {
      case OKind::sub:
        if (subs_.count(l.label)) l.o_error = fmt::format("subroutine o{} defined twice", l.label);
        else subs_[l.label] = i;
        open.push_back(i);
        break;
      case OKind::do_: case OKind::if_: case OKind::repeat: open.push_back(i); break;
      case OKind::while_:
        if (top_is(OKind::do_, l.label)) {
          l.closes_do = true;
          l.partner = open.back();
          lines_[static_cast<std::size_t>(open.back())].partner = i;
          open.pop_back();
        } else {
          open.push_back(i);
        }
        break;
      case OKind::endsub: case OKind::endwhile: case OKind::endrepeat: {
        const OKind opener = l.o == OKind::endsub ? OKind::sub : l.o == OKind::endwhile ? OKind::while_ : OKind::repeat;
        const int o = close(opener, l.o == OKind::endsub     ? "endsub"
                                    : l.o == OKind::endwhile ? "endwhile"
                                                             : "endrepeat");
        if (o >= 0) {
          l.partner = o;
          lines_[static_cast<std::size_t>(o)].partner = i;
        }
        break;
      }
      case OKind::elseif: case OKind::else_: case OKind::endif: {
        if (!top_is(OKind::if_, l.label)) {
          l.o_error = fmt::format("{} o{} with no matching if",
                                  l.o == OKind::endif   ? "endif"
                                  : l.o == OKind::else_ ? "else"
                                                        : "elseif",
                                  l.label);
          break;
        }
        // Chain: the if (or its last clause) points to this clause.
        int k = open.back();
        while (lines_[static_cast<std::size_t>(k)].partner >= 0) k = lines_[static_cast<std::size_t>(k)].partner;
        if (lines_[static_cast<std::size_t>(k)].o == OKind::else_ && l.o != OKind::endif) {
          l.o_error = fmt::format("{} after else in o{}", l.o == OKind::else_ ? "else" : "elseif", l.label);
          break;
        }
        lines_[static_cast<std::size_t>(k)].partner = i;
        if (l.o == OKind::endif) {
          for (int c = open.back(); c != i; c = lines_[static_cast<std::size_t>(c)].partner)
            lines_[static_cast<std::size_t>(c)].endif = i;
          open.pop_back();
        }
        break;
      }
      case OKind::break_: case OKind::continue_: {
        for (auto it = open.rbegin(); it != open.rend(); ++it) {
          const SourceLine& o = lines_[static_cast<std::size_t>(*it)];
          if (o.label == l.label && (o.o == OKind::while_ || o.o == OKind::do_ || o.o == OKind::repeat)) {
            l.partner = *it;
            break;
          }
        }
        if (l.partner < 0)
          l.o_error = fmt::format("{} o{} outside a loop with that label", l.o == OKind::break_ ? "break" : "continue",
                                  l.label);
        break;
      }
      case OKind::return_:  // returns from whatever subroutine is running, as in LinuxCNC
      case OKind::call: case OKind::none: break;
    }
  }
  // Lines left open keep partner -1: like LinuxCNC, that is an error only when the flow needs
  // the end line (a false condition, a definition to skip, a break).
}

double Reader::value_at(const std::string& code, std::size_t& pos) {
  try {
    return gcode_expr::read_real_value(code, pos, *this);
  } catch (const gcode_expr::SyntaxError& e) {
    fail(e.what());
  }
}

Block Reader::split(const std::string& code) {
  Block b;
  std::size_t pos = 0;
  if (pos < code.size() && code[pos] == '/') ++pos;  // block delete is off: the line runs
  if (pos < code.size() && code[pos] == 'n') {       // line number
    ++pos;
    (void)value_at(code, pos);
  }
  while (pos < code.size()) {
    const char c = code[pos];
    if (c == '#') {
      ++pos;
      std::string name;
      int n = -1;
      try {
        n = gcode_expr::read_parameter_ref(code, pos, *this, name);
      } catch (const gcode_expr::SyntaxError& e) {
        fail(e.what());
      }
      if (pos >= code.size() || code[pos] != '=') fail("parameter without '=' and a value to set it to");
      ++pos;
      const double v = value_at(code, pos);
      if (n < 0) b.set_named.emplace_back(name, v);
      else b.set_numbered.emplace_back(n, v);
      continue;
    }
    if (c == '$') {
      ++pos;
      const double v = value_at(code, pos);
      if (b.spindle) fail("multiple $ words on one line");
      if (std::abs(v - std::round(v)) > 1e-4) fail(fmt::format("spindle number ${:g} is not an integer", v));
      b.spindle = static_cast<int>(std::round(v));
      continue;
    }
    if (c == '[') fail("an expression ([...]) must follow a word letter");
    if (c == '%') fail("'%' is only allowed on a line of its own opening and closing the program");
    if (c == '@' || c == '^') fail("polar coordinates (@ and ^ words) are not supported");
    if (c == 'o') fail("O word must be first on its line");
    if (c == 'n') fail("N word (line number) is only allowed at the start of a line");
    if (!std::isalpha(static_cast<unsigned char>(c))) {
      if (std::isprint(static_cast<unsigned char>(c))) fail(fmt::format("bad character '{}'", c));
      fail(fmt::format("bad character (byte 0x{:02x})", static_cast<unsigned>(static_cast<unsigned char>(c))));
    }
    ++pos;
    const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (pos >= code.size()) fail(fmt::format("{} word without a value", L));
    const double v = value_at(code, pos);
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
        if (std::abs(v - static_cast<double>(m)) > 1e-4 || m > 9999)
          fail(fmt::format("M code M{:g} is not an integer", v));
        if (b.m.size() >= 4) fail("more than 4 M codes on one line");
        b.m.push_back(static_cast<int>(m));
        break;
      }
      case 'x': case 'y': case 'z': case 'i': case 'j': case 'k': case 'r': case 'f': case 's': case 'p':
      case 't': case 'h': case 'l': case 'q': case 'e': case 'd':
        if (b.w(c)) fail(fmt::format("multiple {} words on one line", L));
        b.w(c) = v;
        break;
      case 'a': case 'b': case 'c': case 'u': case 'v': case 'w':
        fail(fmt::format("{} axis words are not supported (only X, Y and Z)", L));
      default: fail(fmt::format("bad character '{}'", c));
    }
  }
  return b;
}

// ---------------------------------------------------------------------------------------------
// The program loop and O-words

// Reads the file into lines (cleaned, O-words recognised); returns whether a closing '%'
// ended it.
bool Reader::read_lines(const std::string& text) {
  const bool grbl = program_.dialect == GcodeDialect::grbl;
  std::size_t start = 0;
  bool percent_mode = false;
  int number = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++number;
    std::string raw = text.substr(start, std::min(end - start, options_.max_line_chars + 2));
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    start = end + 1;
    SourceLine l;
    l.number = number;
    if (raw.size() > options_.max_line_chars) {
      l.error = fmt::format("line is longer than {} characters", options_.max_line_chars);
      lines_.push_back(std::move(l));
      continue;
    }
    const auto first = raw.find_first_not_of(" \t");
    if (first != std::string::npos && raw[first] == '%') {
      if (grbl) continue;  // GRBL: '%' lines are ignored wherever they stand
      // LinuxCNC: '%' lines open and close the program.
      if (number == 1) { percent_mode = true; continue; }
      if (percent_mode) return true;
    }
    if (grbl && first != std::string::npos && raw[first] == '$') {
      l.system_command = true;
      const auto last = raw.find_last_not_of(" \t");
      l.text = raw.substr(first, last - first + 1);
      lines_.push_back(std::move(l));
      continue;
    }
    l.code = clean(raw, l.error);
    if (l.error.empty()) scan_o_word(l);
    if (options_.report_magic_comments) l.magic = magic_comment(raw);
    lines_.push_back(std::move(l));
  }
  return false;
}

void Reader::system_command(const SourceLine& l) {
  ProgramEvent e;
  e.kind = ProgramEvent::Kind::controller_command;
  e.text = l.text.substr(0, 80);
  event(e);
  if (system_commands_++ == 0) first_system_line_ = l.number;
}

Program Reader::run(const std::string& text) {
  options_.validate();
  const bool closing_percent = read_lines(text);
  match_structure();

  int pc = 0;
  while (pc < static_cast<int>(lines_.size())) {
    const SourceLine& l = lines_[static_cast<std::size_t>(pc)];
    line_ = l.number;
    if (++executed_ > options_.max_executed_lines)
      fail(fmt::format("more than {} lines executed: an endless loop?", options_.max_executed_lines));
    if (!l.error.empty()) fail(l.error);
    if (l.system_command) {
      system_command(l);
      ++pc;
      continue;
    }
    if (l.o != OKind::none) {
      pc = control(pc);
      continue;
    }
    if (!l.magic.empty()) {
      ProgramEvent e;
      e.kind = ProgramEvent::Kind::magic_comment;
      e.text = l.magic;
      e.mode = inches_ ? 20 : 21;
      event(e);
    }
    const Block b = split(l.code);
    set_parameters(b);
    if (!execute(b)) {
      ended_ = true;
      program_.ends_with_program_end = true;
      break;
    }
    ++pc;
  }
  if (!ended_ && closing_percent) ended_ = true;
  if (!ended_ && frames_.size() > 1) fail("file ended inside a subroutine call");
  const bool grbl = program_.dialect == GcodeDialect::grbl;
  if (system_commands_ > 0)
    program_.warnings.push_back(fmt::format("{}:{}: {} GRBL system command line{} ($...) kept as events and otherwise "
                                            "ignored",
                                            program_.source, first_system_line_, system_commands_,
                                            system_commands_ == 1 ? "" : "s"));
  if (!ended_ && !grbl) {
    if (options_.require_program_end) fail("file ended with no percent sign or program end (M2 or M30)");
    program_.warnings.push_back(fmt::format(
        "{}: the program has no end (M2, M30 or a closing %): read to the end of the file", program_.source));
  }
  return std::move(program_);
}

std::optional<double> Reader::OWord::value(bool required, const char* what) {
  const std::string& s = l_.code;
  if (pos_ >= s.size()) {
    if (required) r_.fail(fmt::format("o{} {}: '[' and a value expected", l_.label, what));
    return std::nullopt;
  }
  if (s[pos_] != '[') r_.fail(fmt::format("o{} {}: '[' expected after the keyword", l_.label, what));
  try {
    return gcode_expr::read_expression(s, pos_, r_);
  } catch (const gcode_expr::SyntaxError& e) {
    r_.fail(e.what());
  }
}

void Reader::OWord::nothing_after() const {
  if (pos_ < l_.code.size()) r_.fail(fmt::format("unexpected '{}' after the O-word", l_.code.substr(pos_, 12)));
}

const SourceLine& Reader::OWord::line_of(int i) const {
  if (i < 0) r_.fail(fmt::format("o{} is never closed (no matching end line)", l_.label));
  return r_.lines_[static_cast<std::size_t>(i)];
}

int Reader::OWord::end_of(int partner) const {
  if (partner < 0) r_.fail(fmt::format("o{} is never closed (no matching end line)", l_.label));
  return partner;
}

// Runs an O-word line: its keyword's family does the work.
int Reader::control(int pc) {
  const SourceLine& l = lines_[static_cast<std::size_t>(pc)];
  if (!l.o_error.empty()) fail(l.o_error);
  OWord o(*this, l);
  switch (l.o) {
    case OKind::sub: case OKind::endsub: case OKind::return_: case OKind::call: return subroutine(o, pc);
    case OKind::do_: case OKind::while_: case OKind::endwhile: case OKind::repeat: case OKind::endrepeat:
    case OKind::break_: case OKind::continue_:
      return loop(o, pc);
    case OKind::if_: case OKind::elseif: case OKind::else_: case OKind::endif: return conditional(o, pc);
    case OKind::none: break;
  }
  return pc + 1;
}

// sub (skipped where it stands), call (arguments into #1..#30, a new frame), endsub and
// return (the caller's #1..#30 back, #<_value>).
int Reader::subroutine(OWord& o, int pc) {
  const SourceLine& l = o.line();
  if (l.o == OKind::sub) {
    o.nothing_after();
    return o.end_of(l.partner) + 1;  // definitions are skipped when met; a call jumps in
  }
  if (l.o == OKind::endsub || l.o == OKind::return_) {
    const std::optional<double> v = o.value(false, l.o == OKind::return_ ? "return" : "endsub");
    o.nothing_after();
    if (frames_.size() < 2)
      fail(fmt::format("{} o{} reached outside a subroutine call", l.o == OKind::return_ ? "return" : "endsub", l.label));
    const Frame done = std::move(frames_.back());
    frames_.pop_back();
    for (int i = 0; i < 30; ++i) params_[static_cast<std::size_t>(i + 1)] = done.saved[static_cast<std::size_t>(i)];
    globals_["_value"] = v.value_or(0.0);
    globals_["_value_returned"] = v ? 1.0 : 0.0;
    return done.return_pc;
  }
  std::vector<double> args;
  while (o.more()) {
    if (!o.at_bracket())
      fail(fmt::format("o{} call: arguments are [values], found '{}'", l.label, l.code.substr(o.pos(), 12)));
    args.push_back(*o.value(true, "call"));
  }
  if (args.size() > 30) fail(fmt::format("o{} call: more than 30 arguments", l.label));
  const auto it = subs_.find(l.label);
  if (it == subs_.end())
    fail(fmt::format("subroutine o{} is not defined in this file (subroutines from other files are not supported)",
                     l.label));
  if (static_cast<int>(frames_.size()) > kMaxCallDepth)
    fail(fmt::format("subroutine calls nested deeper than {}", kMaxCallDepth));
  Frame f;
  f.return_pc = pc + 1;
  for (int i = 0; i < 30; ++i) {
    f.saved[static_cast<std::size_t>(i)] = params_[static_cast<std::size_t>(i + 1)];
    params_[static_cast<std::size_t>(i + 1)] = i < static_cast<int>(args.size()) ? args[static_cast<std::size_t>(i)] : 0.0;
  }
  frames_.push_back(std::move(f));
  return it->second + 1;
}

// do / while / endwhile, repeat / endrepeat, break, continue.
int Reader::loop(OWord& o, int pc) {
  const SourceLine& l = o.line();
  switch (l.o) {
    case OKind::do_: o.nothing_after(); return pc + 1;
    case OKind::while_: {
      const bool go_on = *o.value(true, "while") != 0.0;
      o.nothing_after();
      if (l.closes_do) return go_on ? l.partner + 1 : pc + 1;
      return go_on ? pc + 1 : o.end_of(l.partner) + 1;
    }
    case OKind::endwhile: o.nothing_after(); return l.partner;
    case OKind::repeat: {
      const double n = *o.value(true, "repeat");
      o.nothing_after();
      const long long count = static_cast<long long>(std::llround(std::clamp(n, -1.0, 1e12)));
      if (count <= 0) return o.end_of(l.partner) + 1;
      frames_.back().repeats[pc] = count - 1;
      return pc + 1;
    }
    case OKind::endrepeat: {
      o.nothing_after();
      long long& left = frames_.back().repeats[l.partner];
      if (left > 0) {
        --left;
        return l.partner + 1;
      }
      return pc + 1;
    }
    default: break;
  }
  // break / continue
  o.nothing_after();
  const SourceLine& loop_line = o.line_of(l.partner);
  if (l.o == OKind::break_) return o.end_of(loop_line.partner) + 1;
  if (loop_line.o == OKind::while_) return l.partner;  // test again
  return o.end_of(loop_line.partner);                  // do: its closing while; repeat: endrepeat
}

// if / elseif / else / endif: the first clause whose condition holds runs; a clause reached
// from the one before it (that ran) jumps past the endif.
int Reader::conditional(OWord& o, int pc) {
  const SourceLine& l = o.line();
  if (l.o == OKind::elseif || l.o == OKind::else_) return o.end_of(l.endif) + 1;  // the branch before it ran
  if (l.o == OKind::endif) {
    o.nothing_after();
    return pc + 1;
  }
  bool taken = *o.value(true, "if") != 0.0;
  o.nothing_after();
  int at = pc;
  while (!taken) {
    at = o.line_of(at).partner;
    const SourceLine& c = o.line_of(at);
    if (c.o != OKind::elseif) return at + 1;  // else: its body; endif: after it
    line_ = c.number;
    std::size_t p = c.rest;
    if (p >= c.code.size() || c.code[p] != '[') fail(fmt::format("o{} elseif: '[' expected after the keyword", c.label));
    try {
      taken = gcode_expr::read_expression(c.code, p, *this) != 0.0;
    } catch (const gcode_expr::SyntaxError& e) {
      fail(e.what());
    }
  }
  return at + 1;
}

// ---------------------------------------------------------------------------------------------
// One block, in LinuxCNC's order of execution. execute() reads the block's codes by modal
// group (modal_groups), checks that every word has a code to use it (check_words), then runs
// the groups in LinuxCNC's order, one function each.

bool Reader::execute(const Block& b) {
  Codes c = modal_groups(b);
  check_words(b, c);
  feed_speed_tool(b, c);
  inputs_outputs(b, c);
  tool_and_spindle(b, c);
  other_m_codes(b, c);
  modes(b, c);
  offsets(b, c);
  motion(b, c);
  return program_stop(c);
}

// Modal group checks: the G and M codes of the block by group.
Codes Reader::modal_groups(const Block& b) {
  Codes c;
  c.g.fill(-1);
  c.m.fill(-1);
  for (int g : b.g10) {
    int group = g_group(g);
    if (group < 0) {
      const auto& refused = refused_g_codes();
      const auto it = refused.find(g);
      if (it != refused.end()) fail(fmt::format("{} ({}) is not supported", g_name(g), it->second));
      fail(fmt::format("unknown G code {}", g_name(g)));
    }
    int& seen = c.g[static_cast<std::size_t>(group)];
    // G80 beside another motion code gives way to it, as in LinuxCNC.
    if (group == 1 && (g == 800 || seen == 800)) {
      if (seen < 0 || seen == 800) seen = g;
      continue;
    }
    if (seen >= 0)
      fail(fmt::format("two G codes from the same modal group on one line: {} and {}", g_name(seen), g_name(g)));
    seen = g;
  }
  for (int m : b.m) {
    const int group = m_group(m);
    if (group < 0) {
      if (const char* name = refused_m_code(m)) fail(fmt::format("M{} ({}) is not supported", m, name));
      fail(fmt::format("unknown M code M{}", m));
    }
    if (c.m[static_cast<std::size_t>(group)] >= 0)
      fail(fmt::format("two M codes from the same modal group on one line: M{} and M{}",
                       c.m[static_cast<std::size_t>(group)], m));
    c.m[static_cast<std::size_t>(group)] = m;
  }
  return c;
}

// Words without a code that uses them; the motion the line performs.
void Reader::check_words(const Block& b, Codes& c) {
  c.has_axis = b.w('x') || b.w('y') || b.w('z');
  const int g0 = c.g[0];
  c.g0_uses_axes = g0 == 100 || g0 == 280 || g0 == 300 || g0 == 520 || g0 == 920;
  const int g_motion = c.g[1];
  if (g_motion == 800 && c.has_axis && !c.g0_uses_axes) fail("axis words (X, Y, Z) with G80");
  if (c.g0_uses_axes && g_motion >= 0 && g_motion != 800)
    fail(fmt::format("cannot use two G codes that both use axis values: {} and {}", g_name(g0), g_name(g_motion)));
  if (g_motion >= 0 && g_motion != 800) c.motion = g_motion;
  else if (g_motion < 0 && c.has_axis && !c.g0_uses_axes) {
    if (motion_g10_ == 800) fail("axis words (X, Y, Z) without a motion code G0..G3 to use them (motion mode is G80)");
    c.motion = motion_g10_;
  }
  c.is_arc = c.motion == 20 || c.motion == 30;
  c.cycle = c.motion >= 0 && is_cycle(c.motion);
  c.plane = c.g[2] == 180 ? Move::Plane::xz : c.g[2] == 190 ? Move::Plane::yz : c.g[2] == 170 ? Move::Plane::xy : plane_;
  const int m5 = c.m[5], m9 = c.m[9], m10 = c.m[10];
  if (c.is_arc) {
    const char missing = c.plane == Move::Plane::xy ? 'k' : c.plane == Move::Plane::xz ? 'j' : 'i';
    const char* pname = c.plane == Move::Plane::xy ? "XY" : c.plane == Move::Plane::xz ? "XZ" : "YZ";
    if (b.w(missing))
      fail(fmt::format("{} word given for an arc in the {} plane", static_cast<char>(std::toupper(missing)), pname));
  } else {
    if (b.w('i')) fail("I word with no G2 or G3 to use it");
    if (b.w('j')) fail("J word with no G2 or G3 to use it");
    if (b.w('k')) fail("K word with no G2 or G3 to use it");
  }
  if (b.w('r') && !c.is_arc && !c.cycle && g0 != 100) fail("R word with no G2, G3, G10 or canned cycle to use it");
  const bool p_used = c.is_arc || g0 == 40 || g0 == 100 || c.g[13] == 640 || c.motion == 820 || c.motion == 890 ||
                      (m5 >= 62 && m5 <= 66) || m9 >= 0 || m10 >= 0;
  if (b.w('p') && !p_used)
    fail("P word with no code that uses it (G2/G3, G4, G10, G64, G82, G89, M50-M53, M62-M66, M100-M199)");
  if (b.w('q') && !(c.g[13] == 640 || c.motion == 730 || c.motion == 830 || m5 == 66 || m5 == 67 || m5 == 68 ||
                    c.m[6] == 61 || m10 >= 0))
    fail("Q word with no code that uses it (G64, G73, G83, M61, M66-M68, M100-M199)");
  if (b.w('l') && !(g0 == 100 || c.cycle || m5 == 66)) fail("L word with no G10, canned cycle or M66 to use it");
  if (b.w('e') && !(m5 == 66 || m5 == 67 || m5 == 68))
    fail("E word with no M66, M67 or M68 to use it (and 'E' is a word letter, not an exponent: write 1000, not 1e3)");
  if (b.w('h') && c.g[8] != 430) fail("H word with no G43 to use it");
  if (b.w('d')) fail("D words (cutter compensation) are not supported");
  if (c.is_arc) check_arc_words(b, c);
  if (b.spindle) {
    const int n = *b.spindle;
    const bool all = n == -1 && c.m[7] == 5;
    if (!all && (n < 0 || n >= options_.spindle_count))
      fail(fmt::format("invalid spindle ($) number ${}: this machine has {} spindle{} ($0{})", n,
                       options_.spindle_count, options_.spindle_count == 1 ? "" : "s",
                       options_.spindle_count == 1 ? "" : fmt::format("..${}", options_.spindle_count - 1)));
  }
}

// The centre or radius words and the P word (turns) of an arc.
void Reader::check_arc_words(const Block& b, const Codes& c) {
  const char first = c.plane == Move::Plane::xy ? 'i' : c.plane == Move::Plane::xz ? 'k' : 'j';
  const char second = c.plane == Move::Plane::xy ? 'j' : c.plane == Move::Plane::xz ? 'i' : 'k';
  if (b.w('r') && (b.w(first) || b.w(second))) fail("mixed radius (R) and centre (I, J, K) format for an arc");
  if (!b.w('r') && !b.w(first) && !b.w(second)) fail("R, I, J and K words all missing for an arc");
  if (!b.w('p')) return;
  const double p = *b.w('p');
  if (std::abs(p - std::round(p)) > 1e-4) fail(fmt::format("P word on G2/G3 is not an integer: P{:g}", p));
  if (std::round(p) < 1) fail(fmt::format("P word on G2/G3 must be 1 or greater (number of turns), got P{:g}", p));
  if (std::round(p) > options_.max_arc_turns)
    fail(fmt::format("P{:g} asks for more than {} turns on one arc", p, options_.max_arc_turns));
}

int Reader::integer_word(const Block& b, char c, const char* what) const {
  const double v = *b.w(c);
  if (std::abs(v - std::round(v)) > 1e-4 || v < 0)
    fail(fmt::format("{} word {}{:g} must be a whole number >= 0 ({})", static_cast<char>(std::toupper(c)),
                     static_cast<char>(std::toupper(c)), v, what));
  return static_cast<int>(std::round(std::min(v, 1e9)));
}

// G94 (which resets the feed), F, S, T.
void Reader::feed_speed_tool(const Block& b, const Codes& c) {
  if (c.g[5] == 940) feed_mm_per_min_ = 0.0;  // G94 resets the feed, as LinuxCNC does
  if (b.w('f')) {
    if (*b.w('f') < 0) fail("negative F word (feed rate)");
    feed_mm_per_min_ = *b.w('f') * scale();
  }
  if (b.w('s')) {
    if (*b.w('s') < 0) fail("negative S word (spindle speed)");
    spindle_speed_ = *b.w('s');
  }
  if (b.w('t')) {
    tool_selected_ = integer_word(b, 't', "tool number");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_select;
    e.number = tool_selected_;
    event(e);
  }
}

// M62..M68: outputs and inputs.
void Reader::inputs_outputs(const Block& b, const Codes& c) {
  const int m5 = c.m[5];
  if (m5 >= 62 && m5 <= 65) {
    if (!b.w('p')) fail(fmt::format("M{} needs a P word (output number)", m5));
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::digital_output;
    e.number = integer_word(b, 'p', "output number");
    e.value = (m5 == 62 || m5 == 64) ? 1.0 : 0.0;
    e.synchronized = m5 == 62 || m5 == 63;
    event(e);
  } else if (m5 == 66) {
    if (!b.w('p') && !b.w('e')) fail("M66 needs a P (digital) or E (analog) input number");
    if (b.w('p') && b.w('e')) fail("M66 takes a P or an E word, not both");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::wait_input;
    e.number = b.w('p') ? integer_word(b, 'p', "input number") : integer_word(b, 'e', "input number");
    e.mode = b.w('l') ? integer_word(b, 'l', "wait mode 0..4") : 0;
    if (e.mode > 4) fail(fmt::format("M66 wait mode L{} must be 0..4", e.mode));
    e.value = b.w('q').value_or(0.0);
    if (e.value < 0) fail("M66 timeout Q must be >= 0 seconds");
    event(e);
  } else if (m5 == 67 || m5 == 68) {
    if (!b.w('e') || !b.w('q')) fail(fmt::format("M{} needs an E word (output number) and a Q word (value)", m5));
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::analog_output;
    e.number = integer_word(b, 'e', "output number");
    e.value = *b.w('q');
    e.synchronized = m5 == 67;
    event(e);
  }
}

// M6 / M61 (tool change), then M3 / M4 / M5 (torch or spindle).
void Reader::tool_and_spindle(const Block& b, const Codes& c) {
  if (c.m[6] == 6) {
    // LinuxCNC stops the spindle for the change.
    Move m;
    m.kind = Move::Kind::torch_off;
    push(m);
    tool_in_spindle_ = tool_selected_;
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_change;
    e.number = tool_in_spindle_;
    event(e);
  } else if (c.m[6] == 61) {
    if (!b.w('q')) fail("M61 needs a Q word (tool number)");
    tool_in_spindle_ = tool_selected_ = integer_word(b, 'q', "tool number");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_change;
    e.number = tool_in_spindle_;
    event(e);
  }
  if (c.m[7] == 3 || c.m[7] == 4) {
    Move m;
    m.kind = Move::Kind::torch_on;
    m.spindle_speed = spindle_speed_;
    m.spindle = b.spindle.value_or(0);
    push(m);
  } else if (c.m[7] == 5) {
    Move m;
    m.kind = Move::Kind::torch_off;
    m.spindle = b.spindle.value_or(0);
    push(m);
  }
}

// M7-M9 (coolant), M48-M53 (overrides), M100-M199 (user M codes), then G4 (dwell).
void Reader::other_m_codes(const Block& b, const Codes& c) {
  if (c.m[8] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::coolant;
    e.number = c.m[8];
    event(e);
  }
  if (c.m[9] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::feed_override;
    e.number = c.m[9];
    e.value = b.w('p').value_or(1.0);
    event(e);
  }
  if (c.m[10] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::user_m_code;
    e.number = c.m[10];
    e.value = b.w('p').value_or(0.0);
    e.value2 = b.w('q').value_or(0.0);
    event(e);
  }
  if (c.g[0] == 40) {
    if (!b.w('p') || *b.w('p') < 0) fail("dwell time missing with G4 (P seconds, 0 or more)");
    Move m;
    m.kind = Move::Kind::dwell;
    m.seconds = *b.w('p');
    push(m);
  }
}

// Plane, units, tool length offset, coordinate system, path control, distance modes and the
// canned cycles' retract mode.
void Reader::modes(const Block& b, const Codes& c) {
  if (c.g[2] >= 0) plane_ = c.plane;
  if (c.g[6] == 200) inches_ = true;
  if (c.g[6] == 210) inches_ = false;
  if (c.g[8] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_length_offset;
    e.number = c.g[8] == 490 ? -1 : b.w('h') ? integer_word(b, 'h', "tool number") : tool_in_spindle_;
    event(e);
  }
  if (c.g[12] >= 0) {
    const int g = c.g[12];
    const int system = g <= 590 ? (g - 540) / 10 + 1 : 6 + (g - 590);
    change_offsets([&] {
      params_[kCoordSystemParam] = system;
      load_g5x();
    });
  }
  if (c.g[13] >= 0) {
    const int g = c.g[13];
    path_mode_ = g == 610 ? Move::PathMode::exact_path : g == 611 ? Move::PathMode::exact_stop : Move::PathMode::blend;
    if (g == 640) {
      if (b.w('p') && *b.w('p') < 0) fail("G64 P (path tolerance) must be >= 0");
      if (b.w('q') && *b.w('q') < 0) fail("G64 Q (naive CAM tolerance) must be >= 0");
      path_tolerance_mm_ = b.w('p').value_or(0.0) * scale();
    } else {
      path_tolerance_mm_ = 0.0;
    }
  }
  if (c.g[3] == 900) incremental_ = false;
  if (c.g[3] == 910) incremental_ = true;
  if (c.g[4] == 901) ij_absolute_ = true;
  if (c.g[4] == 911) ij_absolute_ = false;
  if (c.g[10] >= 0) retract_r_plane_ = c.g[10] == 990;
}

// G10 L2 / L20: a coordinate system's offsets.
void Reader::set_coordinate_system(const Block& b) {
  if (!b.w('l')) fail("G10 needs an L word (L2 or L20 set a coordinate system)");
  const int l = integer_word(b, 'l', "G10 L");
  if (l == 1 || l == 10 || l == 11) fail(fmt::format("G10 L{} (setting tool table data) is not supported", l));
  if (l != 2 && l != 20) fail(fmt::format("G10 L{} is not a G10 code LinuxCNC knows (L1, L2, L10, L11, L20)", l));
  if (!b.w('p')) fail(fmt::format("G10 L{} needs a P word (coordinate system 0..9)", l));
  int p = integer_word(b, 'p', "coordinate system");
  if (p > 9) fail(fmt::format("G10 L{} P{}: the coordinate system must be 0..9", l, p));
  if (b.w('r') && *b.w('r') != 0.0) fail("G10 L2 R (rotation of a coordinate system) is not supported");
  const int current = static_cast<int>(params_[kCoordSystemParam]);
  if (p == 0) p = current;
  for (int a = 0; a < 3; ++a) {
    const auto& v = b.w(kAxes[a]);
    if (!v) continue;
    double off = *v * scale();
    if (l == 20) off = machine_position()[a] - (g92_on_ ? g92_mm_[a] : 0.0) - off;
    params_[static_cast<std::size_t>(g5x_param(p, a))] = off;
  }
  if (p == current) change_offsets([&] { load_g5x(); });
}

// The non-modal codes that set offsets or go through stored positions: G10, G28 / G30,
// G28.1 / G30.1, G92, G52, G92.1 / G92.2 / G92.3.
void Reader::offsets(const Block& b, const Codes& c) {
  const int g0 = c.g[0];
  if (g0 == 100) {
    set_coordinate_system(b);
  } else if (g0 == 280 || g0 == 300) {
    // Through the point the axis words give (if any) to the stored position (#5161.. for G28,
    // #5181.. for G30, machine coordinates), moving only the named axes, or all without any.
    const int base = g0 == 280 ? kFirstG28Param : kFirstG30Param;
    Eigen::Vector3d via = pos_mm_;
    for (int a = 0; a < 3; ++a)
      if (const auto& v = b.w(kAxes[a])) via[a] = incremental_ ? pos_mm_[a] + *v * scale() : *v * scale();
    straight(Move::Kind::rapid, via);
    Eigen::Vector3d home = via;
    for (int a = 0; a < 3; ++a)
      if (!c.has_axis || b.w(kAxes[a])) home[a] = params_[static_cast<std::size_t>(base + a)] - offset()[a];
    straight(Move::Kind::rapid, home);
  } else if (g0 == 281 || g0 == 301) {
    const int base = g0 == 281 ? kFirstG28Param : kFirstG30Param;
    const Eigen::Vector3d machine = machine_position();
    for (int a = 0; a < 3; ++a) params_[static_cast<std::size_t>(base + a)] = machine[a];
  } else if (g0 == 920) {
    if (!c.has_axis) fail("G92 needs at least one axis word");
    change_offsets([&] {
      const Eigen::Vector3d machine = machine_position();
      for (int a = 0; a < 3; ++a) {
        if (const auto& v = b.w(kAxes[a])) g92_mm_[a] = machine[a] - g5x_mm_[a] - *v * scale();
        else if (!g92_on_) g92_mm_[a] = 0.0;
        params_[static_cast<std::size_t>(kFirstG92Param + a)] = g92_mm_[a];
      }
      g92_on_ = true;
      params_[5210] = 1;
    });
  } else if (g0 == 520) {
    // G52: the local offset, which LinuxCNC keeps in the G92 offset, set to the values given.
    change_offsets([&] {
      if (!g92_on_) g92_mm_.setZero();
      for (int a = 0; a < 3; ++a) {
        if (const auto& v = b.w(kAxes[a])) g92_mm_[a] = *v * scale();
        params_[static_cast<std::size_t>(kFirstG92Param + a)] = g92_mm_[a];
      }
      g92_on_ = true;
      params_[5210] = 1;
    });
  } else if (g0 == 921 || g0 == 922 || g0 == 923) {
    g92_off_or_restore(g0);
  }
}

// G92.1 (offsets off and cleared), G92.2 (off, kept), G92.3 (restored from the parameters).
void Reader::g92_off_or_restore(int g0) {
  change_offsets([&] {
    if (g0 == 923) {
      for (int a = 0; a < 3; ++a) g92_mm_[a] = params_[static_cast<std::size_t>(kFirstG92Param + a)];
      g92_on_ = true;
      params_[5210] = 1;
      return;
    }
    g92_on_ = false;
    params_[5210] = 0;
    if (g0 == 921) {
      g92_mm_.setZero();
      for (int a = 0; a < 9; ++a) params_[static_cast<std::size_t>(kFirstG92Param + a)] = 0.0;
    }
  });
}

// G0 / G1 / G2 / G3 / the canned cycles, with G53 for the line.
void Reader::motion(const Block& b, const Codes& c) {
  const int previous_motion = motion_g10_;
  if (c.g[1] >= 0) motion_g10_ = c.g[1];
  if ((c.motion >= 0 && !is_cycle(c.motion)) || c.g[1] == 800) cycle_series_ = false;
  if (c.motion < 0) return;
  const int g0 = c.g[0];
  if (g0 == 530) {
    if (c.motion != 0 && c.motion != 10) fail("G53 is allowed only with G0 or G1");
    if (incremental_) fail("G53 cannot be used in incremental distance mode (G91)");
  }
  Eigen::Vector3d end = pos_mm_;
  if (!c.cycle) {
    for (int a = 0; a < 3; ++a) {
      const auto& v = b.w(kAxes[a]);
      if (!v) continue;
      if (g0 == 530) end[a] = *v * scale() - offset()[a];
      else end[a] = incremental_ ? pos_mm_[a] + *v * scale() : *v * scale();
    }
  }
  if (c.motion == 0) {
    straight(Move::Kind::rapid, end);
  } else if (c.motion == 10) {
    straight(Move::Kind::line, end);
  } else if (c.is_arc) {
    if (feed_mm_per_min_ <= 0) fail(fmt::format("cannot make an arc (G{}) with zero feed rate", c.motion / 10));
    arc(b, c.motion == 20, end);
    pos_mm_ = end;
  } else {
    cycle(b, c.motion, previous_motion);
  }
}

// M0 / M1 are kept; M2 / M30 end the program (returns false).
bool Reader::program_stop(const Codes& c) {
  const int m4 = c.m[4];
  if (m4 == 0 || m4 == 1) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::program_stop;
    e.number = m4;
    event(e);
  }
  return !(m4 == 2 || m4 == 30);
}

// Drilling cycles G73, G81, G82, G83, G85, G89 in the XY plane, expanded as LinuxCNC does
// (interp_convert.cc, convert_cycle_xy): up to R first when the series began below it; the
// first hole reached at the current height and then down to R, later ones at the clearance
// height; the cycle's feeds; back up to R (G99) or to the height where the series began
// (G98). In G91, R is relative to that height, Z to R, and L repeats the X/Y increments.
void Reader::cycle(const Block& b, int g10, int previous_motion) {
  const bool first_in_series = previous_motion != g10;
  if (plane_ != Move::Plane::xy)
    fail(fmt::format("{} (canned cycle) outside the XY plane is not supported", g_name(g10)));
  // As LinuxCNC, the arithmetic is in program units (pecks are counted in them).
  const double s = scale();
  const double current_z = pos_mm_.z() / s;
  if (first_in_series && !b.w('r'))
    fail(fmt::format("R clearance plane unspecified in the canned cycle {}", g_name(g10)));
  if (first_in_series && !b.w('z')) fail(fmt::format("Z value unspecified in the canned cycle {}", g_name(g10)));
  // R and Z are kept as written (relative in G91) for the cycles that follow.
  if (b.w('r')) cycle_r_ = *b.w('r');
  if (b.w('z')) cycle_z_ = *b.w('z');
  // The height when the series of cycles began (LinuxCNC's cycle_il); a motion that is not a
  // cycle ends the series.
  if (!cycle_series_) {
    cycle_initial_z_ = current_z;
    cycle_series_ = true;
  }
  double old_cc = cycle_initial_z_;
  const double r = incremental_ ? cycle_r_ + old_cc : cycle_r_;
  const double bottom = incremental_ ? r + cycle_z_ : cycle_z_;
  if (r < bottom) fail(fmt::format("R value ({:g}) less than Z value ({:g}) in the canned cycle", r, bottom));
  int repeats = 1;
  if (b.w('l')) {
    const double l = *b.w('l');
    if (std::abs(l - std::round(l)) > 1e-4 || l < 0) fail(fmt::format("L word L{:g} must be a whole number >= 0", l));
    repeats = static_cast<int>(std::min(std::round(l), 1e6));
  }
  if (g10 == 730 || g10 == 830) {
    if (b.w('q')) cycle_q_ = *b.w('q');
    else if (first_in_series) fail(fmt::format("Q word missing with {}", g_name(g10)));
    if (!(cycle_q_ > 0)) fail(fmt::format("Q (peck depth) must be > 0 with {}", g_name(g10)));
    if ((r - bottom) / cycle_q_ > 1e6) fail(fmt::format("{} would make more than a million pecks", g_name(g10)));
  }
  if (g10 == 820 || g10 == 890) {
    if (b.w('p')) cycle_p_s_ = *b.w('p');
    else if (first_in_series) fail(fmt::format("dwell time P word missing with {}", g_name(g10)));
    if (cycle_p_s_ < 0) fail("P (dwell) must be >= 0 in a canned cycle");
  }
  double current_cc = current_z;
  if (old_cc < r) {
    straight(Move::Kind::rapid, Eigen::Vector3d(pos_mm_.x(), pos_mm_.y(), r * s));
    old_cc = current_cc = r;
  }
  const double clear = retract_r_plane_ ? r : old_cc;
  const double rapid_delta = inches_ ? 0.010 : 0.254;
  double x = pos_mm_.x(), y = pos_mm_.y(), dx = 0, dy = 0;
  if (incremental_) {
    dx = b.w('x').value_or(0.0) * s;
    dy = b.w('y').value_or(0.0) * s;
  } else {
    if (b.w('x')) x = *b.w('x') * s;
    if (b.w('y')) y = *b.w('y') * s;
  }
  const auto at = [&](double z) { return Eigen::Vector3d(x, y, z * s); };
  const auto dwell = [&](double seconds) {
    Move m;
    m.kind = Move::Kind::dwell;
    m.seconds = seconds;
    push(m);
  };
  for (int k = 0; k < repeats; ++k) {
    x += dx;
    y += dy;
    // The first hole is reached at the current height, the others at the clearance height.
    if (k == 0 && current_cc > r) {
      straight(Move::Kind::rapid, at(current_cc));
      straight(Move::Kind::rapid, at(r));
    } else {
      straight(Move::Kind::rapid, at(clear));
      if (clear > r) straight(Move::Kind::rapid, at(r));
    }
    switch (g10) {
      case 810: case 820:
        straight(Move::Kind::line, at(bottom));
        if (g10 == 820) dwell(cycle_p_s_);
        straight(Move::Kind::rapid, at(clear));
        break;
      case 730: case 830:
        for (double depth = r - cycle_q_; depth > bottom; depth -= cycle_q_) {
          straight(Move::Kind::line, at(depth));
          if (g10 == 830) straight(Move::Kind::rapid, at(r));
          straight(Move::Kind::rapid, at(depth + rapid_delta));
        }
        straight(Move::Kind::line, at(bottom));
        straight(Move::Kind::rapid, at(clear));
        break;
      case 850:
        straight(Move::Kind::line, at(bottom));
        straight(Move::Kind::line, at(r));
        straight(Move::Kind::rapid, at(clear));
        break;
      case 890:
        straight(Move::Kind::line, at(bottom));
        dwell(cycle_p_s_);
        straight(Move::Kind::line, at(clear));
        break;
      default: fail(fmt::format("{} (canned cycle) is not supported", g_name(g10)));
    }
  }
}

void Reader::arc(const Block& b, bool clockwise, const Eigen::Vector3d& end_mm) {
  // LinuxCNC does this arithmetic in program units and in the plane's own axes; so do we.
  const double s = scale();
  const double radius_tolerance = inches_ ? kRadiusToleranceInch : kRadiusToleranceInch * kMmPerInch;
  const double spiral_abs_tolerance = inches_ ? kSpiralAbsToleranceInch : kSpiralAbsToleranceMm;
  const Eigen::Vector2d start = plane_pair(pos_mm_) / s, finish = plane_pair(end_mm) / s;
  const double x0 = start.x(), y0 = start.y();
  const double x1 = finish.x(), y1 = finish.y();
  const char first = plane_ == Move::Plane::xy ? 'i' : plane_ == Move::Plane::xz ? 'k' : 'j';
  const char second = plane_ == Move::Plane::xy ? 'j' : plane_ == Move::Plane::xz ? 'i' : 'k';
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
    const double i = b.w(first).value_or(0.0), j = b.w(second).value_or(0.0);
    // Offsets are in program units; with G90.1 they are absolute centre coordinates (of the
    // work coordinate system; no G91 offset applies to them).
    cx = ij_absolute_ ? i : x0 + i;
    cy = ij_absolute_ ? j : y0 + j;
    const double r1 = std::hypot(cx - x0, cy - y0);
    const double r2 = std::hypot(cx - x1, cy - y1);
    const auto where = [&] {
      return fmt::format("start=({:.4f},{:.4f}) center=({:.4f},{:.4f}) end=({:.4f},{:.4f}) r1={:.4f} r2={:.4f}", x0, y0,
                         cx, cy, x1, y1, r1, r2);
    };
    if (r1 < radius_tolerance || r2 < radius_tolerance) fail("zero-radius arc: " + where());
    const double abs_err = std::abs(r1 - r2);
    const double rel_err = abs_err / std::max(r1, r2);
    if (abs_err > spiral_abs_tolerance * 100.0 ||
        (rel_err > kSpiralRelativeTolerance && abs_err > spiral_abs_tolerance))
      fail("radius to end of arc differs from radius to start: " + where());
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) fail("arc centre cannot be computed (numbers too large or too small)");
  Move m;
  m.kind = Move::Kind::arc;
  m.plane = plane_;
  m.end = end_mm;
  m.center = Eigen::Vector2d(cx * s, cy * s);
  m.clockwise = clockwise;
  m.turns = b.w('p') ? static_cast<int>(std::lround(*b.w('p'))) - 1 : 0;
  m.feed_mm_per_min = feed_mm_per_min_;
  push(m);
}

// A sign that a program is written for GRBL: the first line that is a GRBL system command
// ('$' alone or followed by a letter, '$' or '#': $H, $X, $$, $#, $J=...; or by digits and
// '=': $100=250; LinuxCNC's spindle words $0 M3, $-1 M5 are not), or a '%' line where LinuxCNC
// allows none (not the first line, when the first line is not '%'). 0 for none.
struct GrblSign {
  int line = 0;
  const char* what = "";
};

GrblSign grbl_sign(const std::string& text) {
  int number = 0;
  bool percent_first = false;
  for (std::size_t start = 0; start < text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++number;
    std::size_t p = text.find_first_not_of(" \t", start);
    const char c = p < end ? text[p] : '\0';
    start = end + 1;
    if (c == '%') {
      if (number == 1) percent_first = true;
      else if (!percent_first) return {number, "a '%' line inside the program"};
      continue;
    }
    if (c != '$') continue;
    ++p;
    if (p >= end || text[p] == '\r' || std::isalpha(static_cast<unsigned char>(text[p])) || text[p] == '$' ||
        text[p] == '#')
      return {number, "a GRBL system command line"};
    while (p < end && std::isdigit(static_cast<unsigned char>(text[p]))) ++p;
    if (p < end && text[p] == '=' && text[p - 1] != '$') return {number, "a GRBL setting line"};
  }
  return {};
}

Program read_as(const std::string& text, const std::string& source_name, const GcodeOptions& options, bool& ended) {
  Reader reader(source_name, options);
  Program p = reader.run(text);
  ended = reader.ended();
  return p;
}

}  // namespace

std::optional<GcodeDialect> gcode_dialect_from(std::string_view name) {
  if (name == "linuxcnc") return GcodeDialect::linuxcnc;
  if (name == "grbl") return GcodeDialect::grbl;
  if (name == "auto") return GcodeDialect::automatic;
  return std::nullopt;
}

void GcodeOptions::validate() const {
  if (max_line_chars < 1 || max_line_chars > (1u << 20))
    throw InputError::field("max_line_chars", fmt::format("{} must be in 1..{}", max_line_chars, 1u << 20));
  if (max_moves < 1) throw InputError::field("max_moves", "0 must be at least 1");
  if (max_arc_turns < 1 || max_arc_turns > 1'000'000)
    throw InputError::field("max_arc_turns", fmt::format("{} must be in 1..1000000", max_arc_turns));
  if (spindle_count < 1 || spindle_count > 100)
    throw InputError::field("spindle_count", fmt::format("{} must be in 1..100", spindle_count));
  if (max_executed_lines < 1) throw InputError::field("max_executed_lines", "0 must be at least 1");
}

Program read_gcode(const std::string& text, const std::string& source_name, const GcodeOptions& options) {
  bool ended = false;
  if (options.dialect != GcodeDialect::automatic) return read_as(text, source_name, options, ended);
  GcodeOptions o = options;
  o.dialect = GcodeDialect::grbl;
  if (const GrblSign sign = grbl_sign(text); sign.line > 0) {
    Program p = read_as(text, source_name, o, ended);
    p.warnings.insert(p.warnings.begin(),
                      fmt::format("{}:{}: read as a GRBL program (auto-detected: {}; the linuxcnc dialect reads it "
                                  "as LinuxCNC does)",
                                  source_name, sign.line, sign.what));
    return p;
  }
  o.dialect = GcodeDialect::linuxcnc;
  if (!options.require_program_end) return read_as(text, source_name, o, ended);
  o.require_program_end = false;
  Program p = read_as(text, source_name, o, ended);
  if (ended) return p;
  o.dialect = GcodeDialect::grbl;
  Program g = read_as(text, source_name, o, ended);
  g.warnings.insert(g.warnings.begin(),
                    fmt::format("{}: read as a GRBL program (auto-detected: no program end, M2, M30 or a closing %; "
                                "the linuxcnc dialect reads it as LinuxCNC does)",
                                source_name));
  return g;
}

Program read_gcode_file(const std::string& path, const GcodeOptions& options) {
  return read_gcode(read_text_file(path), path, options);
}

}  // namespace machplan
