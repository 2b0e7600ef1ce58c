#include "solvers/tuning/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "solvers/common/picture.h"

namespace machplan::tuning {

void write_time_plot(const std::string& path, const std::string& field, const std::string& title,
                     const std::vector<Panel>& panels) {
  const double W = 1000, ph = 280, top = 64, left = 80, right = 20, gap = 50;
  const double H = top + panels.size() * (ph + gap) + 10;
  double t0 = std::numeric_limits<double>::infinity(), t1 = -t0;
  for (const Panel& p : panels)
    for (const Series& s : p.series)
      for (double t : s.t_s) t0 = std::min(t0, t), t1 = std::max(t1, t);
  if (!(t1 > t0)) t0 = 0, t1 = 1;
  write_picture(path, field, W, H, [&](Canvas& cr) {
    cr.set_source_rgb(1, 1, 1);
    cr.paint();
    cr.set_source_rgb(0, 0, 0);
    draw_text(cr, left, 24, title, 15);
    for (std::size_t k = 0; k < panels.size(); ++k) {
      const Panel& p = panels[k];
      const double y0 = top + k * (ph + gap), pw = W - left - right;
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const Series& s : p.series)
        for (double v : s.y)
          if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
      if (!(hi > lo)) lo -= 1, hi += 1;
      const double pad = 0.05 * (hi - lo);
      lo -= pad;
      hi += pad;
      const auto X = [&](double t) { return left + (t - t0) / (t1 - t0) * pw; };
      const auto Y = [&](double v) { return y0 + ph - (v - lo) / (hi - lo) * ph; };
      cr.set_source_rgb(0.5, 0.5, 0.5);
      cr.set_line_width(1);
      cr.rectangle(left, y0, pw, ph);
      cr.stroke();
      // Ticks at round values, with light grid lines across the panel.
      const double vs = round_step((hi - lo) / 4), ts = round_step((t1 - t0) / 5);
      for (double v = std::ceil(lo / vs) * vs; v <= hi; v += vs) {
        const double y = Y(std::abs(v) < 1e-9 * vs ? 0.0 : v);
        cr.set_source_rgb(0.88, 0.88, 0.88);
        cr.move_to(left, y);
        cr.line_to(left + pw, y);
        cr.stroke();
        cr.set_source_rgb(0.3, 0.3, 0.3);
        draw_text(cr, 4, y + 4, fmt::format("{:g}", std::abs(v) < 1e-9 * vs ? 0.0 : v), 10);
      }
      for (double t = std::ceil(t0 / ts) * ts; t <= t1; t += ts) {
        cr.set_source_rgb(0.3, 0.3, 0.3);
        draw_text(cr, X(t) - 8, y0 + ph + 14, fmt::format("{:g}", std::abs(t) < 1e-9 * ts ? 0.0 : t), 10);
      }
      cr.set_source_rgb(0, 0, 0);
      draw_text(cr, left + 4, y0 - 6, p.y_label + "   (time, s)", 12);
      double lx = left + pw - 260, ly = y0 + 16;
      for (const Series& s : p.series) {
        cr.set_source_rgb(s.r, s.g, s.b);
        cr.set_line_width(1.5);
        if (s.dashed) {
          const double d[] = {6, 4};
          cr.set_dash(d, 2, 0);
        }
        bool first = true;
        for (std::size_t i = 0; i < s.t_s.size() && i < s.y.size(); ++i) {
          if (!std::isfinite(s.y[i])) {
            first = true;
            continue;
          }
          if (first) cr.move_to(X(s.t_s[i]), Y(s.y[i]));
          else cr.line_to(X(s.t_s[i]), Y(s.y[i]));
          first = false;
        }
        cr.stroke();
        cr.set_dash(nullptr, 0, 0);
        cr.move_to(lx, ly - 4);
        cr.line_to(lx + 20, ly - 4);
        cr.stroke();
        draw_text(cr, lx + 26, ly, s.name, 11);
        ly += 15;
      }
    }
  });
}

void write_tune_plot(const std::string& path, const std::string& field, const Evaluator& ev, const TuneOptions& o,
                     const TuneResult& r) {
  Panel p{fmt::format("contour error, um ({}, seed {})", ev.contours().front().spec, ev.options().seed), {}};
  auto base = ev.error_series(0, o.baseline_kind, {});
  auto tuned = ev.error_series(0, r.kind, r.gains);
  for (auto* s : {&base, &tuned})
    for (double& e : s->error_mm) e *= 1000.0;
  p.series.push_back({"baseline: axial P", 0.8, 0.2, 0.1, base.t_s, base.error_mm});
  p.series.push_back({fmt::format("tuned {}", r.kind), 0.1, 0.3, 0.8, tuned.t_s, tuned.error_mm});
  write_time_plot(path, field, fmt::format("machplan tune: {} on {}", r.kind, r.machine), {p});
}

void write_acc_plot(const std::string& path, const std::string& field, const AccStudy& st) {
  Panel force{"cutting force, N", {}}, feed{"feed, mm/rev", {}}, depth{"depth of cut, mm", {}};
  auto add = [&](const std::vector<turning::AccSample>& run, const std::string& name, double r, double g, double b) {
    Series f{name, r, g, b, {}, {}}, v{name, r, g, b, {}, {}};
    for (const auto& s : run) {
      f.t_s.push_back(s.t_s), f.y.push_back(s.force_n);
      v.t_s.push_back(s.t_s), v.y.push_back(s.feed_mm_per_rev);
    }
    force.series.push_back(f);
    feed.series.push_back(v);
  };
  add(st.koren, "fixed Kc = 0.5 (Koren)", 0.1, 0.1, 0.8);
  for (std::size_t i = 0; i < st.tunings.size(); ++i) {
    const AccTuningResult& t = st.tunings[i];
    add(st.tuned_runs[i], fmt::format("tuned {} = {:.3f}", t.variable_gain ? "L0 (variable gain)" : "Kc", t.gain),
        t.variable_gain ? 0.0 : 0.8, t.variable_gain ? 0.6 : 0.2, 0.1);
  }
  force.series.push_back(
      {fmt::format("F_r = {:g} N", st.reference_force_n), 0.5, 0.5, 0.5, {0.0, st.duration_s}, {st.reference_force_n, st.reference_force_n}, true});
  Series d{"depth", 0.3, 0.3, 0.3, {}, {}};
  for (const auto& s : st.koren) d.t_s.push_back(s.t_s), d.y.push_back(s.depth_mm);
  depth.series.push_back(d);
  write_time_plot(path, field, "Adaptive control constraint: depth-of-cut steps of 2 mm", {force, feed, depth});
}

}  // namespace machplan::tuning
