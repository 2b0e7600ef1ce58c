// How long a job's torch process and dwells keep the axes at rest, whatever the motion does.
//
// The executor holds the axes still while the torch pierces and retracts and during every
// dwell (engine/executor/executor.h), so a job's machine time is its motion plus this. Per
// torch_on step: `torch_on_s` (height sense, descent to pierce height, arc start or preheat,
// move to cut height), the arc start or preheat `start_s` and the pierce delay `pierce_s`, unless a dwell follows (a programmed
// G4 is the pierce delay; it is counted as a dwell); per torch_off step: `torch_off_s` (the
// retract); each dwell: its seconds.
//
// One function, two callers with their own numbers: the run's expected time takes the machine
// file's nominal delays and speeds (solvers/motion/run.h), the executor's upper estimate (for
// its trace buffer) takes the timeouts it would wait at most.
#pragma once

#include "engine/motion/job.h"

namespace machplan::motion {

struct TorchTimes {
  double torch_on_s = 0.0;   // a torch_on step's height moves (sense, down to pierce height, to cut height)
  double start_s = 0.0;      // then the arc start (plasma) or the preheat (oxy-fuel)
  double pierce_s = 0.0;     // the pierce delay when no dwell follows the torch_on
  double torch_off_s = 0.0;  // a torch_off step
};

double process_time_s(const Job& job, const TorchTimes& times);

}  // namespace machplan::motion
