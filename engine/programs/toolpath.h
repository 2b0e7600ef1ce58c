// A CAM tool path: the sequence of tool poses (tip position and tool axis) that a 5-axis or
// 3-axis program visits, as read from an APT/CLDATA file or a CSV table.
//
// This is what placement and interference checking consume: for every pose the tool tip must
// reach `tip_mm` with the spindle along `axis`. Everything is in millimetres, in the
// workpiece frame of the CAM system; `axis` is a unit vector pointing from the tip up into the
// spindle (so a vertical 3-axis tool has axis (0, 0, 1)).
//
// Formats accepted
// ----------------
// APT / CLDATA (extensions .cl, .apt, .cls). One statement per line, keywords case-insensitive,
// "WORD/arg, arg, ..." with any blanks around the separators:
//
//   PARTNO any text              part name, kept in ToolPath::part_name
//   UNITS/MM | UNITS/INCHES      unit of the numbers that follow (default MM); INCHES are
//   UNIT/MM | UNIT/INCHES        converted to mm (x 25.4) as they are read. UNIT is the
//                                spelling CAMWorks and others write.
//   CUTTER/d[, r[, e, f, a, b, h]]
//                                APT cutter: diameter d, corner radius r (default 0), and with
//                                all seven values the flute length h. d > 0, 0 <= r <= d/2.
//                                It describes the tool of the moves that follow it: the tool
//                                the next LOAD/TOOL loads, or, when a move comes first, the
//                                one in the spindle (then a tool of its own if that one has
//                                already moved with another CUTTER).
//   LOAD/TOOL, n[, ...]          a tool change: the moves that follow are made with tool n
//                                (an integer 0 .. 1e6), kept in ToolPath::tools; a number
//                                loaded again is the same tool (its CUTTERs must agree).
//   CSI_SET_FLUTE_LENGTH/l, CSI_SET_EXTENSION_LENGTH/l
//                                CAMWorks' flute length and length out of the holder of the
//                                tool loaded last.
//   FEDRAT/f | FEDRAT/MMPM, f | FEDRAT/f, MMPM | FEDRAT/IPM, f | FEDRAT/f, IPM
//                                feed for the following GOTOs, per minute in the current unit
//                                (MMPM forces mm/min, IPM inch/min); f > 0. Per-revolution
//                                feeds (MMPR, IPR) are refused.
//   MULTAX | MULTAX/ON | MULTAX/OFF
//                                multi-axis output on or off; informational (GOTO decides by
//                                its number of values)
//   TLAXIS/i, j, k               tool axis for the following three-value GOTOs
//   RAPID | RAPID/               the next GOTO is a rapid move (ToolPose::rapid)
//   RAPID/x, y, z[, i, j, k]     a rapid move to that pose (as RAPID then GOTO)
//   GOTO/x, y, z                 a pose with the current TLAXIS (initially +Z)
//   GOTO/x, y, z, i, j, k        a pose with its own axis (does not change TLAXIS)
//   FROM/x, y, z[, i, j, k]      the start position: a rapid pose
//   GODLTA/dx, dy, dz            a pose displaced from the last one
//   CIRCLE/cx, cy, cz, i, j, k[, r, ...]
//                                the next GOTO ends a circular move from the current position
//                                about the axis through (cx, cy, cz) along (i, j, k), turning
//                                counter-clockwise seen from the tip of (i, j, k) (right-hand
//                                rule). A GOTO back to the start point is a full turn; a change
//                                of height along the axis makes a helix. The radius r, when
//                                given, must agree with the distance of the start point to the
//                                axis. The move is kept as a ToolArc in ToolPath::arcs, and
//                                poses along it are added (every ReadOptions::arc_step_rad
//                                radians at most, and close enough that the chord between two
//                                stays within arc_tolerance_mm of the arc), so that a reader
//                                of poses alone still follows the arc.
//   CYCLE/type, FEDTO, d[, key, value ...]
//                                a canned cycle (DRILL, DEEP, DEEP2, BRKCHP, TAP, BORE, REAM,
//                                ... any type with FEDTO): until CYCLE/OFF each GOTO is a hole
//                                position P (its top) and is expanded into: rapid to
//                                P + RTRCTO along the tool axis, rapid to P + RAPTO, feed (MMPM
//                                or IPM value, else the current feed) to P - d, rapid back to
//                                P + RTRCTO. Peck and chip-breaking cycles are expanded as one
//                                plunge: the tool sweeps the same volume. RAPTO and RTRCTO
//                                default to 0. CYCLE/INIT, CYCLE/CLEAR (which the APT
//                                convention reads as INIT: the cycle state starts afresh) and
//                                CYCLE/ON carry nothing.
//   FINI                         end of the path; only comments and blanks may follow
//   $$ text                      comment (anywhere on a line; the rest of the line is ignored)
//   ... $                        a '$' ending a line continues the statement on the next line
//
// Any other statement (SELECT, SPINDL, COOLNT, CUTCOM, CSYS, TRNTYP, INSERT, PPRINT,
// post-processor words ...) carries nothing for placement and is skipped, counted per kind in
// ToolPath::skipped (skipped_summary() says it in one line). A CSYS that is not the identity
// (another setup's coordinate system) is not applied either, and that changes what the path
// means: the poses after it stay in the coordinates written. Nor is cutter compensation
// (CUTCOM/LEFT, CUTCOM/RIGHT: the control moves the tool off the points by its radius). Those
// are the warnings (ToolPath::warnings, "FILE:LINE: ..." naming the first and how many).
//
// CSV (extension .csv): one pose per line, comma separated, blanks around fields ignored,
// lines starting with '#' and blank lines skipped. An optional header names the columns:
// x, y, z (required), i, j, k (together or not at all) and feed (mm/min), in any order. Without
// a header a row holds 3 (x, y, z), 6 (x, y, z, i, j, k) or 7 (..., feed) numbers. Every row
// must have the header's (or the first row's) number of fields. Without i, j, k the axis is +Z.
//
// Other extensions: the content decides. A first statement that starts with a letter and is
// not a CSV header is read as APT; a first line of numbers or a CSV header as CSV.
//
// Refused, always with "FILE:LINE: what" (InputError)
// --------------------------------------------------
//   * a wrong number of values or a word where a number belongs in a statement listed above;
//     a CIRCLE without a position before it or a GOTO after it, or whose end point is not on
//     its circle; a cycle GOTO without FEDTO;
//   * non-finite or out-of-range numbers (inf, nan, 1e999);
//   * a tool axis shorter than 1e-9 (it is normalised to unit length otherwise);
//   * a line longer than ReadOptions::max_line_bytes, a statement (with its continuations)
//     longer than ReadOptions::max_statement_bytes, more than ReadOptions::max_poses poses;
//   * an empty path (no pose at all).
// The line of an APT statement that spans several lines is the line it starts on.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace machplan {

struct ToolPose {
  Eigen::Vector3d tip_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit, from the tip up into the spindle
  double feed_mm_per_min = 0.0;  // feed in force at this pose; 0 when the file gave none
  int line = 0;                  // 1-based source line of the statement or row
  bool rapid = false;            // APT: this GOTO followed a RAPID
  int arc = -1;                  // index into ToolPath::arcs when the move to here is circular
  int tool = -1;                 // index into ToolPath::tools; -1 when the file names no tool
};

// A circular (or helical) move of an APT CIRCLE: from poses[first_pose - 1] through the
// added poses to poses[last_pose], turning by sweep_rad about `axis` (right-hand rule) around
// the line through center_mm. The poses it spans all carry its index in ToolPose::arc.
struct ToolArc {
  std::size_t first_pose = 0, last_pose = 0;
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit
  double radius_mm = 0.0;
  double sweep_rad = 0.0;  // > 0, up to 2 pi for a full turn
  int line = 0;            // line of the CIRCLE statement
};

struct ToolPath {
  struct Cutter {
    double diameter_mm = 0.0;
    double corner_radius_mm = 0.0;  // 0 flat end mill, diameter/2 ball end mill
    double length_mm = 0.0;         // flute length (APT h); 0 when not given
    int line = 0;                   // of the CUTTER statement
  };
  // A tool the moves are made with: loaded by LOAD/TOOL, or described by a CUTTER alone.
  struct Tool {
    int number = -1;                // LOAD/TOOL number; -1 for a tool the file gives no number
    int line = 0;                   // where it is first loaded (or its CUTTER's line)
    std::optional<Cutter> cutter;   // what the file says of its shape
    double flute_mm = 0.0;          // CSI_SET_FLUTE_LENGTH; 0 when not given
    double extension_mm = 0.0;      // CSI_SET_EXTENSION_LENGTH (out of the holder); 0 when not given
    std::size_t poses = 0;          // poses made with it
    double gauge_mm = 0.0;          // from the tip to the spindle's gauge line (a tool table's Z); 0 unknown
    std::string table;              // "FILE:LINE" of its tool table entry, when one was applied
    std::string name() const;       // "T16", or "the tool of line 4"
  };

  std::string source;     // file name (or the name given to a string reader), for messages
  std::string part_name;  // APT PARTNO text, empty otherwise
  std::vector<ToolPose> poses;
  std::optional<Cutter> cutter;  // last CUTTER statement in the file, if any
  std::vector<Tool> tools;       // every tool that makes a move, in order of first use
  bool multiaxis = false;        // MULTAX/ON seen, or some pose carried its own axis
  std::vector<ToolArc> arcs;     // APT CIRCLE moves, in order
  // What changes the result: a CSYS or cutter compensation that is not applied. Empty for most files.
  std::vector<std::string> warnings;
  // Statements that carry nothing for the tool path, per kind ("LOAD", "SPINDL"), in order of
  // first appearance.
  struct SkippedKind {
    std::string statement;
    int first_line = 0;
    std::size_t count = 0;
  };
  std::vector<SkippedKind> skipped;
};

// One line for ToolPath::skipped: "FILE: skipped 6 statements that carry no tool-path geometry:
// LOAD x2 (first at line 2), PPRINT (line 5), ..."; empty when nothing was skipped.
std::string skipped_summary(const ToolPath& path);

// Every number in a tool-path file lies within +-kMaxToolPathNumber (coordinates in mm or
// inch, axis components, feeds); beyond it squares and sums of coordinates lose all precision.
inline constexpr double kMaxToolPathNumber = 1e9;

struct ToolPathReadOptions {
  // Most poses accepted. A pose costs 72 bytes, so the default bounds memory near 3.6 GB.
  std::size_t max_poses = 50'000'000;
  // Longest physical line, in bytes (CL and CSV lines are short; this stops binary garbage
  // or a file without newlines from building a huge statement).
  std::size_t max_line_bytes = 64 * 1024;
  // Longest APT statement after joining '$' continuations.
  std::size_t max_statement_bytes = 1024 * 1024;
  // Largest file read by read_toolpath_file.
  std::size_t max_file_bytes = std::size_t{512} << 20;
  // Poses added along an APT CIRCLE: at most this angle apart (rad, in (0, pi/2]) ...
  double arc_step_rad = 0.1;
  // ... and close enough that each chord stays within this distance of the arc (mm, > 0).
  double arc_tolerance_mm = 0.01;
  // Largest deviation of a CIRCLE's end point from its circle, mm, before it is refused.
  double arc_end_tolerance_mm = 0.01;

  // Throws InputError naming the field.
  void validate() const;
};

enum class ToolPathFormat { apt, csv };

// Reads `path`, choosing the format by extension (.cl, .apt, .cls: APT; .csv: CSV, case
// insensitive) or, for any other extension, by content. Throws InputError.
ToolPath read_toolpath_file(const std::string& path, const ToolPathReadOptions& options = {});

// The same readers on text in memory; `source` names it in messages and in ToolPath::source.
ToolPath read_apt(std::string_view text, const std::string& source,
                  const ToolPathReadOptions& options = {});
ToolPath read_toolpath_csv(std::string_view text, const std::string& source,
                           const ToolPathReadOptions& options = {});
// Picks APT or CSV by content (see above); throws InputError when neither fits.
ToolPath read_toolpath(std::string_view text, const std::string& source,
                       const ToolPathReadOptions& options = {});
ToolPathFormat sniff_toolpath_format(std::string_view text, const std::string& source);

// A G-code job (engine/programs/gcode.h; files are read in the dialect they point to, LinuxCNC's
// or GRBL's) as a tool path: the tip at
// the end of every rapid and feed move, and along arcs (every 0.1 rad at most, chords within
// 0.01 mm), the tool axis +Z; each tool change (M6, M61) starts the moves of its tool (ToolPath::
// tools, with no shape until a tool table gives one). read_toolpath_file reads files ending in
// .ngc, .nc, .gcode, .tap or .g this way. Throws InputError.
struct Program;
ToolPath toolpath_from_gcode(const Program& program, const ToolPathReadOptions& options = {});

// One line of a LinuxCNC tool table ("T1 P1 D6.0 Z+50.0 ;comment"): the tool, its diameter (D)
// and its length (Z: from the tip to the spindle's gauge line), 0 when not given.
struct ToolTableEntry {
  int number = 0;
  double diameter_mm = 0.0, length_mm = 0.0;
  int line = 0;
};
// Reads a tool table: words T P X Y Z A B C U V W D I J Q, ';' comments. A line without its T
// word, another letter, or a bad number is refused with the file and line (InputError).
std::vector<ToolTableEntry> read_tool_table_file(const std::string& path);
// Gives each tool of the path that the table lists its diameter (when no CUTTER gave one) and
// its length (ToolPath::Tool::gauge_mm).
void apply_tool_table(ToolPath& path, const std::vector<ToolTableEntry>& table, const std::string& table_file);

// Figures for a readable report of a tool path.
struct ToolPathSummary {
  std::size_t poses = 0, rapid_poses = 0;
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero(), max_mm = Eigen::Vector3d::Zero();  // tips
  double min_tilt_rad = 0.0, max_tilt_rad = 0.0;  // angle of the axis from +Z
  double max_step_mm = 0.0;   // largest distance between consecutive tips
  int max_step_line = 0;      // line of the pose that ends that step
  double feed_length_mm = 0.0;   // summed distance of steps ending in a non-rapid pose
  double rapid_length_mm = 0.0;  // summed distance of steps ending in a rapid pose
};

ToolPathSummary summarize(const ToolPath& path);

}  // namespace machplan
