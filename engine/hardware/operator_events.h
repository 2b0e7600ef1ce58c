// An operator's inputs on a timeline: what the simulator plays to the executor in place of a
// person at the panel (`machplan run --operator-events FILE.csv`), and what tests script.
//
// File format (CSV; '#' starts a comment; blank lines are ignored). The first data line is the
// header `t_s,event,value`; then one event a row, times in seconds from the start of the run,
// never decreasing:
//
//     t_s,event,value
//     12.5,hold,                feed hold: the motion comes to rest along the path
//     15.0,start,               cycle start: resume (re-pierce first when a cut was held)
//     18.0,feed_override,50     feed moves at 50 % (0 .. 200; 0 behaves as a hold)
//     20.0,rapid_override,25    rapids at 25 % (1 .. 100)
//     22.0,paused_motion,-30    while held: move 30 mm back along the program's path (torch
//                               off; -1000 .. 1000, not 0); `recover` is an older name
//     23.0,paused_motion_speed,0.5   while held: move on along the path at half the machine's
//                               paused-motion speed until it is set to 0 again (-1 .. 1)
//     24.0,thc,0                torch height control off (1: on)
//     26.0,torch,0              torch disabled: the job runs dry (1: enabled again)
//     30.0,stop,                end the job: controlled stop, torch off
//
// `value` is empty for hold, start and stop and required for the others. A button (hold,
// start, stop) is pressed at its time and released `kPress_s` later, so that the executor,
// which acts on a button's rising edge, sees every press; two presses of the same button
// closer than that are refused. Errors name FILE:LINE: an unknown event, a missing or extra
// value, a number out of range, a time that goes back or lies beyond 1e7 s, more than
// 100 000 rows.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "engine/hardware/backend.h"

namespace machplan::hardware {

// The state of the operator's panel from `at_s` on (until the next event).
struct OperatorEvent {
  double at_s = 0.0;
  OperatorInputs inputs;
};

inline constexpr double kPress_s = 0.01;

// One row as written, for reports.
struct OperatorEventRow {
  enum class Kind { hold, start, stop, feed_override, rapid_override, paused_motion, paused_motion_speed, thc, torch };
  Kind kind = Kind::hold;
  double t_s = 0.0;
  double value = 0.0;
  int line = 0;
};
const char* to_string(OperatorEventRow::Kind k);

struct OperatorTimeline {
  std::string source;
  std::vector<OperatorEventRow> rows;
  // The panel's states in time order, from the default state (no button, overrides 100 %,
  // THC on) at 0.
  std::vector<OperatorEvent> states;
};

OperatorTimeline parse_operator_events(std::string_view text, const std::string& source);
OperatorTimeline read_operator_events(const std::string& path);

}  // namespace machplan::hardware
