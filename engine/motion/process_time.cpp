#include "engine/motion/process_time.h"

namespace machplan::motion {

double process_time_s(const Job& job, const TorchTimes& times) {
  double t = 0.0;
  for (std::size_t i = 0; i < job.steps.size(); ++i) {
    const Step& s = job.steps[i];
    switch (s.kind) {
      case Step::Kind::torch_on: {
        t += times.torch_on_s;
        t += times.start_s;
        const bool programmed = i + 1 < job.steps.size() && job.steps[i + 1].kind == Step::Kind::dwell;
        if (!programmed) t += times.pierce_s;  // a following G4 is counted as a dwell
        break;
      }
      case Step::Kind::torch_off: t += times.torch_off_s; break;
      case Step::Kind::dwell: t += s.seconds; break;
      case Step::Kind::move: break;
    }
  }
  return t;
}

}  // namespace machplan::motion
