// The executor's plan of work: a part program cut into motion stretches and torch events,
// and the trajectory interface the real-time loop samples.
//
// Data flow:
//
//   Program --make_job--> Job (stretches of programmed XY geometry + steps)
//           --kerf (engine/motion/kerf)--> Job with compensated cutting stretches
//           --rapid planning (solvers/motion, OMPL)--> Job with rapid stretches re-routed
//           --feed planning (engine/motion/feed_planner)--> one Trajectory per move step
//           --executor (engine/executor)--> servo loop at 1 kHz against a Backend
//
// A Stretch is the geometry the program asks for between two events that require the tool
// to be at rest (torch on/off, dwell, program start/end, a change between rapid and feed).
// Everything is in the XY plane: the thermal gantry's torch height and the XY table's
// operator are not programmed through Z (make_job refuses Z motion, naming the line).
//
// Units: mm, s, rad. Feeds are mm/s here; the program's F (mm/min) is converted by make_job.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/geometry/contour.h"

namespace machplan {
struct Program;
}

namespace machplan::motion {

// The commanded state of the tool point at one instant.
struct Setpoint {
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity_mm_per_s = Eigen::Vector2d::Zero();
  Eigen::Vector2d acceleration_mm_per_s2 = Eigen::Vector2d::Zero();
};

// One rest-to-rest motion, planned completely before execution starts.
//
// Real-time contract: sample() neither allocates, throws, locks nor does I/O, and runs in
// bounded time (the executor calls it once per servo period). It is const and may be called
// from any thread. Times outside [0, duration_s()] are clamped: before 0 the start state,
// after the end the end state with zero velocity and acceleration.
struct Stretch;
class Trajectory {
 public:
  virtual ~Trajectory() = default;
  virtual double duration_s() const = 0;
  virtual void sample(double t_s, Setpoint& out) const = 0;
  // The path the setpoints follow when it is not the stretch's programmed one (a planner that
  // rounds corners: its executed path), else null. Contour controllers follow this path.
  virtual const Stretch* followed_path() const { return nullptr; }
  // How long from t_s the motion goes on at constant path speed on the same piece of path (no
  // speed change, no change of curvature), s; 0 when it is not cruising or does not know.
  // What a feed override above 100 % may use (engine/executor/time_scale.h). Real time.
  virtual double cruise_left_s(double t_s) const {
    (void)t_s;
    return 0.0;
  }
};

// Programmed geometry between two rest events. `segments` are contiguous (each starts where
// the previous ended, within 1e-6 mm). Per-segment vectors have the same length as
// `segments`.
struct Stretch {
  bool cutting = false;                 // torch on during this stretch
  bool rapid = false;                   // G0 (feed is the machine's rapid speed)
  std::vector<Segment> segments;        // programmed path in the XY plane, mm
  std::vector<double> feed_mm_per_s;    // programmed feed per segment (rapid: rapid feed)
  std::vector<int> source_lines;        // 1-based program line per segment
  // Per segment, when not empty: torch height control held off there (QtPlasmaC's M62/M64 P2;
  // M63/M65 P2 let it act again). Empty: THC may act on the whole stretch.
  std::vector<std::uint8_t> thc_off;
};

// A plasma material's cutting parameters (QtPlasmaC's material file, engine/motion/
// materials.h), for the cuts made while it is in force. Feeds are applied when the job is
// made; the executor takes the heights, delays and volts at each torch_on.
struct CutParameters {
  int number = 0;                    // the material file's [MATERIAL_NUMBER_n] (0: temporary)
  std::string name;
  double pierce_height_mm = 3.8;
  double pierce_delay_s = 0.5;
  double cut_height_mm = 1.5;
  double cut_feed_mm_per_s = 0.0;    // CUT_SPEED
  double kerf_mm = 0.0;              // KERF_WIDTH (0: not given)
  bool thc = true;                   // THC (0: torch height control off for this material)
  double puddle_jump_height_pct = 0.0;  // of the pierce height (0: no puddle jump)
  double puddle_jump_delay_s = 0.0;
  double cut_amps = 0.0, cut_volts = 0.0;  // cut_volts 0: THC samples its target
  double pause_at_end_s = 0.0;       // at the end of each cut, torch on, before it goes off
  // A moving pierce for thick plate (ramp; PIERCE_TYPE 2): `pierce_motion_delay_pct` of the
  // pierce delay after the arc the torch starts along the cut at the gouge speed for the gouge
  // distance, then at the creep speed for the creep distance, then at the cut's feed; its
  // height goes from the pierce height to the pierce end height (0: the cut height) over the
  // rest of the delay and stays there `cut_height_delay_s` before going to cut height. The
  // molten metal is blown back along the kerf instead of up into the nozzle.
  bool ramp_pierce = false;
  double pierce_motion_delay_pct = 0.0, pierce_end_height_mm = 0.0, cut_height_delay_s = 0.0;
  double gouge_speed_mm_per_s = 0.0, gouge_distance_mm = 0.0, creep_speed_mm_per_s = 0.0, creep_distance_mm = 0.0;
};

// One thing the executor does, in order.
struct Step {
  // probe: the offset probe finds the sheet under the probe, where the torch stands plus the
  // probe's offset (engine/motion/offset_probe.h inserts it); the next torch_on takes that
  // surface.
  enum class Kind { move, torch_on, torch_off, dwell, probe };
  Kind kind = Kind::move;
  int source_line = 0;
  std::size_t stretch = 0;  // move: index into Job::stretches
  double seconds = 0.0;     // dwell
  // torch_off: the height the torch retracts to, mm, when above the machine's retract height
  // (a rapid over parts already cut follows: solvers/motion/rapids.h); 0: the retract height.
  double height_mm = 0.0;
  // torch_on: the material of the cut it starts, an index into Job::materials (-1: the
  // machine file's torch settings).
  int material = -1;
};

struct Job {
  std::string source;                               // program file, for messages
  Eigen::Vector2d start_mm = Eigen::Vector2d::Zero();  // tool position before the first step
  std::vector<Stretch> stretches;
  std::vector<Step> steps;
  std::vector<CutParameters> materials;             // those the job's cuts use (Step::material)
  // A frame traced by the laser pointer (engine/motion/frame.h): its output is on while the
  // job's moves run.
  bool laser_pointer = false;
};

}  // namespace machplan::motion
