// Run from line, as LinuxCNC's: a job started at a program line, with the state the program had
// there, reached by a safe rapid.
//
// The job is read, placed and kerf-compensated whole, so every modal word before the line has
// done its work (units, offsets, feeds are in the canonical moves already). start_at_line()
// then cuts it at the first step, in execution order, whose program line is `line` or later
// (a move may be entered at the segment of that line):
//
//     [what was cut before the line]   kept aside, for the rapid planner only
//     rapid from the job's start to the point where the line begins
//     torch on (a new pierce) when the torch was lit there and the line is not itself a
//         torch step; a spindle is started the same way
//     the rest of the job, step for step as in the full job
//
// The cuts before the line are given to the rapid planner as parts already cut (they were, on
// the run that stopped), so that the rapids after the line are planned exactly as in the full
// run: the moves executed after the start are the full run's from that line on. The caller
// plans the rapids on the returned job, then drops the prefix (drop_prefix).
#pragma once

#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "engine/motion/job.h"

namespace machplan::motion {

struct LineStart {
  int line = 0;                     // as asked
  std::size_t step = 0;             // of the full job where the run starts
  std::size_t segment = 0;          // of that step's stretch, when it is a move
  Eigen::Vector2d at_mm = Eigen::Vector2d::Zero();  // where the start point is
  bool relight = false;             // the torch (or spindle) is started there first
  std::size_t prefix_steps = 0, prefix_stretches = 0;  // the cuts before, kept aside
};

// The job from `line` on (see the file comment), the cuts before it in front as a prefix.
// InputError::field("from_line", ...) when no step of the job is at or after the line.
Job start_at_line(const Job& job, int line, double rapid_feed_mm_per_s, LineStart& start);

// A straight rapid from `from` to `to` at program line `line`, added to job.stretches; returns
// the move step that runs it, for the caller to put in place. The rapid planner routes it.
Step new_rapid(Job& job, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double rapid_feed_mm_per_s, int line);

// A job of one rapid from `from_mm` to `to_mm`, made as the rapid a run from a line starts
// with: how the panel brings the machine to a job's start. Planned as any job (plan_job), its
// rapid is routed round the declared no-go zones.
Job rapid_job(const Eigen::Vector2d& from_mm, const Eigen::Vector2d& to_mm, double rapid_feed_mm_per_s, std::string source);

// Removes the prefix that start_at_line() put in front, renumbering the stretches.
void drop_prefix(Job& job, const LineStart& start);

}  // namespace machplan::motion
