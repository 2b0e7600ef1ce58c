// The result of a run in words and figures: the fault messages (composed after the run from
// the numbers the tick recorded), ExecutionResult::report() and its figures, and a hold's
// jerk-limited stopping distance.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/executor/session_impl.h"

namespace machplan::executor {

using FK = FaultKind;

std::string Session::Impl::fault_message(const FaultReport& f) const {
  const Termination* termination = parts.termination;
  std::string message;
  const std::string where = f.source_line > 0 ? fmt::format("{}:{}", job.source, f.source_line) : job.source;
  const std::string ax = f.axis == 0 ? "X" : (f.axis == 1 ? "Y" : "");
  switch (f.kind) {
    case FK::following_error:
      message = fmt::format("following error of {:.3f} mm on axis {} exceeds the limit of {} mm", f.value, ax,
                            ms.servo[f.axis].following_error_limit_mm);
      break;
    case FK::encoder_glitch:
      message = fmt::format("counter of axis {} jumped {} counts in one period (at most {} are possible); the "
                            "encoder signal is not trusted from here",
                            ax, static_cast<long long>(f.value), adapter.max_counts(f.axis));
      break;
    case FK::counter_wrap_misread:
      message = fmt::format("counter of axis {} read {} counts away, a whole number of 256-count carries: the counter "
                            "bytes were read across a carry; position not trusted from here",
                            ax, static_cast<long long>(f.value));
      break;
    case FK::estop: message = "E-stop input opened"; break;
    case FK::lost_backend:
      message = "the backend stopped answering; nothing more could be commanded (its watchdog must stop the machine)";
      break;
    case FK::watchdog:
      message = fmt::format("the backend's watchdog stopped the machine: no exchange for more than {} periods",
                            static_cast<int>(f.value));
      break;
    case FK::arc_start_failed: message = fmt::format("no arc OK within {} s of firing the torch", f.value); break;
    case FK::arc_lost: message = fmt::format("arc OK dropped for {:.3f} s while cutting", f.value); break;
    case FK::torch_height_timeout:
      message = fmt::format("the torch height axis did not reach its target within {} s", f.value);
      break;
    case FK::axis_stalled:
      message = fmt::format("axis {} does not move while commanded at {:.2f} mm/s: it covered less than {:.0f} % of "
                            "the commanded travel (jammed axis, or a drive that does not answer)",
                            ax, f.value, 100 * opt.supervisor.stall_min_fraction);
      break;
    case FK::drive_saturated:
      message = fmt::format("the drive command was clipped in most periods while the contour error reached {:.3f} mm "
                            "(limit {} mm): the loop cannot hold the path (gains too high, or a feed the drive "
                            "cannot give)",
                            f.value, ms.contour_error_limit_mm);
      break;
    case FK::torch_breakaway:
      message = fmt::format("the torch touched the plate ({}) at a torch height of {:.2f} mm: a collision; torch off and "
                            "a controlled stop",
                            f.axis == 2 ? "float switch closed while the torch fired" : "breakaway switch open", f.value);
      break;
    case FK::probe_miss:
      message = fmt::format("the probe found no sheet: no contact by {} mm under the expected surface; the torch was "
                            "never lit",
                            f.value);
      break;
    case FK::probe_switch_stuck:
      message = fmt::format("the {} was closed before the probe went down (stuck, or shorted to the plate); the torch "
                            "was never lit",
                            f.value == 1.0 ? "float switch" : "ohmic sense");
      break;
    case FK::operator_stop: message = "stopped by the operator"; break;
    case FK::stop_requested:
      message = termination && termination->ended() && termination->reason() != Termination::Reason::stop_requested
                    ? termination->describe()
                    : "stop requested";
      break;
  }
  return fmt::format("{}: {} at t = {:.3f} s, step {}, last known position ({:.3f}, {:.3f}) mm", where, message,
                     f.time_s, f.step, f.last_known_mm.x(), f.last_known_mm.y());
}

double ExecutionResult::max_contour_error_mm() const {
  double m = 0;
  for (const CutError& c : cuts) m = std::max(m, c.max_mm);
  return m;
}

double ExecutionResult::max_true_contour_error_mm() const {
  double m = std::numeric_limits<double>::quiet_NaN();
  for (const CutError& c : cuts)
    if (!std::isnan(c.max_true_mm)) m = std::isnan(m) ? c.max_true_mm : std::max(m, c.max_true_mm);
  return m;
}

std::string ExecutionResult::report() const {
  std::string s = fmt::format("{} on {} ({} mode{}): {}\n", source.empty() ? "job" : source, machine, to_string(mode),
                              backend.empty() || backend == "sim" ? "" : ", backend " + backend,
                              summary.done()                       ? "completed"
                              : summary.status == Status::faulted ? "FAULTED"
                                                                   : to_string(summary.status));
  s += fmt::format("  cycle time {:.3f} s, torch on {:.3f} s, rapids {:.1f} mm, {} steps done\n", cycle_time_s, torch_on_s,
                   rapid_distance_mm, steps_completed);
  for (const CutError& c : cuts) {
    s += fmt::format("  cut (stretch {}, line {}): contour error max {:.4f} mm, rms {:.4f} mm", c.stretch, c.source_line,
                     c.max_mm, c.rms_mm);
    if (!std::isnan(c.max_true_mm)) s += fmt::format(" (true: max {:.4f}, rms {:.4f})", c.max_true_mm, c.rms_true_mm);
    s += c.complete ? "\n" : ", interrupted\n";
  }
  if (!truth_available && !cuts.empty())
    s += fmt::format("  true contour error unavailable: the {} backend reports only what the machine measures\n",
                     backend.empty() ? "machine's" : backend);
  for (const FaultReport& f : faults) s += fmt::format("  fault {}: {}\n", to_string(f.kind), f.message);
  if (!summary.done())
    s += fmt::format("  torch {} at the end; machine {}\n", torch_off_at_end ? "off" : "ON",
                     stopped_at_rest ? "stopped at rest" : "stop not confirmed (see fault)");
  if (trace_truncated) s += "  trace truncated (buffer full)\n";
  if (trace_stream_dropped > 0)
    s += fmt::format("  trace stream: {} samples dropped (the file could not be written fast enough)\n",
                     trace_stream_dropped);
  return s;
}

double HoldReport::jerk_limited_stop_mm() const {
  // From (v, a) along the path: the jerk -J brings the acceleration down to -A, -A holds, then
  // +J brings it back to 0 as the speed reaches 0 (the S-curve's time-optimal stop), integrated
  // in small steps of the exact piecewise-cubic motion.
  const double A = stop_acceleration_mm_per_s2, J = stop_jerk_mm_per_s3;
  if (!(speed_mm_per_s > 0) || !(A > 0) || !(J > 0)) return 0.0;
  double v = speed_mm_per_s, a = acceleration_mm_per_s2, s = 0.0;
  const double h = 1e-5;
  for (int n = 0; n < 100000000 && v > 0; ++n) {
    // Ramp the acceleration back up when the speed left is what the ramp from a to 0 takes.
    const double ramp_dv = a < 0 ? a * a / (2 * J) : 0.0;
    const double j = v <= ramp_dv ? J : (a > -A ? -J : 0.0);
    const double a1 = std::clamp(a + j * h, -A, std::max(a, 0.0) + J * h);
    s += v * h + a * h * h / 2;
    v += (a + a1) / 2 * h;
    a = a1;
  }
  return s;
}

}  // namespace machplan::executor
