// Hybrid manual / servo-assisted machining on the simulated XY table: the pipeline behind
// `machplan guard`, also used by the tests and the bench so that all three run the same thing.
//
//   profile (closed contours, from a DXF) --ProhibitedRegion::build--> region (tool radius R)
//   operator (script | random:N | joystick | keys) --jog source--> Guard (engine/executor/
//       guard.h, strategy paper or predictive, tolerance T, link latency L) --> controller
//       --> simulated XY table (models/sim)
//   [--finish] automatic mode: from where the operator left the tool touching the part, the
//       planner contours the whole offset profile at the finishing feed (optionally first at
//       an over-dimension, the paper's proposed double pass), through the executor's planned
//       mode
//
// Attempts. Each push of the stick (a script row with a speed, a stroke of the random
// operator, a deflection of a live stick after a release) that brings the tool into the
// tolerance band (d <= T) or makes the guard act is one attempt. Its window runs from the push
// to the next push (or the end). Per attempt, from the table's TRUE position (the simulator's):
//   closest_mm   the least signed distance to the prohibited region's boundary (the offset
//                profile) in the window; where the tool stopped, as the paper measured
//   success      closest_mm >= -1e-6 mm (rounding): the tool centre never entered the prohibited region
//   invasion_mm  max(0, -closest_mm): how deep it went in (cut into the part)
//   undercut_mm  max(0, closest_mm) for a success: material left beyond the offset profile
// Totals: attempts, successes, invasions, max invasion, mean and max under-cut over the
// successes (the paper's Tables 2 and 3 average the under-cut of the successes), time.
//
// The random operator (random:N, seeded): N strokes, each aimed at a random point of the
// boundary (uniform along its length) from a random place T + 2 + feed x 0.05 .. T + 12 +
// feed x 0.05 mm away from it, within 60 degrees of the boundary's normal there (an operator
// roughing pushes at the profile, not along it), pushed at the feed after a random reaction time of
// 0 .. 0.2 s + L (so the link's answers fall at random phases of the approach) until the guard
// holds the table at rest or the aim would have been passed by 0.5 s, then released. Each
// stroke is one jog session from its start point.
//
// A panel (the web panel of `machplan serve`) drives a session through a GuardLink: the
// operator kind `panel` reads the stick the panel writes (the browser's keys, on-screen stick
// or gamepad) instead of a device, paced to the wall clock like a joystick; the panel's E-stop
// opens the operator E-stop input of every period; and the session's state (phase, table
// position, signed distance to the boundary, the guard holding) is published every period for
// the panel's live view. Everything else (the region, the guard, the attempts, the finishing
// pass) is the same code as `machplan guard`'s.
//
// Errors: bad options, profiles, scripts or devices throw InputError (exit 2 in the CLI).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/latest.h"
#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/executor/guard.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/region.h"
#include "engine/hardware/operator_input.h"

namespace machplan::guard {

struct OperatorSpec {
  // panel: the stick of a GuardLink (never read from text: a panel sets it).
  enum class Kind { script, random, joystick, keys, panel };
  Kind kind = Kind::random;
  std::string path;   // script: the CSV; joystick: the device (default /dev/input/js0)
  int strokes = 20;   // random
};
const char* to_string(OperatorSpec::Kind k);
// "FILE.csv" | "random:N" (1 <= N <= 100000) | "joystick[:DEVICE]" | "keys";
// throws InputError::field("op", ...).
OperatorSpec operator_from_string(const std::string& text);

struct GuardRunOptions {
  std::string machine = "xy_table";     // bundled name or YAML path
  RegionOptions region;                 // side, tool radius, offset method
  executor::GuardOptions guard;         // strategy, T, L
  double feed_mm_per_s = 12.0;          // operator speed (random operator, and the jog limit)
  OperatorSpec op;
  bool finish = false;                  // run the automatic finishing pass after roughing
  double finish_feed_mm_per_s = 0.0;    // 0: the feed
  double finish_allowance_mm = 0.0;     // > 0: first pass this far off the profile, then the final one
  std::uint64_t seed = 1;
  double max_session_s = 3600.0;        // a live or scripted session ends after this
  // The machine: "sim" (the simulated table) or "hal" (through LinuxCNC's HAL; not with the
  // random operator, whose strokes each start somewhere else).
  std::string backend = "sim";
  void validate() const;                // InputError::field naming the field ("guard.tolerance_mm")
};

struct Attempt {
  int index = 0;
  Eigen::Vector2d start_mm{0, 0};       // where the push began
  Eigen::Vector2d aim_mm{0, 0};         // random: the aimed boundary point; else start + direction
  Eigen::Vector2d closest_at_mm{0, 0};  // where the tool came closest (stopped)
  double speed_mm_per_s = 0.0;
  double closest_mm = 0.0, invasion_mm = 0.0, undercut_mm = 0.0;
  bool success = true;
  double time_s = 0.0;
  std::vector<Eigen::Vector2d> path_mm; // true positions, every 10 ms
};

struct FinishPass {
  double allowance_mm = 0.0;            // 0: the final pass on the offset profile
  bool completed = false;
  std::string fault;                    // empty when completed
  double time_s = 0.0;
  double max_deviation_mm = 0.0;        // max |distance of the true position from the pass's path|
  double rms_deviation_mm = 0.0;
  double max_from_profile_mm = 0.0;     // final pass: max |signed distance to the offset profile|
  std::size_t samples = 0;
  std::vector<Eigen::Vector2d> path_mm; // true positions, every 10 ms
};

struct GuardRunResult {
  std::string profile_source, machine;
  GuardRunOptions options;
  std::vector<Contour> profile;
  std::vector<Contour> boundary;        // the region's boundary (offset profile)
  std::vector<std::string> warnings;    // region problems
  std::vector<Attempt> attempts;
  int strokes = 0;                      // pushes, attempts or not
  int successes = 0, invasions = 0;
  double max_invasion_mm = 0.0, mean_undercut_mm = 0.0, max_undercut_mm = 0.0;
  double roughing_time_s = 0.0, finishing_time_s = 0.0;
  long guard_stops = 0, guard_failsafe_ticks = 0, guard_emergency_ticks = 0;
  std::vector<FinishPass> finish;
  bool quit_by_operator = false;
  // How the session ended (done, or cancelled by a stop request), with the brief and the full
  // report for people.
  Summary summary;

  double success_percent() const { return attempts.empty() ? 0.0 : 100.0 * successes / attempts.size(); }
  std::string report() const;
};

// A guard session's state for a display, published every period (GuardLink::live).
struct GuardLive {
  enum class Phase : std::uint8_t { roughing, finishing, done };
  Phase phase = Phase::roughing;
  double t_s = 0.0;                                        // since the phase began
  Eigen::Vector2d position_mm = Eigen::Vector2d::Zero();   // the table (the simulator's truth)
  double distance_mm = 0.0;  // signed distance of the tool centre to the boundary (> 0: allowed)
  bool guard_holding = false;                              // the guard holds the table back
  int strokes = 0;                                         // pushes so far
};

// What a panel attaches to a session; every member may be null. The pointees must outlive the
// run. Read and written from the session's thread between ticks (one atomic load each).
struct GuardLink {
  const std::atomic<std::uint64_t>* stick = nullptr;  // hardware::LiveOperator::pack()ed StickState
  const std::atomic<bool>* estop = nullptr;           // true: the operator's E-stop is open
  Latest<GuardLive>* live = nullptr;
  bool paced_finish = false;                          // pace the finishing pass to the wall clock too
};

// Runs the whole thing on `profile` (closed contours in mm). `source` names the profile in
// messages and reports.
// `termination` ends the session early: a stop request ends the stroke under way
// (the machine stops in a controlled way) and the rest; the result then counts the attempts
// made and its summary says why it ended. `progress` (may be null) follows the strokes
// (random), the script's time (script), and the finishing pass.
// `link` (may be null) connects a panel (see the file comment); the operator kind `panel` needs
// its stick.
GuardRunResult run_guard(const std::vector<Contour>& profile, const std::string& source, const GuardRunOptions& options,
                         Termination& termination, Progress* progress = nullptr, const GuardLink* link = nullptr);

// Reads the DXF (refusing drawings with errors, naming them) and runs run_guard.
GuardRunResult run_guard_file(const std::string& dxf_path, const GuardRunOptions& options, Termination& termination,
                              Progress* progress = nullptr, const GuardLink* link = nullptr);
// The closed contours of a DXF profile as run_guard_file reads them (drawings with errors
// refused, naming them); its warnings are added to `warnings`.
std::vector<Contour> read_guard_profile(const std::string& dxf_path, std::vector<std::string>& warnings);

// The picture of the paper's Figure 8: profile, offset region, roughing strokes, finishing path.
// `field` names the option that gave `path` in a message about its extension.
void write_guard_plot(const GuardRunResult& r, const std::string& path, const std::string& field = "plot");

}  // namespace machplan::guard
