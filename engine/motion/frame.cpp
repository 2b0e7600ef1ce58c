#include "engine/motion/frame.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::motion {

namespace {

// The rectangle round the segments of the stretches `take` selects; empty when none.
template <class Take>
Eigen::AlignedBox2d extent(const Job& job, Take take) {
  Eigen::AlignedBox2d box;  // empty
  for (const Stretch& s : job.stretches)
    if (take(s))
      for (const Segment& g : s.segments) box.extend(bounding_box(g));
  return box;
}

Segment line(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return make_segment(a, b, 0.0); }

// One move step over the segments; none when they carry no motion.
void add_move(Job& job, std::vector<Segment> segments, double feed_mm_per_s, bool rapid) {
  std::erase_if(segments, [](const Segment& g) { return length(g) <= 1e-9; });
  if (segments.empty()) return;
  Stretch s;
  s.rapid = rapid;
  s.feed_mm_per_s.assign(segments.size(), feed_mm_per_s);
  s.source_lines.assign(segments.size(), 0);
  s.segments = std::move(segments);
  Step step;
  step.kind = Step::Kind::move;
  step.stretch = job.stretches.size();
  job.stretches.push_back(std::move(s));
  job.steps.push_back(step);
}

}  // namespace

Frame frame_job(const Job& job, const FrameOptions& o) {
  const auto positive = [&](double v, const char* field) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError::field(field, fmt::format("{} must be a positive speed, mm/s", v));
  };
  positive(o.feed_mm_per_s, "feed_mm_per_s");
  positive(o.rapid_feed_mm_per_s, "rapid_feed_mm_per_s");
  if (!(std::isfinite(o.margin_mm) && o.margin_mm >= 0.0 && o.margin_mm <= 1000.0))
    throw InputError::field("margin_mm", fmt::format("{} must be 0 .. 1000 mm", o.margin_mm));
  if (!(o.pointer_offset_mm.allFinite() && o.pointer_offset_mm.cwiseAbs().maxCoeff() <= 1000.0))
    throw InputError::field("pointer_offset_mm", "must be finite, within 1000 mm of the torch");

  Frame f;
  f.outline = extent(job, [](const Stretch& s) { return s.cutting; });
  if (f.outline.isEmpty()) {
    f.from_cuts = false;
    f.outline = extent(job, [](const Stretch& s) { return !s.rapid; });
  }
  if (f.outline.isEmpty())
    throw InputError(job.source, 0, "the job has no cut and no feed move: there is no outline to frame");
  const Eigen::Vector2d grow = Eigen::Vector2d::Constant(o.margin_mm);
  f.outline = Eigen::AlignedBox2d(f.outline.min() - grow, f.outline.max() + grow);

  const Eigen::Vector2d lo = f.outline.min() - o.pointer_offset_mm, hi = f.outline.max() - o.pointer_offset_mm;
  const Eigen::Vector2d lr(hi.x(), lo.y()), ul(lo.x(), hi.y());
  f.job.source = job.source.empty() ? std::string("frame") : "frame of " + job.source;
  f.job.start_mm = job.start_mm;
  f.job.laser_pointer = o.laser;
  add_move(f.job, {line(job.start_mm, lo)}, o.rapid_feed_mm_per_s, true);
  add_move(f.job, {line(lo, lr), line(lr, hi), line(hi, ul), line(ul, lo)}, o.feed_mm_per_s, false);
  add_move(f.job, {line(lo, job.start_mm)}, o.rapid_feed_mm_per_s, true);
  return f;
}

}  // namespace machplan::motion
