// What the machine is doing now, as the executor's tick sees it: published every period into a
// Latest<LiveState> (engine/common/latest.h) for a display (the web panel's live stream, a
// terminal). The tick never waits for a reader and allocates nothing to publish.
#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace machplan::executor {

struct LiveState {
  enum class Run : std::uint8_t { idle, running, held, stopping, faulted, done };
  Run run = Run::idle;
  // Which executor session published it: a new number for every session of the process, from
  // 1 (0: none yet). With `tick`, what a reader needs to know whether the run it sees is the
  // one it spoke to.
  std::uint32_t session = 0;
  std::uint64_t tick = 0;
  double t_s = 0.0;                 // since the start of the run
  int step = -1;                    // into the job's steps (-1: none)
  int source_line = 0;              // program line being executed (0: none)
  Eigen::Vector2d commanded_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d measured_mm = Eigen::Vector2d::Zero();
  double path_speed_mm_per_s = 0.0; // commanded
  double rate = 1.0;                // of the plan: 0 held .. 2 (time_scale.h)
  double feed_override_pct = 100.0, rapid_override_pct = 100.0;  // as asked
  // The feed override as the machine will really run the feed moves left: above 100 % only
  // where its limits leave room (a job cut at the machine's top speed stays at 100 % whatever
  // is asked); the asked one when the source cannot say.
  double feed_effective_pct = 100.0;
  bool drives_enabled = false, torch_fire = false, arc_ok = false;
  bool laser_on = false;            // the laser pointer (a frame traced with it)
  double torch_height_mm = 0.0;
  bool thc_active = false;          // torch height control is holding the height (plasma)
  double arc_voltage_v = 0.0;       // when the backend reports it
  double progress = 0.0;            // share of the job's expected time done, 0 .. 1
  double time_left_s = 0.0;         // at the current overrides as the machine takes them; it stands still while held
  int fault = -1;                   // the first fault's FaultKind, -1: none
  int holds = 0;                    // holds so far
};

}  // namespace machplan::executor
