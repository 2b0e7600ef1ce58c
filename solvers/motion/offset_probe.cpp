#include "solvers/motion/offset_probe.h"

#include <vector>

#include "solvers/motion/from_line.h"

namespace machplan::motion {

std::size_t insert_offset_probes(Job& job, const executor::ProbeSetup& probe, double rapid_feed_mm_per_s, std::size_t first) {
  if (!probe.offset()) return 0;
  const Eigen::Vector2d offset(probe.offset_x_mm, probe.offset_y_mm);
  std::vector<Step> steps;
  steps.reserve(job.steps.size());
  Eigen::Vector2d at = job.start_mm;
  bool probed = false;
  Eigen::Vector2d probed_at = Eigen::Vector2d::Zero();
  std::size_t inserted = 0;
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const Step st = job.steps[i];
    if (st.kind == Step::Kind::move) at = job.stretches[st.stretch].segments.back().end;
    const bool skipped = probed && probe.skip_distance_mm > 0 && (at - probed_at).cwiseAbs().maxCoeff() <= probe.skip_distance_mm;
    if (st.kind != Step::Kind::torch_on || i < first || skipped) {
      steps.push_back(st);
      continue;
    }
    const Eigen::Vector2d there = at - offset;  // the torch, with the probe over the pierce point
    // The rapid that brought the torch here ends where it probes instead (its last segment is a
    // straight line: a G0); otherwise a rapid of its own goes there.
    Stretch* before = !steps.empty() && steps.back().kind == Step::Kind::move ? &job.stretches[steps.back().stretch] : nullptr;
    if (before && before->rapid && !before->segments.back().is_arc() && i > first) {
      Segment& last = before->segments.back();
      last = make_segment(last.start, there, 0.0);
    } else {
      steps.push_back(new_rapid(job, at, there, rapid_feed_mm_per_s, st.source_line));
    }
    Step p;
    p.kind = Step::Kind::probe;
    p.source_line = st.source_line;
    steps.push_back(p);
    steps.push_back(new_rapid(job, there, at, rapid_feed_mm_per_s, st.source_line));
    steps.push_back(st);
    probed = true;
    probed_at = at;
    ++inserted;
  }
  job.steps = std::move(steps);
  return inserted;
}

}  // namespace machplan::motion
