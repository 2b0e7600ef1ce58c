// A part program after interpretation: a list of canonical moves in millimetres, absolute
// coordinates, with the source line each came from.
//
// This is what every executor and checker consumes; readers (G-code today) produce it. The
// meaning follows LinuxCNC's RS274NGC interpreter (`rs274 -g` is the reference):
//   * rapid / line: straight move from the previous end to `end`.
//   * arc: in `plane` (XY by default; XZ and YZ as G18 / G19 make them), from the previous end
//     to `end` about `center` (in the plane's axis order: (x, y), (z, x) or (y, z)),
//     `clockwise` (G2) or counter-clockwise (G3) seen in that order, with `turns` extra full
//     turns (a P word, or 0), and the plane's normal axis moving linearly along the arc (a
//     helix) to its value in `end`.
//   * dwell: wait `seconds`.
//   * torch_on / torch_off: M3 / M5 (torch or spindle). `spindle_speed` carries S at M3,
//     `spindle` the spindle ($n word; -1 on M5 $-1: every spindle).
// Coordinates are machine coordinates: the program's work offsets (G54-G59.3, G92) are
// applied, and G53 moves are where they say on the machine.
// Feeds are in mm/min as in the program (F); the executor converts to mm/s at its edge.
// Words that carry no geometry are kept as ProgramEvents (tool, coolant, outputs, ...) and
// each motion carries the path mode (G61 / G61.1 / G64 P) in force.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace machplan {

struct Move {
  enum class Kind { rapid, line, arc, dwell, torch_on, torch_off };

  Kind kind = Kind::rapid;
  int line = 0;                               // 1-based source line
  Eigen::Vector3d end = Eigen::Vector3d::Zero();     // mm, absolute (rapid, line, arc)
  double feed_mm_per_min = 0.0;               // line, arc
  // Arc plane: G17 XY (centre (x, y), helix along z), G18 XZ (centre (z, x), along y),
  // G19 YZ (centre (y, z), along x): LinuxCNC's canonical axis order for each plane.
  enum class Plane { xy, xz, yz };
  Plane plane = Plane::xy;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // mm, absolute (arc), in the plane's axis order
  bool clockwise = false;                     // arc
  int turns = 0;                              // arc: extra full turns beyond the first pass
  double seconds = 0.0;                       // dwell
  double spindle_speed = 0.0;                 // torch_on (S word, rpm or machine units)
  int spindle = 0;                            // torch_on / torch_off: $n (-1: all spindles)
  // Path mode in force (rapid, line, arc): G64 blends corners within path_tolerance_mm
  // (0: no tolerance given, as fast as possible); G61 exact path; G61.1 exact stop.
  enum class PathMode { blend, exact_path, exact_stop };
  PathMode path_mode = PathMode::blend;
  double path_tolerance_mm = 0.0;             // G64 P, mm
};

// A word with no geometry, kept for whoever can use it. `before_move` is the index in
// Program::moves of the first move after it (moves.size() when none follows).
struct ProgramEvent {
  enum class Kind {
    tool_select,        // T n: `number` is the tool
    tool_change,        // M6 (the tool selected last) or M61 Q n: `number`
    tool_length_offset, // G43 [H n] / G49: `number` is H (-1 for G49); no Z effect here
    coolant,            // M7 mist (number 7), M8 flood (8), M9 both off (9): no-op
    feed_override,      // M48-M53 (number = M code, value = P or 1): no-op
    digital_output,     // M62-M65: `number` = P (output), `value` = 1 on / 0 off, `synchronized` M62/M63
    analog_output,      // M67 / M68: `number` = E (output), `value` = Q, `synchronized` M67
    wait_input,         // M66: `number` = P or E (input), `value` = Q (timeout, s), `mode` = L
    user_m_code,        // M100-M199: `number` = M code, `value` = P, `value2` = Q
    program_stop,       // M0 (number 0) / M1 (number 1)
    controller_command, // GRBL dialect: a '$' system command line ($H, $X, $J=...): `text`
    parameter,          // a named parameter listed in GcodeOptions::reported_params set: `text` its
                        // name (lower case, no blanks), `value` the value, `mode` 20 under G20
                        // (the value in inches, as written) else 21
    magic_comment,      // GcodeOptions::report_magic_comments: a comment "(o=...)", `text` inside
                        // the parentheses as written (QtPlasmaC's material comments), `mode`
                        // 20 or 21 as for parameter
  };
  Kind kind = Kind::tool_select;
  int line = 0;
  std::size_t before_move = 0;
  int number = 0;
  double value = 0.0;
  double value2 = 0.0;
  int mode = 0;
  bool synchronized = false;
  std::string text;  // controller_command: the line as written (at most 80 characters); parameter,
                    // magic_comment: see the kinds
};

const char* to_string(ProgramEvent::Kind kind);
const char* to_string(Move::PathMode mode);

const char* to_string(Move::Kind kind);
// Whether `m` moves the tool (a rapid, a line or an arc): what sets the position its successor
// starts from.
inline bool is_motion(const Move& m) {
  return m.kind == Move::Kind::rapid || m.kind == Move::Kind::line || m.kind == Move::Kind::arc;
}

// Whose reading of G-code (engine/programs/gcode.h): LinuxCNC's RS274NGC, GRBL's, or the one
// the text points to (a reader's option only; a Program is read as one of the first two).
enum class GcodeDialect { linuxcnc, grbl, automatic };
const char* to_string(GcodeDialect d);

// A feed that asks for the material's cut feed: what F#<_hal[plasmac.cut-feed-rate]> (QtPlasmaC's
// way of saying it) reads while a program is run, and what the G-code writer writes back as that
// parameter. No program writes this number (mm/min).
inline constexpr double kMaterialCutFeed = 987654.321;

struct Program {
  std::string source;                 // file name, for messages
  GcodeDialect dialect = GcodeDialect::linuxcnc;  // as which it was read
  Eigen::Vector3d start = Eigen::Vector3d::Zero();  // position before the first move, mm
  std::vector<Move> moves;
  bool ends_with_program_end = false;  // M2 or M30 seen
  std::vector<ProgramEvent> events;    // non-motion words, in program order
  std::vector<std::string> warnings;   // things a reader accepted leniently, one line each
};

// Summary figures for a readable report.
struct ProgramSummary {
  std::size_t rapid_count = 0, line_count = 0, arc_count = 0, dwell_count = 0, torch_on_count = 0;
  double rapid_length_mm = 0.0;
  double feed_length_mm = 0.0;
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();  // bounding box of all moves
  double estimated_seconds = 0.0;  // feed moves at their F, rapids at `rapid_mm_per_min`, dwells
};

ProgramSummary summarize(const Program& program, double rapid_mm_per_min = 5000.0);

}  // namespace machplan
