#include "solvers/calibration/record.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "models/axis/plant.h"

namespace machplan::calibration {
namespace {

// One period of the program: the fraction of full scale to command and whether the ruler is
// read at its end.
struct Step {
  double fraction = 0.0;
  bool ruler = false;
};

void append(std::vector<Step>& p, double fraction, double seconds, double period_s) {
  const long n = std::max(1L, std::lround(seconds / period_s));
  for (long i = 0; i < n; ++i) p.push_back({fraction, false});
}

std::vector<Step> program(const RecordOptions& o, double period_s) {
  std::vector<Step> p;
  append(p, 0.0, o.settle_s, period_s);
  p.back().ruler = true;
  for (int r = 0; r < o.repeats; ++r) {
    for (double speed : o.speed_fractions) {
      for (double sign : {1.0, -1.0}) {
        const int stairs = static_cast<int>(std::ceil(speed / o.stair_fraction - 1e-9));
        for (int i = 1; i < stairs; ++i) append(p, sign * speed * i / stairs, o.stair_hold_s, period_s);
        append(p, sign * speed, o.stroke_hold_s, period_s);
        for (int i = stairs - 1; i >= 1; --i) append(p, sign * speed * i / stairs, o.stair_hold_s, period_s);
        append(p, 0.0, o.dwell_s, period_s);
        p.back().ruler = true;
      }
    }
  }
  return p;
}

}  // namespace

void RecordOptions::validate() const {
  auto bad = [](const char* field, const std::string& what) { throw InputError::field(field, what); };
  if (speed_fractions.empty()) bad("speed_fractions", "needs at least one speed");
  for (double f : speed_fractions)
    if (!(f > 0 && f <= 1)) bad("speed_fractions", fmt::format("{} is not in (0, 1]", f));
  if (!(stair_fraction > 0 && stair_fraction <= 1)) bad("stair_fraction", fmt::format("{} is not in (0, 1]", stair_fraction));
  if (!(stair_hold_s > 0 && stair_hold_s < 60)) bad("stair_hold_s", fmt::format("{} is not in (0, 60) s", stair_hold_s));
  if (!(stroke_hold_s > 0 && stroke_hold_s < 600)) bad("stroke_hold_s", fmt::format("{} is not in (0, 600) s", stroke_hold_s));
  if (!(dwell_s > 0 && dwell_s < 60)) bad("dwell_s", fmt::format("{} is not in (0, 60) s", dwell_s));
  if (!(stop_s > 0 && stop_s < 60)) bad("stop_s", fmt::format("{} is not in (0, 60) s", stop_s));
  if (!(settle_s > 0 && settle_s < 60)) bad("settle_s", fmt::format("{} is not in (0, 60) s", settle_s));
  if (repeats < 1 || repeats > 1000) bad("repeats", fmt::format("{} is not in 1 .. 1000", repeats));
  if (!(ruler_noise_mm >= 0 && ruler_noise_mm < 10)) bad("ruler_noise_mm", fmt::format("{} is not in [0, 10) mm", ruler_noise_mm));
}

long record_periods(const RecordOptions& o, double period_s) {
  o.validate();
  return static_cast<long>(program(o, period_s).size());
}

Recording record_session(hardware::Backend& backend, const cutting::MachineConfig& nominal, const RecordOptions& o,
                         Termination& termination, Progress* progress) {
  o.validate();
  if (backend.command_kind() != hardware::CommandKind::speed_dac)
    throw InputError::field("backend", fmt::format("backend '{}' takes position commands; calibration needs a speed_dac "
                                                   "backend (raw DAC codes and counters)",
                                                   backend.name()));
  const double dt = backend.period_s();
  const auto steps = program(o, dt);
  std::mt19937_64 rng(o.seed);

  Recording rec;
  SessionLog& log = rec.log;
  hardware::Inputs in = backend.initial_inputs();
  hardware::Outputs out;
  // Leaves the machine with the drives off and a zero command.
  const auto drives_off = [&] {
    out = hardware::Outputs{};
    backend.exchange(out, in);
  };
  // Ends the recording early (after a stop request, with the drives off; after a fault, as the
  // backend left them).
  const auto end_early = [&](Status status, std::string message) {
    if (status != Status::faulted) drives_off();
    rec.summary.status = status;
    rec.summary.message = std::move(message);
    rec.summary.brief = rec.summary.full = fmt::format("calibration {}: {}", to_string(status), rec.summary.message);
    return rec;
  };
  log.comments.push_back(fmt::format("machine: {}", nominal.name));
  log.comments.push_back(fmt::format("backend: {}", backend.name()));
  log.comments.push_back(fmt::format("routine: speeds {} of full scale, stair {}, hold {} s, dwell {} s, repeats {}",
                                     fmt::join(o.speed_fractions, " "), o.stair_fraction, o.stroke_hold_s, o.dwell_s,
                                     o.repeats));
  const bool has_ruler = [&] {
    Eigen::Vector2d p;
    return backend.true_position(p);
  }();
  log.comments.push_back(has_ruler ? fmt::format("ruler: the backend's true position, noise {} mm (seed {})",
                                                 o.ruler_noise_mm, o.seed)
                                   : "ruler: none (the backend does not know its true position)");
  log.samples.reserve(2 * (steps.size() + 1));

  std::array<int, 2> max_code{};
  for (int a = 0; a < 2; ++a) {
    const auto sig = backend.axis_signals(a);
    max_code[a] = (1 << (sig.dac_bits - 1)) - 1;
  }
  auto push = [&](double t, const hardware::Inputs& in, const std::array<std::int32_t, 2>& code, bool ruler) {
    Eigen::Vector2d truth = Eigen::Vector2d::Zero();
    const bool read = ruler && backend.true_position(truth);
    for (int a = 0; a < 2; ++a) {
      LogSample s;
      s.t_s = t;
      s.axis = a;
      s.dac = code[a];
      s.counter = in.counter[a] % kCounterModulus;
      s.direction_negative = in.counter_direction_negative[a];
      if (read) {
        s.has_ref = true;
        s.ref_mm = truth[a] + o.ruler_noise_mm * axis::gaussian(rng);
      }
      log.samples.push_back(s);
    }
  };

  push(0.0, in, {0, 0}, true);
  out.drives_enabled = true;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    report_progress(progress, static_cast<double>(k) / static_cast<double>(steps.size()));
    termination.charge(1, dt);
    if (termination.should_end()) {
      // Zero speed until the drives' lag has run out, then drives off.
      out.dac_code = {0, 0};
      const long n = std::max(1L, std::lround(o.stop_s / dt));
      for (long i = 0; i < n; ++i)
        if (backend.exchange(out, in) == hardware::Health::lost) break;
      return end_early(status_of(termination.reason()),
                 fmt::format("calibration ended at {:.3f} s ({}); the axes were stopped", k * dt, termination.describe()));
    }
    std::array<std::int32_t, 2> code{};
    for (int a = 0; a < 2; ++a)
      code[a] = static_cast<std::int32_t>(std::lround(steps[k].fraction * (max_code[a] + 1)));
    for (int a = 0; a < 2; ++a) code[a] = std::clamp(code[a], kDacMin, kDacMax);
    out.dac_code = code;
    if (backend.exchange(out, in) == hardware::Health::lost)
      return end_early(Status::faulted, fmt::format("calibration stopped at {:.3f} s: the backend is lost", (k + 1) * dt));
    if (in.estop) return end_early(Status::faulted, fmt::format("calibration stopped at {:.3f} s: E-stop", (k + 1) * dt));
    if (in.watchdog_tripped)
      return end_early(Status::faulted, fmt::format("calibration stopped at {:.3f} s: the backend's watchdog tripped", (k + 1) * dt));
    push(static_cast<double>(k + 1) * dt, in, code, steps[k].ruler);
  }
  // Leave the machine at rest with the drives off.
  drives_off();
  report_progress(progress, 1.0);
  rec.summary.brief = rec.summary.full =
      fmt::format("calibration done: {} samples, {:.1f} s", log.samples.size(), log.samples.empty() ? 0.0 : log.samples.back().t_s);
  return rec;
}

}  // namespace machplan::calibration
