// Reading RS274NGC part programs (G-code) the way LinuxCNC reads them.
//
// read_gcode() interprets a program into a Program: canonical moves in millimetres, absolute
// coordinates, each tagged with its source line. LinuxCNC's interpreter is the reference: for
// every program this reader accepts, `rs274 -g` prints the same sequence of moves (the
// conformance test in tests/programs/gcode_conformance_test.cpp checks this on our corpus and on
// the samples LinuxCNC installs), and every program rs274 rejects is rejected here too.
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
//   * Numbers: optional sign, digits with at most one '.', at least one digit: "1", "-0.5",
//     ".5", "+1", "1.". No exponents: 'E' is a word letter in RS274NGC, so "X1e400" is the word X1
//     followed by an E word, which is refused. Magnitudes above 1e9 are refused.
//   * G0 rapid, G1 line, G2/G3 clockwise / counter-clockwise arc in the XY plane.
//       - Centre format: I/J offsets from the start point (G91.1, the default) or absolute
//         centre coordinates (G90.1); an omitted I or J is 0. End point equal to the start point
//         makes a full circle.
//       - Radius format: R; negative R selects the arc longer than a semicircle.
//       - Z moving along the arc makes a helix; P n (an integer >= 1) makes n turns, that is
//         n - 1 extra full turns (Move::turns = n - 1).
//       - An arc whose radius to the end differs from its radius to the start is refused when
//         the difference exceeds 100 x the absolute tolerance, or exceeds the absolute tolerance
//         and 0.1 % of the larger radius; the absolute tolerance is 2 x 0.01 x sqrt(2) mm
//         (2 x 0.001 x sqrt(2) inch under G20), LinuxCNC's default. A radius below
//         0.00005 inch (0.00127 mm) is a zero-radius arc, refused. With R, an end point further
//         than |R| + that tolerance from the start ("radius too small to reach end point") and
//         an end point equal to the start are refused.
//     G0 or a G1 without axis words moves to where the tool already is (rs274 emits such a
//     zero-length move too). G2/G3 without axis words but with I/J is a full circle.
//   * G4 P dwell (seconds, >= 0). G17 (the only plane). G20 / G21 (inch / mm; inch values are
//     converted to mm). G90 / G91 absolute / incremental distances; G90.1 / G91.1 arc centre
//     mode. G40, G49, G54, G80, G94: the states LinuxCNC starts in (no cutter compensation, no
//     tool length offset, first work coordinate system with zero offset, no canned cycle,
//     units per minute feed); accepted so that common program preambles read. After G80 axis
//     words need a new G0..G3.
//   * F feed (program units per minute, >= 0), S spindle speed (>= 0). F takes the length units
//     in effect when it is read, that is before a G20/G21 on the same line (LinuxCNC's order of
//     execution on a line: F, S, M3/M4/M5, G4, G17, G20/G21, G90/G91, motion, M0/M1/M2/M30).
//   * M3 / M4 (torch or spindle on, either direction) -> torch_on with the current S;
//     M5 -> torch_off. M0 / M1 (program stop, optional stop): accepted, produce no move.
//     M2 / M30 end the program; nothing after them is read.
//   * The state at the start is LinuxCNC's: position (0, 0, 0), mm, G17, G90, G91.1, G0 motion,
//     feed 0, S 0.
//
// What is refused (InputError, "FILE:LINE: message")
// -------------------------------------------------
//   * Unsupported features, each named: O-word subroutines and control flow, parameters ('#'),
//     expressions ('[...]' and functions), G18 / G19 planes, cutter compensation, tool length
//     offsets, work offsets and coordinate systems other than G54, canned cycles, probing,
//     threading, splines, inverse-time and per-revolution feed, tool changes (T, M6), coolant,
//     overrides, I/O M codes, user M codes, A/B/C/U/V/W axes, E/L/Q/D/H words, polar
//     coordinates (@ and ^). Messages read
//     "G41 (cutter radius compensation) is not supported".
//   * LinuxCNC's errors: unknown G or M code; a repeated word letter on a line ("multiple X
//     words on one line"); two G codes or two M codes of the same modal group on a line; more
//     than 4 M codes; G1 / G2 / G3 with zero feed rate; negative F or S; G4 without P or with a
//     negative P; R together with I/J; an arc with none of R, I, J; K on an XY arc; I/J/K/R/P
//     words with no code that uses them; axis words with G80 or after G80 with no motion code;
//     malformed numbers; non-integer M codes; a program that ends with neither M2/M30 nor a
//     closing '%' (unless GcodeOptions::require_program_end is false).
//   * Where rs274 accepts nonsense, this reader refuses it: R0 on an arc (rs274 prints a NaN
//     centre) and a doubled sign such as "X--1" (rs274 reads it as X1).
//   * Limits that keep any input bounded: GcodeOptions::max_moves moves, max_arc_turns turns
//     on one arc, max_line_chars characters on a line.
//
// Thread safety: read_gcode is a pure function of its arguments and may run concurrently.
#pragma once

#include <cstddef>
#include <map>
#include <string>

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

  // Throws InputError naming the field when a value is out of range.
  void validate() const;
};

// Interprets `text`. `source_name` is used in messages and stored in Program::source.
// Throws InputError("source_name", line, message) on the first error.
Program read_gcode(const std::string& text, const std::string& source_name, const GcodeOptions& options = {});

// Reads the file at `path` (see read_text_file for its limits) and interprets it.
Program read_gcode_file(const std::string& path, const GcodeOptions& options = {});

}  // namespace machplan
