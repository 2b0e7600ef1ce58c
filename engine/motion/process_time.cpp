#include "engine/motion/process_time.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace machplan::motion {

namespace {
double height_move_s(double from_mm, double to_mm, const TorchTimes::Height& h) {
  return std::max(0.0, std::abs(from_mm - to_mm) - h.tolerance_mm) / h.speed_mm_per_s;
}

const CutParameters* material_of(const Job& job, const Step& s) {
  if (s.material < 0 || static_cast<std::size_t>(s.material) >= job.materials.size()) return nullptr;
  return &job.materials[static_cast<std::size_t>(s.material)];
}

// The probe from `waiting_mm` down to the contact, debounced; `rest_mm` is where the torch
// stands then, under the surface.
double probe_down_s(double waiting_mm, const TorchTimes::Height& h, const TorchTimes::Probe& p, double& rest_mm) {
  rest_mm = -p.contact_below_mm - p.debounce_s * p.speed_mm_per_s;
  return height_move_s(waiting_mm, p.height_mm, h) + (p.height_mm + p.contact_below_mm) / p.speed_mm_per_s + p.debounce_s;
}

// The probe from `waiting_mm` to the surface, and on to pierce height.
double probe_s(double waiting_mm, double pierce_mm, const TorchTimes::Height& h, const TorchTimes::Probe& p) {
  double rest_mm = 0.0;
  const double down_s = probe_down_s(waiting_mm, h, p, rest_mm);
  return down_s + height_move_s(rest_mm, pierce_mm, h);
}

// An offset probe's step from `waiting_mm`: deploy, probe, and up to the probe height while it
// is stowed.
double offset_probe_s(double waiting_mm, const TorchTimes::Height& h, const TorchTimes::Probe& p) {
  double rest_mm = 0.0;
  const double down_s = probe_down_s(waiting_mm, h, p, rest_mm);
  return p.offset_delay_s + down_s + std::max(p.offset_delay_s, height_move_s(rest_mm, p.height_mm, h));
}

// The torch height moves of a torch_on from `waiting_mm`: down to pierce height (by the probe
// when one runs), after the pierce up or down to the puddle jump height (when the material has
// one) and to cut height.
// A ramp pierce (`ramp`) goes down to cut height while it moves: not counted.
double torch_on_heights_s(double waiting_mm, TorchTimes::Height h, const TorchTimes::Probe* probe, const CutParameters* m,
                          bool ramp) {
  if (m) h.pierce_mm = m->pierce_height_mm, h.cut_mm = m->cut_height_mm;
  double t = probe ? probe_s(waiting_mm, h.pierce_mm, h, *probe) : height_move_s(waiting_mm, h.pierce_mm, h);
  if (ramp) return t;
  if (m && m->puddle_jump_height_pct > 0.0) {
    const double jump_mm = h.pierce_mm * m->puddle_jump_height_pct / 100.0;
    return t + height_move_s(h.pierce_mm, jump_mm, h) + height_move_s(jump_mm, h.cut_mm, h);
  }
  return t + height_move_s(h.pierce_mm, h.cut_mm, h);
}
// A ramp pierce: the part of its delay before the torch moves, and what its slow start costs
// the cut beyond the plan's time there (at least d/v - d/F for each distance d at speed v
// under the feed F: the plan takes at least d/F over d).
double ramp_pierce_s(const Job& job, std::size_t cut, double delay_s, const CutParameters& m) {
  double t = delay_s * m.pierce_motion_delay_pct / 100.0;
  const Stretch& s = job.stretches[job.steps[cut].stretch];
  const double feed = s.feed_mm_per_s.empty() ? 0.0 : s.feed_mm_per_s.front();
  if (!(feed > 0.0)) return t;
  for (const auto& [d, v] : {std::pair{m.gouge_distance_mm, m.gouge_speed_mm_per_s}, std::pair{m.creep_distance_mm, m.creep_speed_mm_per_s}})
    if (d > 0.0 && v > 0.0 && v < feed) t += d / v - d / feed;
  return t;
}
}  // namespace

std::size_t ramp_cut(const Job& job, std::size_t i) {
  const std::size_t cut = i + (i + 1 < job.steps.size() && job.steps[i + 1].kind == Step::Kind::dwell ? 2 : 1);
  const bool ok = cut < job.steps.size() && job.steps[cut].kind == Step::Kind::move && job.stretches[job.steps[cut].stretch].cutting;
  return ok ? cut : 0;
}

double process_time_s(const Job& job, const TorchTimes& times) {
  double t = 0.0;
  double waiting_mm = times.height ? times.height->retract_mm : 0.0;  // where the torch waits between cuts
  const CutParameters* material = nullptr;                           // of the cut in progress
  bool lit = false;  // a torch_off after another (a second M5) finds the torch up already
  bool skip_dwell = false;  // the dwell after a ramp pierce's torch_on is its delay, counted there
  Eigen::Vector2d at = job.start_mm, probed_at = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const Step& s = job.steps[i];
    switch (s.kind) {
      case Step::Kind::torch_on: {
        material = times.use_materials ? material_of(job, s) : nullptr;
        lit = true;
        const TorchTimes::Probe* probe = times.probe && !times.probe->offset ? &*times.probe : nullptr;
        if (probe && probe->skip_distance_mm > 0 && (at - probed_at).cwiseAbs().maxCoeff() <= probe->skip_distance_mm)
          probe = nullptr;  // skipped
        if (probe) probed_at = at;
        const bool programmed = i + 1 < job.steps.size() && job.steps[i + 1].kind == Step::Kind::dwell;
        const std::size_t cut = material && material->ramp_pierce && times.height ? ramp_cut(job, i) : 0;
        if (const auto& h = times.height) t += torch_on_heights_s(waiting_mm, *h, probe, material, cut > 0);
        else t += times.torch_on_s;
        t += times.start_s;
        if (cut > 0) {
          t += ramp_pierce_s(job, cut, programmed ? job.steps[i + 1].seconds : material->pierce_delay_s, *material);
          skip_dwell = programmed;
          break;
        }
        // A following G4 is counted as a dwell.
        if (!programmed) t += material ? material->pierce_delay_s + material->puddle_jump_delay_s : times.pierce_s;
        break;
      }
      case Step::Kind::torch_off:
        if (material) t += material->pause_at_end_s;
        if (const auto& h = times.height) {
          const double from_mm = !lit ? waiting_mm : material ? material->cut_height_mm : h->cut_mm;
          waiting_mm = std::max(h->retract_mm, s.height_mm);
          t += height_move_s(from_mm, waiting_mm, *h);
        } else {
          t += times.torch_off_s;
        }
        material = nullptr;
        lit = false;
        break;
      case Step::Kind::dwell:
        if (!skip_dwell) t += s.seconds;
        skip_dwell = false;
        break;
      case Step::Kind::probe:
        if (times.height && times.probe && times.probe->offset) {
          t += offset_probe_s(waiting_mm, *times.height, *times.probe);
          waiting_mm = times.probe->height_mm;
        }
        break;
      case Step::Kind::move: {
        const auto& seg = job.stretches[s.stretch].segments;
        if (!seg.empty()) at = seg.back().end;
        break;
      }
    }
  }
  return t;
}

}  // namespace machplan::motion
