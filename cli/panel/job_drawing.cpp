#include "cli/panel/job_drawing.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"

namespace machplan::panel {
namespace {

// Appends "x,y" (3 decimals) to `out`, with a comma before when `first` is false.
void point(std::string& out, const Eigen::Vector2d& p, bool& first) {
  if (!first) out += ',';
  first = false;
  fmt::format_to(std::back_inserter(out), "{:.3f},{:.3f}", p.x(), p.y());
}

// A segment's points after its start: the end of a line; chords of an arc within 0.05 mm.
template <class F>
void follow(const Segment& s, F&& add) {
  if (!s.is_arc() || s.radius <= 0) {
    add(s.end);
    return;
  }
  const double sag = std::min(0.05, s.radius * 0.5);
  const double step = 2.0 * std::acos(1.0 - sag / s.radius);
  const int n = std::clamp(static_cast<int>(std::ceil(std::abs(s.sweep) / std::max(step, 1e-6))), 1, 256);
  for (int i = 1; i < n; ++i) {
    const double a = s.start_angle + s.sweep * i / n;
    add(Eigen::Vector2d(s.center.x() + s.radius * std::cos(a), s.center.y() + s.radius * std::sin(a)));
  }
  add(s.end);
}

}  // namespace

std::string job_drawing_json(const motion::PlannedRun& plan, int job_id) {
  const motion::Job& job = plan.job;
  Eigen::AlignedBox2d box;
  box.extend(job.start_mm);
  std::string out;
  out.reserve(64 + job.stretches.size() * 64);
  fmt::format_to(std::back_inserter(out), "{{\"job_id\":{},\"source\":{},\"machine\":{},", job_id,
                 nlohmann::json(job.source).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                 nlohmann::json(plan.machine.name).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  fmt::format_to(std::back_inserter(out), "\"origin_mm\":[{:.3f},{:.3f}],\"start_mm\":[{:.3f},{:.3f}],", plan.origin_mm.x(),
                 plan.origin_mm.y(), job.start_mm.x(), job.start_mm.y());
  std::size_t moves = 0;
  out += "\"paths\":[";
  bool first_path = true;
  for (const motion::Step& st : job.steps) {
    if (st.kind != motion::Step::Kind::move || st.stretch >= job.stretches.size()) continue;
    const motion::Stretch& s = job.stretches[st.stretch];
    if (s.segments.empty()) continue;
    if (!first_path) out += ',';
    first_path = false;
    const char* kind = s.rapid ? "rapid" : s.cutting ? "cut" : "move";
    fmt::format_to(std::back_inserter(out), "{{\"kind\":\"{}\",\"line\":{},\"points\":[", kind,
                   s.source_lines.empty() ? 0 : s.source_lines.front());
    bool first = true;
    point(out, s.segments.front().start, first);
    box.extend(s.segments.front().start);
    for (const Segment& seg : s.segments) {
      follow(seg, [&](const Eigen::Vector2d& p) {
        point(out, p, first);
        box.extend(p);
      });
    }
    moves += s.segments.size();
    out += "]}";
  }
  out += "],\"parts\":[";
  bool first_part = true;
  for (const Contour& c : plan.cut_zones) {
    if (c.size() == 0) continue;
    if (!first_part) out += ',';
    first_part = false;
    out += '[';
    bool first = true;
    point(out, c.span(0).start, first);
    for (std::size_t i = 0; i < c.size(); ++i) follow(c.span(i), [&](const Eigen::Vector2d& p) { point(out, p, first); });
    out += ']';
  }
  out += "],\"pierces\":[";
  bool first_pierce = true;
  Eigen::Vector2d at = job.start_mm;
  for (const motion::Step& st : job.steps) {
    if (st.kind == motion::Step::Kind::move && st.stretch < job.stretches.size() && !job.stretches[st.stretch].segments.empty())
      at = job.stretches[st.stretch].segments.back().end;
    if (st.kind != motion::Step::Kind::torch_on) continue;
    if (!first_pierce) out += ',';
    bool first = true;
    out += '[';
    point(out, at, first);
    out += ']';
    first_pierce = false;
  }
  const Eigen::Vector2d travel(plan.machine.axes[0].travel_mm, plan.machine.axes[1].travel_mm);
  fmt::format_to(std::back_inserter(out),
                 "],\"bounds\":{{\"min\":[{:.3f},{:.3f}],\"max\":[{:.3f},{:.3f}]}},\"travel_mm\":[{:.3f},{:.3f}],"
                 "\"moves\":{},\"steps\":{},\"estimate_s\":{:.3f},\"lower_bound_s\":{:.3f}}}",
                 box.min().x(), box.min().y(), box.max().x(), box.max().y(), travel.x(), travel.y(), moves,
                 job.steps.size(), plan.expected_s(), plan.lower_bound_s);
  return out;
}

motion::Job job_from_line(const motion::Job& job, int line) {
  using motion::Step;
  motion::Job out;
  out.source = job.source;
  bool torch_on = false;
  double pierce_s = -1.0;  // the dwell after the last torch_on, if any
  Eigen::Vector2d at = job.start_mm;
  std::size_t k = 0;
  std::size_t first_segment = 0;
  for (; k < job.steps.size(); ++k) {
    const Step& st = job.steps[k];
    if (st.kind == Step::Kind::move) {
      const motion::Stretch& s = job.stretches[st.stretch];
      std::size_t j = 0;
      while (j < s.source_lines.size() && s.source_lines[j] < line) ++j;
      if (j < s.segments.size()) {
        first_segment = j;
        break;
      }
      if (!s.segments.empty()) at = s.segments.back().end;
      if (!s.cutting) torch_on = false;
      continue;
    }
    if (st.source_line >= line) break;
    if (st.kind == Step::Kind::torch_on) {
      torch_on = true;
      pierce_s = k + 1 < job.steps.size() && job.steps[k + 1].kind == Step::Kind::dwell ? job.steps[k + 1].seconds : -1.0;
    }
    if (st.kind == Step::Kind::torch_off) torch_on = false;
  }
  if (k == job.steps.size())
    throw InputError(job.source, line, fmt::format("no move or torch step of the job comes from line {} or later", line));
  const Step& first = job.steps[k];
  if (first.kind == Step::Kind::move) at = job.stretches[first.stretch].segments[first_segment].start;
  out.start_mm = at;
  const bool starts_cutting = first.kind == Step::Kind::move && job.stretches[first.stretch].cutting;
  if (torch_on && starts_cutting) {
    out.steps.push_back({Step::Kind::torch_on, line, 0, 0.0});
    if (pierce_s >= 0) out.steps.push_back({Step::Kind::dwell, line, 0, pierce_s});
  }
  for (std::size_t i = k; i < job.steps.size(); ++i) {
    Step st = job.steps[i];
    if (st.kind == Step::Kind::move) {
      motion::Stretch s = job.stretches[st.stretch];
      if (i == k && first_segment > 0) {
        const auto cut = static_cast<std::ptrdiff_t>(first_segment);
        s.segments.erase(s.segments.begin(), s.segments.begin() + cut);
        s.feed_mm_per_s.erase(s.feed_mm_per_s.begin(), s.feed_mm_per_s.begin() + cut);
        s.source_lines.erase(s.source_lines.begin(), s.source_lines.begin() + cut);
        st.source_line = s.source_lines.front();
      }
      out.stretches.push_back(std::move(s));
      st.stretch = out.stretches.size() - 1;
    }
    out.steps.push_back(st);
  }
  return out;
}

}  // namespace machplan::panel
