// The G-code reader's inside, shared by its files (not part of the installed interface).
// The reader is split as LinuxCNC splits its interpreter (src/emc/rs274ngc):
//   gcode.cpp          read_gcode(): the dialects, the program loop, the parameters
//                      (LinuxCNC's rs274ngc_pre.cc and interp_namedparams.cc)
//   gcode_read.cpp     a file into cleaned lines, a line into words (interp_read.cc)
//   gcode_o_word.cpp   O-word structure and control flow: subroutines, loops, conditionals
//                      (interp_o_word.cc)
//   gcode_convert.cpp  a block into motion and events, in LinuxCNC's order of execution
//                      (interp_execute.cc, interp_convert.cc, interp_arc.cc)
//   gcode_cycles.cpp   the drilling cycles (interp_cycles.cc)
// Each line is first cleaned (comments removed, spaces dropped, lower-cased), then split into
// words, then checked (modal groups, words without a code that uses them), then executed in
// LinuxCNC's fixed order. Geometry checks on arcs are done in program units, as LinuxCNC does
// them, and the result is converted to mm.
#pragma once

#include <array>
#include <cctype>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"
#include "engine/programs/gcode_expr.h"

namespace machplan::gcode_interp {

inline constexpr double kMmPerInch = 25.4;

// G codes are kept as ten times their number (G38.2 -> 382). g_name(382) is "G38.2".
std::string g_name(int g10);
// Modal group of a supported G code (LinuxCNC's numbering); -1 for codes we do not support.
int g_group(int g10);
inline bool is_cycle(int g10) { return g10 == 730 || (g10 >= 810 && g10 <= 890); }

// Control-flow keyword of an O-word line.
enum class OKind { none, sub, endsub, call, do_, while_, endwhile, if_, elseif, else_, endif, repeat, endrepeat,
                   return_, break_, continue_ };

OKind o_kind_of(const std::string& word);

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

inline constexpr char kAxes[3] = {'x', 'y', 'z'};

// A subroutine call in progress.
struct Frame {
  int return_pc = 0;
  std::array<double, 30> saved{};  // the caller's #1..#30
  std::map<std::string, double> locals;
  std::map<int, long long> repeats;  // repeat line -> passes left
};

inline constexpr int kMaxCallDepth = 50;
inline constexpr int kFirstG28Param = 5161;   // #5161..#5169: the G28 position (machine coordinates)
inline constexpr int kFirstG30Param = 5181;   // #5181..#5189: the G30 position
inline constexpr int kFirstG92Param = 5211;   // #5211..#5219: G92 offsets, #5210: G92 in effect
inline constexpr int kCoordSystemParam = 5220;
inline constexpr int kFirstG5xParam = 5221;   // #5221 + 20 (n - 1) + axis: G54..G59.3 offsets

// Parameters that hold lengths (kept in mm, read and written in the program's units): the G28
// and G30 positions, the G92 offsets and the G54..G59.3 offsets (X, Y, Z, A, B, C, U, V, W).
inline bool is_length_param(int n) {
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
  std::size_t realtime_lines_ = 0;   // GRBL real-time command lines skipped
  int first_realtime_line_ = 0;

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

// A sign that a program is written for GRBL: the first line that is a GRBL system command
// ('$' alone or followed by a letter, '$' or '#': $H, $X, $$, $#, $J=...; or by digits and
// '=': $100=250; LinuxCNC's spindle words $0 M3, $-1 M5 are not), or a '%' line where LinuxCNC
// allows none (not the first line, when the first line is not '%'), or a line of GRBL real-time
// commands ('?', '~', '!'). Line 0 for none.
struct GrblSign {
  int line = 0;
  const char* what = "";
};
GrblSign grbl_sign(const std::string& text);

}  // namespace machplan::gcode_interp
