#include "engine/motion/process_time.h"

#include <algorithm>
#include <cmath>

namespace machplan::motion {

namespace {
double height_move_s(double from_mm, double to_mm, const TorchTimes::Height& h) {
  return std::max(0.0, std::abs(from_mm - to_mm) - h.tolerance_mm) / h.speed_mm_per_s;
}
}  // namespace

double process_time_s(const Job& job, const TorchTimes& times) {
  double t = 0.0;
  double waiting_mm = times.height ? times.height->retract_mm : 0.0;  // where the torch waits between cuts
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const Step& s = job.steps[i];
    switch (s.kind) {
      case Step::Kind::torch_on: {
        if (const auto& h = times.height)
          t += h->sense_s + height_move_s(waiting_mm, h->pierce_mm, *h) + height_move_s(h->pierce_mm, h->cut_mm, *h);
        else
          t += times.torch_on_s;
        t += times.start_s;
        const bool programmed = i + 1 < job.steps.size() && job.steps[i + 1].kind == Step::Kind::dwell;
        if (!programmed) t += times.pierce_s;  // a following G4 is counted as a dwell
        break;
      }
      case Step::Kind::torch_off:
        if (const auto& h = times.height) {
          waiting_mm = std::max(h->retract_mm, s.height_mm);
          t += height_move_s(h->cut_mm, waiting_mm, *h);
        } else {
          t += times.torch_off_s;
        }
        break;
      case Step::Kind::dwell: t += s.seconds; break;
      case Step::Kind::move: break;
    }
  }
  return t;
}

}  // namespace machplan::motion
