#include "solvers/motion/from_line.h"

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::motion {

namespace {

// The first step at or after `line`, and the segment of a move.
bool find_line(const Job& job, int line, LineStart& at) {
  for (std::size_t s = 0; s < job.steps.size(); ++s) {
    const Step& st = job.steps[s];
    if (st.kind != Step::Kind::move) {
      if (st.source_line >= line) return at.step = s, at.segment = 0, true;
      continue;
    }
    const Stretch& k = job.stretches[st.stretch];
    for (std::size_t j = 0; j < k.segments.size(); ++j)
      if (k.source_lines[j] >= line) return at.step = s, at.segment = j, true;
  }
  return false;
}

Stretch part_of(const Stretch& k, std::size_t from, std::size_t to) {
  Stretch out;
  out.cutting = k.cutting;
  out.rapid = k.rapid;
  out.segments.assign(k.segments.begin() + from, k.segments.begin() + to);
  out.feed_mm_per_s.assign(k.feed_mm_per_s.begin() + from, k.feed_mm_per_s.begin() + to);
  out.source_lines.assign(k.source_lines.begin() + from, k.source_lines.begin() + to);
  if (!k.thc_off.empty()) out.thc_off.assign(k.thc_off.begin() + from, k.thc_off.begin() + to);
  return out;
}

void add_move(Job& job, Stretch s, int line) {
  job.stretches.push_back(std::move(s));
  Step st;
  st.kind = Step::Kind::move;
  st.source_line = line;
  st.stretch = job.stretches.size() - 1;
  job.steps.push_back(st);
}

void add_rapid(Job& job, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double rapid_feed_mm_per_s, int line) {
  job.steps.push_back(new_rapid(job, from, to, rapid_feed_mm_per_s, line));
}

}  // namespace

Step new_rapid(Job& job, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double rapid_feed_mm_per_s, int line) {
  Stretch r;
  r.rapid = true;
  r.segments.push_back(make_segment(from, to, 0.0));
  r.feed_mm_per_s.push_back(rapid_feed_mm_per_s);
  r.source_lines.push_back(line);
  job.stretches.push_back(std::move(r));
  Step st;
  st.kind = Step::Kind::move;
  st.source_line = line;
  st.stretch = job.stretches.size() - 1;
  return st;
}

Job rapid_job(const Eigen::Vector2d& from_mm, const Eigen::Vector2d& to_mm, double rapid_feed_mm_per_s, std::string source) {
  Job job;
  job.source = std::move(source);
  job.start_mm = from_mm;
  add_rapid(job, from_mm, to_mm, rapid_feed_mm_per_s, 0);
  return job;
}

Job start_at_line(const Job& job, int line, double rapid_feed_mm_per_s, LineStart& start) {
  start = LineStart{};
  start.line = line;
  if (!find_line(job, line, start)) {
    int last = 0;
    for (const Step& st : job.steps) last = std::max(last, st.source_line);
    throw InputError::field("from_line", fmt::format("line {} comes after the program's last step (line {})", line, last));
  }
  // The state at the start: the torch, and where the tool is.
  bool lit = false;
  int material = -1;  // of the cut lit last
  Eigen::Vector2d at = job.start_mm;
  for (std::size_t s = 0; s < start.step; ++s) {
    const Step& st = job.steps[s];
    if (st.kind == Step::Kind::torch_on) lit = true, material = st.material;
    if (st.kind == Step::Kind::torch_off) lit = false;
    if (st.kind != Step::Kind::move) continue;
    const Stretch& k = job.stretches[st.stretch];
    if (!k.cutting) lit = false;  // the executor turns the torch off before a move that does not cut
    at = k.segments.back().end;
  }
  const Step& first = job.steps[start.step];
  const bool in_move = first.kind == Step::Kind::move;
  if (in_move) at = job.stretches[first.stretch].segments[start.segment].start;
  start.at_mm = at;
  start.relight = lit && first.kind != Step::Kind::torch_on && first.kind != Step::Kind::torch_off &&
                  (!in_move || job.stretches[first.stretch].cutting);

  Job out;
  out.source = job.source;
  out.start_mm = job.start_mm;
  out.materials = job.materials;
  // What was cut before the line: the rapid planner's parts cut so far.
  for (std::size_t s = 0; s < start.step; ++s) {
    const Step& st = job.steps[s];
    if (st.kind == Step::Kind::move && job.stretches[st.stretch].cutting) add_move(out, job.stretches[st.stretch], st.source_line);
  }
  if (in_move && start.segment > 0 && job.stretches[first.stretch].cutting)
    add_move(out, part_of(job.stretches[first.stretch], 0, start.segment), first.source_line);
  start.prefix_steps = out.steps.size();
  start.prefix_stretches = out.stretches.size();

  // The safe rapid to the start, and the torch lit there.
  if ((at - job.start_mm).norm() > 1e-9) add_rapid(out, job.start_mm, at, rapid_feed_mm_per_s, line);
  if (start.relight) {
    Step on;
    on.kind = Step::Kind::torch_on;
    on.source_line = line;
    on.material = material;
    out.steps.push_back(on);
  }
  // The rest, as in the full job.
  std::size_t s = start.step;
  if (in_move) {
    const Stretch& k = job.stretches[first.stretch];
    add_move(out, part_of(k, start.segment, k.segments.size()), first.source_line);
    ++s;
  }
  for (; s < job.steps.size(); ++s) {
    Step st = job.steps[s];
    if (st.kind == Step::Kind::move) {
      out.stretches.push_back(job.stretches[st.stretch]);
      st.stretch = out.stretches.size() - 1;
    }
    out.steps.push_back(st);
  }
  return out;
}

void drop_prefix(Job& job, const LineStart& start) {
  job.steps.erase(job.steps.begin(), job.steps.begin() + static_cast<std::ptrdiff_t>(start.prefix_steps));
  job.stretches.erase(job.stretches.begin(), job.stretches.begin() + static_cast<std::ptrdiff_t>(start.prefix_stretches));
  for (Step& st : job.steps)
    if (st.kind == Step::Kind::move) st.stretch -= start.prefix_stretches;
}

}  // namespace machplan::motion
