// Reading RS274NGC part programs (G-code) the way LinuxCNC reads them.
//
// read_gcode() interprets a program into a Program: canonical moves in millimetres, machine
// coordinates (the program's work offsets applied), each tagged with its source line, and the
// words that carry no geometry as ProgramEvents. LinuxCNC's interpreter is the reference: for
// every program this reader accepts, `rs274 -g` prints the same sequence of moves once the work
// offsets it announces are added (the conformance test in tests/programs/gcode_conformance_test.cpp
// checks this on our own programs and on the samples LinuxCNC installs), and every program rs274
// rejects is rejected here too.
//
//   Program p = read_gcode("G21 G90\nG0 X10 Y5\nM3 S3000\nG1 X20 F1200\nM5\nM2\n", "part.ngc");
//   // p.moves: rapid to (10,5,0), torch_on, line to (20,5,0) at 1200 mm/min, torch_off.
//
// What is accepted
// ----------------
//   * Lines: at most 252 characters (longer lines are an error, as in LinuxCNC). Spaces and tabs
//     anywhere outside comments are ignored ("G 0 X 1." is "G0X1."), letters may be lower case.
//     A leading '/' (block delete) is accepted and the line runs (block delete is off).
//   * Comments: "( ... )" anywhere on a line, and ';' to the end of the line. A '(' inside a
//     comment ("nested comment") and a comment left open at the end of the line are errors.
//   * '%': when the first line starts with '%', the program ends at the next line starting with
//     '%'; a '%' anywhere else is an error.
//   * N words (line numbers): only first on a line; ignored.
//   * Values: numbers (optional sign, digits with at most one '.'; no exponents: 'E' is a word
//     letter, so "X1e400" is X1 followed by an E word), parameters and expressions with
//     LinuxCNC's semantics (engine/programs/gcode_expr.h): #1..#5602, ##n, #[expr], named
//     #<local> and #<_global> parameters, [expressions] with every binary operator and function
//     rs274 has. Magnitudes of written numbers above 1e9 are refused.
//   * Parameter settings (#n=..., #<name>=...) take effect after the whole line is read, so a
//     line reads the values from before it. #1..#30 are a subroutine's arguments (saved and
//     restored around a call); names without a leading '_' are local to the call. #5161..,
//     #5181.. (G28 / G30 positions), #5210..#5219 (G92), #5220 (coordinate system), #5221..
//     (G54..G59.3 offsets), #5400 (tool), #5420..#5422 (position) and the predefined named
//     parameters _x _y _z _metric _imperial _absolute _incremental _feed _rpm _current_tool
//     _selected_tool _call_level _line _value _value_returned read as in LinuxCNC. Named
//     parameters LinuxCNC takes from the machine (_hal[...], _ini[...]) and any other value the
//     program reads but does not set come from GcodeOptions::params; without one the program
//     is refused naming the parameter.
//   * O-words, with a number or <name> label: sub / endsub [value] / call [args]..., return
//     [value] (sets #<_value> and #<_value_returned>), while / endwhile, do / while, if /
//     elseif / else / endif, repeat [n] / endrepeat, break, continue. Subroutines may be defined
//     anywhere in the file (before or after M2); definitions are skipped where they stand.
//     A construct left open is an error only when the flow needs its end line, as in rs274.
//   * G0 rapid, G1 line, G2/G3 clockwise / counter-clockwise arc in the G17 XY, G18 XZ or G19
//     YZ plane (Move::plane; the centre is stored in the plane's axis order).
//       - Centre format: I/J (XY), K/I (XZ), J/K (YZ) offsets from the start point (G91.1, the
//         default) or absolute centre coordinates (G90.1); an omitted offset is 0. End point
//         equal to the start point makes a full circle.
//       - Radius format: R; negative R selects the arc longer than a semicircle.
//       - The axis normal to the plane moving along the arc makes a helix; P n (an integer
//         >= 1) makes n turns, that is n - 1 extra full turns (Move::turns = n - 1).
//       - An arc whose radius to the end differs from its radius to the start is refused when
//         the difference exceeds 100 x the absolute tolerance, or exceeds the absolute tolerance
//         and 0.1 % of the larger radius; the absolute tolerance is 2 x 0.01 x sqrt(2) mm
//         (2 x 0.001 x sqrt(2) inch under G20), LinuxCNC's default. A radius below
//         0.00005 inch (0.00127 mm) is a zero-radius arc, refused. With R, an end point further
//         than |R| + that tolerance from the start ("radius too small to reach end point") and
//         an end point equal to the start are refused.
//     G0 or a G1 without axis words moves to where the tool already is (rs274 emits such a
//     zero-length move too). G2/G3 without axis words but with centre words is a full circle.
//     G80 on a line with another motion code gives way to it.
//   * Drilling cycles G73, G81, G82, G83, G85, G89 in the XY plane, G98 / G99, L repeats, in
//     G90 and G91, expanded into rapids, feeds and dwells exactly as LinuxCNC expands them.
//   * Work offsets: G54..G59.3 select; G10 L2 Pn (offset values) and G10 L20 Pn (offset that
//     makes the current point the given coordinates) set, P0 meaning the active system;
//     G92 / G92.1 / G92.2 / G92.3; G52 (the local offset, kept with G92's); G53 moves (G0/G1)
//     in machine coordinates; G28 / G30 (through the given point to the stored position) and
//     G28.1 / G30.1; all in mm and inch.
//   * G4 P dwell (seconds, >= 0). G20 / G21 (inch / mm; inch values are converted to mm).
//     G90 / G91 absolute / incremental distances; G90.1 / G91.1 arc centre mode. G40, G49,
//     G94, G97: LinuxCNC's start states. G94 sets the feed to 0 as LinuxCNC does.
//   * Path control, kept on each move (Move::path_mode, path_tolerance_mm): G64 [P tolerance]
//     [Q], G61 exact path, G61.1 exact stop.
//   * F feed (program units per minute, >= 0), S spindle speed (>= 0). F takes the length units
//     in effect when it is read, that is before a G20/G21 on the same line (LinuxCNC's order of
//     execution on a line: G93/G94, F, S, T, M62-M68, M6/M61, M3/M4/M5, M7-M9, M48-M53, user M
//     codes, G4, plane, units, G43/G49, coordinate system, path control, distance modes,
//     G98/G99, G10/G28/G30/G92, motion, M0/M1/M2/M30).
//   * M3 / M4 (torch or spindle on, either direction) -> torch_on with the current S;
//     M5 -> torch_off. $n selects the spindle (0 .. GcodeOptions::spindle_count - 1; $-1 with
//     M5 stops every spindle); Move::spindle keeps it. M2 / M30 end the program; nothing after
//     them is read.
//   * Kept as ProgramEvents, with no geometry: T (tool select), M6 (tool change; it also stops
//     the spindle, a torch_off, as LinuxCNC does), M61 Q, G43 [H] / G49 (no Z effect: tool
//     lengths are not modelled), M7 / M8 / M9, M48-M53, M62-M65 (digital outputs, M62/M63
//     synchronised with the next move), M66 (wait for an input), M67 / M68 (analog outputs),
//     M100-M199 (user M codes with their P and Q), M0 / M1; on request, the settings of
//     named parameters (GcodeOptions::reported_params) and "(o=...)" comments
//     (GcodeOptions::report_magic_comments).
//   * The state at the start is LinuxCNC's: position (0, 0, 0), mm, G17, G90, G91.1, G0 motion,
//     G54 with zero offsets, G99 retract, feed 0, S 0.
//
// What is refused (InputError, "FILE:LINE: message")
// -------------------------------------------------
//   * Unsupported features, each named ("... is not supported"): cutter compensation, inverse-time
//     and per-revolution feed, G43.1 / G43.2, probing, threading, tapping and the other
//     canned cycles (G74, G76, G84, G86-G88), splines, lathe modes, UV/WU/VW planes, G10 L1/L10/
//     L11 (tool table), G10 L2 R (rotation), subroutines in other files, M19, M60, M70-M73,
//     M98/M99, A/B/C/U/V/W axes, D words, polar coordinates (@ and ^).
//   * LinuxCNC's errors: unknown G or M code; a repeated word letter on a line ("multiple X
//     words on one line"); two G codes or two M codes of the same modal group on a line; two G
//     codes that both use axis words; more than 4 M codes; G1 / G2 / G3 / cycles with zero feed
//     rate; negative F or S; G4 without P or with a negative P; R together with centre words;
//     an arc with no R or centre word; a centre word of the wrong plane; words with no code that
//     uses them (I J K R P Q L E H); axis words with G80 or after G80 with no motion code;
//     malformed numbers and expressions; division by zero and the functions' domain errors;
//     undefined named parameters; a spindle number the machine does not have; O-word structure
//     errors; a program that ends with neither M2/M30 nor a closing '%' (unless
//     GcodeOptions::require_program_end is false: then Program::warnings says so).
//   * A file that is not text: a NUL byte anywhere ("not a text file", at its line), before
//     anything else is read. A line of GRBL real-time commands ('?', '~', '!'), naming the
//     grbl dialect, which reads it.
//   * Where rs274 accepts nonsense, this reader refuses it: R0 on an arc (rs274 prints a NaN
//     centre) and a doubled sign such as "X--1" (rs274 reads it as X1).
//   * Limits that keep any input bounded: GcodeOptions::max_moves moves, max_arc_turns turns
//     on one arc, max_line_chars characters on a line, max_executed_lines lines executed
//     (loops), 50 nested calls.
//
// Dialects (GcodeOptions::dialect)
// --------------------------------
//   * linuxcnc (the default): everything above, as rs274 reads it.
//   * grbl: GRBL's reading, for programs written for GRBL controllers (Estlcam, laser plug-ins,
//     GRBL posts): a line starting with '$' is a controller command ($H homing, $X unlock, $I,
//     $$, $J=... jog, $100=... settings), kept as a controller_command event with its text and
//     otherwise ignored, with one warning for the program; a line of real-time commands only
//     ('?' status, '~' cycle start, '!' feed hold, which a GRBL sender sends at once rather than
//     as a line) is skipped as a sender skips it, with one warning; a program may end without
//     M2, M30 or '%'; '%' lines are ignored wherever they stand; GRBL's modal defaults (G0 G54 G17 G21
//     G90 G94 G91.1 M5 M9 T0 F0 S0 as LinuxCNC's, and G61 exact path, GRBL's only path mode);
//     every other line is read as in linuxcnc.
//   * automatic: grbl when the text shows a GRBL program (a '$' system command or setting
//     line, a line of real-time commands, or a '%' line where LinuxCNC allows none) or, when require_program_end is set, when
//     it has no program end; linuxcnc otherwise. Program::warnings opens with a note naming
//     the reason and the line when grbl is chosen; Program::dialect says which was read.
//
// Thread safety: read_gcode is a pure function of its arguments and may run concurrently.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/programs/program.h"

namespace machplan {

struct GcodeOptions {
  // LinuxCNC refuses lines longer than this.
  std::size_t max_line_chars = 252;
  // A program with more moves is refused, so that no input exhausts memory (each Move is about
  // 100 bytes, so the default caps the result near 1 GB).
  std::size_t max_moves = 10'000'000;
  // Largest P word on G2/G3: the number of turns of one arc.
  int max_arc_turns = 10'000;
  // LinuxCNC refuses a file that ends without M2/M30 or a closing '%'. Set false to accept
  // program fragments (Program::ends_with_program_end then says whether an end was seen).
  bool require_program_end = true;
  // Values of named parameters the program reads but does not set, such as QtPlasmaC's
  // "_hal[plasmac.cut-feed-rate]" and "_ini[...]": keys as written between #< and >, without
  // blanks, any case. A program that reads one not given here is refused naming it.
  std::map<std::string, double> params;
  // Spindles the machine has: $n words may name 0 .. spindle_count - 1 (LinuxCNC's default
  // is 1; QtPlasmaC configurations have 3: torch, scribe, spotting).
  int spindle_count = 1;
  // Lines executed (loops and subroutine calls count every pass): a bound so that an endless
  // loop is an error, not a hang.
  std::size_t max_executed_lines = 20'000'000;
  // Whose reading of G-code; see "Dialects" above.
  GcodeDialect dialect = GcodeDialect::linuxcnc;
  // Named parameters whose settings are kept as ProgramEvent::Kind::parameter events, in
  // program order (names as written between #< and >, lower case, no blanks): how a caller
  // follows settings such as QtPlasmaC's #<holes> or #<pierce-only> through the program.
  std::vector<std::string> reported_params;
  // Keep each comment "(o=...)" (QtPlasmaC's material comments) as a magic_comment event.
  bool report_magic_comments = false;

  // Throws InputError naming the field when a value is out of range.
  void validate() const;
};

// "linuxcnc", "grbl", "auto" (automatic), and back; nothing for another name.
std::optional<GcodeDialect> gcode_dialect_from(std::string_view name);

// Interprets `text`. `source_name` is used in messages and stored in Program::source.
// Throws InputError("source_name", line, message) on the first error.
Program read_gcode(const std::string& text, const std::string& source_name, const GcodeOptions& options = {});

// Reads the file at `path` (see read_text_file for its limits) and interprets it. An empty
// file (0 bytes) is refused: it is a failed copy or post-processor, not a program.
Program read_gcode_file(const std::string& path, const GcodeOptions& options = {});

}  // namespace machplan
