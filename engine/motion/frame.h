// Framing: before a job is cut, the torch traces the job's outline with the torch off, so that
// the operator sees on the machine that the job lies where the sheet is (QtPlasmaC's "frame").
//
// The outline is the rectangle round everything the torch will cut, as the job will run it
// (the kerf applied: the path of the torch's centre), grown by `margin_mm` on every side. The
// frame job starts where the job starts, goes there with a rapid, traces the rectangle once
// at `feed_mm_per_s` (lower left, lower right, upper right, upper left, lower left) with the
// torch off, and returns to the job's start with a rapid: the machine ends where it began, so
// the job can be cut next without moving anything. A job that cuts nothing is framed by the
// rectangle round its feed moves (a marking or scribing job); one with no feed move at all
// has nothing to frame and is refused.
//
// The frame job is an ordinary Job: plan_job (solvers/motion/run.h) checks it against the
// travel and the declared no-go zones and plans it like any other.
//
// Errors: InputError naming the job's source and the field (feed_mm_per_s, margin_mm) or
// saying that there is nothing to frame. Pure function.
#pragma once

#include <Eigen/Geometry>

#include "engine/motion/job.h"

namespace machplan::motion {

struct FrameOptions {
  // Speed along the outline, mm/s (> 0; plan_frame in solvers/motion/run.h puts the machine's
  // rapid speed in place of 0).
  double feed_mm_per_s = 0.0;
  // Speed of the rapids to and from the outline, mm/s (> 0; plan_frame: the machine's).
  double rapid_feed_mm_per_s = 0.0;
  // Added round the cut path's rectangle on every side, mm (>= 0, at most 1000).
  double margin_mm = 0.0;
  // Where the point that traces lies from the torch, mm: a laser pointer's offset (0: the
  // torch itself). The axes trace the outline less this, so that the point traces it.
  Eigen::Vector2d pointer_offset_mm = Eigen::Vector2d::Zero();
  // The laser pointer traces it (Job::laser_pointer: its output on while the frame moves).
  bool laser = false;
};

struct Frame {
  Eigen::AlignedBox2d outline;  // the rectangle traced (by the pointer), mm
  bool from_cuts = true;        // false: the job cuts nothing, its feed moves were framed
  Job job;                      // start, rapid, the outline, rapid back; the torch never on
};

Frame frame_job(const Job& job, const FrameOptions& options);

}  // namespace machplan::motion
