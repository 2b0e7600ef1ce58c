// Turning an interpreted part program into the executor's plan of work (a Job).
//
// make_job walks the canonical moves of a Program once and groups them:
//
//   * consecutive rapids form one rapid Stretch (feed = JobOptions::rapid_feed_mm_per_s);
//   * consecutive lines and arcs form one feed Stretch, `cutting` when the torch is on
//     (an M3 was seen and no M5 since);
//   * torch_on, torch_off and dwell become Steps of their own and end the current stretch,
//     because the tool must be at rest for them; a change between rapid and feed ends it too.
//     Every stretch is therefore one rest-to-rest motion, and Job::steps lists, in program
//     order, a `move` step per stretch and the torch and dwell steps between them.
//
// Geometry: lines become line Segments; an arc becomes one or more arc Segments about the
// programmed centre with the radius of its start point. A Segment holds |sweep| < 2 pi, so a
// full circle (start = end) and the extra turns of a P word are split into equal parts of at
// most pi each. Zero-length moves (end = start within 1e-9 mm, or a degenerate arc of zero
// radius) are dropped, since they carry no motion. Feeds: F is mm/min in the program,
// mm/s in the Job.
//
// What is refused (InputError naming the program and line):
//   * any change of Z: these machines (plasma/oxy-fuel gantry, XY table) have no programmable
//     Z axis, so a Z word that moves the tool is not silently flattened;
//   * a helical arc (an arc whose Z changes), named as such;
//   * an arc in the XZ or YZ plane (G18, G19), named as such;
//   * a line or arc with no feed (F missing or zero).
//
// QtPlasmaC programs: material changes, temporary materials, THC and torch switches, velocity
// reduction, hole rules and pierce only are applied as engine/motion/plasma_words.h describes.
//
// Thread safety: pure function. Example:
//
//     Program p = read_gcode("part.ngc");
//     Job job = make_job(p, JobOptions{});
//     for (const Step& s : job.steps) ...
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/motion/job.h"
#include "engine/motion/materials.h"
#include "engine/programs/program.h"

namespace machplan::motion {

struct JobOptions {
  // Speed given to rapid stretches (G0), mm/s. The default is the thermal gantry's top feed
  // (4910 mm/min); the feed planner further caps it by the axis limits.
  double rapid_feed_mm_per_s = 4910.0 / 60.0;
  // Moves whose XY length is at most this are dropped as zero-length, mm.
  double zero_length_mm = 1e-9;
  // Largest change of Z accepted as "no change" (rounding in the program), mm.
  double z_tolerance_mm = 1e-9;

  // QtPlasmaC's words (engine/motion/plasma_words.h). The material file the program's M190
  // words select from (null: none; an M190 Pn, n >= 0, is then refused naming the line).
  const MaterialTable* materials = nullptr;
  // The material in force when the program selects none (and after M190 P-1): a number in
  // `materials`; -1: the machine's own torch settings.
  int default_material = -1;
  // The value the run gives F#<_hal[plasmac.cut-feed-rate]> (mm/min as the reader stores it,
  // or that x 25.4 under G20): moves with this feed take the material's CUT_SPEED. 0: none.
  double material_feed_marker_mm_per_min = 0.0;
  // The cut feed those moves take when no material is in force, mm/s (0: refused).
  double machine_cut_feed_mm_per_s = 0.0;

  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// The Segments of one line or arc move starting at `from` (XY; an arc about m.center, with
// its extra turns), arcs cut into pieces of at most half a turn; none for a move of XY length
// at most zero_length_mm (or an arc of smaller radius). The geometry make_job gives a move.
std::vector<Segment> move_segments(const Move& m, const Eigen::Vector2d& from, double zero_length_mm = 1e-9);

// See the file comment. Throws InputError(program.source, line, ...) on refused input and
// InputError naming the field when `options` is invalid.
Job make_job(const Program& program, const JobOptions& options = {});

}  // namespace machplan::motion
