// A part program after interpretation: a list of canonical moves in millimetres, absolute
// coordinates, with the source line each came from.
//
// This is what every executor and checker consumes; readers (G-code today) produce it. The
// meaning follows LinuxCNC's RS274NGC interpreter (`rs274 -g` is the reference):
//   * rapid / line: straight move from the previous end to `end`.
//   * arc: in the XY plane (G17), from the previous end to `end` about `center` (x, y),
//     `clockwise` (G2) or counter-clockwise (G3), with `turns` extra full turns (a P word,
//     or 0), and z moving linearly along the arc (a helix) to end.z().
//   * dwell: wait `seconds`.
//   * torch_on / torch_off: M3 / M5 (torch or spindle). `spindle_speed` carries S at M3.
// Feeds are in mm/min as in the program (F); the executor converts to mm/s at its edge.
#pragma once

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
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // mm, absolute (arc)
  bool clockwise = false;                     // arc
  int turns = 0;                              // arc: extra full turns beyond the first pass
  double seconds = 0.0;                       // dwell
  double spindle_speed = 0.0;                 // torch_on (S word, rpm or machine units)
};

const char* to_string(Move::Kind kind);

struct Program {
  std::string source;                 // file name, for messages
  Eigen::Vector3d start = Eigen::Vector3d::Zero();  // position before the first move, mm
  std::vector<Move> moves;
  bool ends_with_program_end = false;  // M2 or M30 seen
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
