// Offset probing (QtPlasmaC's offset probe): a probe mounted beside the torch, at a fixed x, y
// offset from it, finds the sheet before a pierce. The torch cannot probe where it stands, so
// the job itself carries the probing: before each pierce that probes, the torch goes where the
// probe stands over the pierce point (the pierce point less the offset), a probe step finds the
// surface there (engine/executor/torch_sequencer.h: deploy, probe, stow), and the torch goes
// back to pierce over that surface.
//
// Which pierces probe follows the executor's skip rule (ProbeSetup::skip_distance_mm): a pierce
// within that distance, in x and y, of the last probed point takes the surface map's estimate
// and gets no probe. The rapid that brought the torch to the pierce ends at the probing
// position instead (a straight rapid, routed by the rapid planner like any other); the rapid
// back is a new one. Both are part of the planned job: the travel check, the rapid planner, the
// time estimate and the executor see them as they see the program's own moves.
#pragma once

#include <cstddef>

#include "engine/executor/machine_setup.h"
#include "engine/motion/job.h"

namespace machplan::motion {

// Inserts the probing before each torch_on from step `first` on (the steps before it are a
// run from a line's prefix, never run) and returns how many probes it inserted. The new rapids
// run at `rapid_feed_mm_per_s` and carry the torch_on's program line. Nothing when `probe` has
// no offset probe.
std::size_t insert_offset_probes(Job& job, const executor::ProbeSetup& probe, double rapid_feed_mm_per_s,
                                 std::size_t first = 0);

}  // namespace machplan::motion
