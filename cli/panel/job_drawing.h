// What the panel's page draws of a planned job, and the panel's run from a line.
//
// job_drawing_json: GET /api/job's document. Every stretch of the job as it will run (after
// kerf and rapid planning) becomes one path of x, y pairs in mm (arcs as chords within
// 0.05 mm of the arc, at most 256 per arc), with its kind (rapid, cut or move: a feed move
// with the torch off) and first program line; the closed cuts as parts; the pierce points
// (where each torch_on step fires); the bounds of all that and the machine's travel; the
// estimate. Numbers are written with 3 decimals (1 um), so a 100,000-move job is a few MB.
//
// job_from_line: the job from program line `line` on, as LinuxCNC's run from line: the first
// step (in the order the job runs) whose line is `line` or later starts it; a move step that
// holds that line is cut there and keeps the segments from it on; when the torch burns at
// that point (a torch_on before it and no torch_off since), the trimmed job starts with a
// torch_on (and the program's pierce dwell when its torch_on had one) at the start point. The
// tool reaches the start point with the panel's positioning rapid. InputError naming the job's
// source when no step has that line or a later one.
#pragma once

#include <string>

#include "engine/motion/job.h"
#include "solvers/motion/run.h"

namespace machplan::panel {

std::string job_drawing_json(const motion::PlannedRun& plan, int job_id);

motion::Job job_from_line(const motion::Job& job, int line);

}  // namespace machplan::panel
