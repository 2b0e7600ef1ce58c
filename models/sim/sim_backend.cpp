#include "models/sim/sim_backend.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::sim {

namespace {
// In FaultInjection::Kind's order.
constexpr Spelling kFaultNames[] = {{"encoder-glitch"}, {"counter-misread"}, {"estop"},             {"lost-backend"},
                                    {"jam"},            {"arc-loss"},        {"arc-start-failure"}, {"watchdog"},
                                    {"probe-miss"},     {"switch-stuck"},    {"breakaway"},         {"ohmic-miss"}};
// How long an injected breakaway holds the float switch closed (a part passing under the torch).
constexpr double kBreakawayKnockS = 0.5;
// The float's overtravel past its switch: pushed further, the torch's breakaway mount gives.
constexpr double kFloatOvertravelMm = 2.0;
}  // namespace

const char* to_string(FaultInjection::Kind k) { return kFaultNames[static_cast<std::size_t>(k)].name.data(); }

Parsed<FaultInjection::Kind> parse_fault_kind(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kFaultNames, text, "faults", "fault kind");
  return {static_cast<FaultInjection::Kind>(p.value), p.note};
}

void SimOptions::validate() const {
  if (watchdog_periods < 1 || watchdog_periods > 100000)
    throw InputError::field("watchdog_periods", fmt::format("{} must be 1 .. 100000", watchdog_periods));
  if (!start_mm.allFinite()) throw InputError::field("start_mm", "must be finite");
  if (sheet_warp_mm) {
    const auto [a, l] = *sheet_warp_mm;
    if (!(std::isfinite(a) && a >= 0 && a <= 50))
      throw InputError::field("sheet_warp_mm", fmt::format("amplitude {} mm must be in [0, 50]", a));
    if (!(std::isfinite(l) && l >= 1 && l <= 1e5))
      throw InputError::field("sheet_warp_mm", fmt::format("wavelength {} mm must be in [1, 100000]", l));
  }
  if (sheet_warp_mm && sheet_map)
    throw InputError::field("sheet_map", "a height map and a warp both describe the sheet: give one");
  if (!(std::isfinite(realtime_speed) && realtime_speed > 0 && realtime_speed <= 1000))
    throw InputError::field("realtime_speed", fmt::format("{} must be in (0, 1000]", realtime_speed));
  for (const FaultInjection& f : faults) {
    if (!(std::isfinite(f.at_s) && f.at_s >= 0 && f.at_s <= 1e7))
      throw InputError::field("faults", fmt::format("{}@{}: the time must be in [0, 1e7] s", to_string(f.kind), f.at_s));
    if (f.axis < 0 || f.axis >= hardware::kAxes)
      throw InputError::field("faults", fmt::format("{}: axis {} does not exist", to_string(f.kind), f.axis));
  }
  double last = 0;
  for (const OperatorEvent& e : operator_events) {
    if (!(std::isfinite(e.at_s) && e.at_s >= last))
      throw InputError::field("operator_events", "times must be finite and in increasing order");
    last = e.at_s;
  }
}

SimBackend::SimBackend(const cutting::MachineConfig& machine, const SimOptions& options)
    : m_(machine), opt_(options), period_s_(machine.servo_period_s), rng_(options.seed) {
  opt_.validate();
  for (int i = 0; i < 2; ++i)
    plants_[i] = std::make_unique<axis::AxisPlant>(m_.axes[i].plant, opt_.start_mm[i], opt_.counter_start[i]);
  height_mm_ = height_target_mm_ = m_.torch_height.fitted ? m_.torch_height.retract_height_mm : 0.0;
  // The plasma process draws from a stream of its own, so that the axes' noise stays as it was.
  process_rng_.seed(opt_.seed ^ 0x9e3779b97f4a7c15ull);
  warp_amplitude_mm_ = opt_.sheet_warp_mm ? opt_.sheet_warp_mm->first : m_.sheet_warp_amplitude_mm;
  warp_wavelength_mm_ = opt_.sheet_warp_mm ? opt_.sheet_warp_mm->second : m_.sheet_warp_wavelength_mm;
  warp_phase_x_ = 2 * M_PI * axis::uniform01(process_rng_);
  warp_phase_y_ = 2 * M_PI * axis::uniform01(process_rng_);
  if (m_.torch.kind == executor::TorchSetup::Kind::plasma) {
    kerf_nx_ = static_cast<long>(m_.axes[0].travel_mm / 2.0) + 3;
    kerf_ny_ = static_cast<long>(m_.axes[1].travel_mm / 2.0) + 3;
    kerf_cells_.assign(static_cast<std::size_t>(kerf_nx_ * kerf_ny_), 0);
  }
  pending_.reserve(16 + opt_.faults.size());
  fired_.reserve(16 + opt_.faults.size());
  effective_.reserve(16 + opt_.faults.size());
  for (const FaultInjection& f : opt_.faults) inject(f);
}

void SimBackend::inject(const FaultInjection& f) {
  pending_.push_back(f);
  fired_.push_back(0);
  effective_.push_back(0);
}

hardware::AxisSignals SimBackend::axis_signals(int axis) const {
  const auto& p = m_.axes[axis].plant;
  return {p.mm_per_count(), p.counter_bits, p.dac_bits, p.dac_full_scale_mm_per_s(), p.command_latency_ticks,
          p.reading_latency_ticks};
}

hardware::Inputs SimBackend::sample() {
  hardware::Inputs in;
  for (int i = 0; i < 2; ++i) {
    const axis::CounterReading r = plants_[i]->read();
    std::uint32_t v = r.value;
    if (misread_[i] != 0) {
      const std::uint32_t mask = m_.axes[i].plant.counter_bits == 32 ? 0xFFFFFFFFu : ((1u << m_.axes[i].plant.counter_bits) - 1u);
      v = static_cast<std::uint32_t>(static_cast<std::int64_t>(v) + misread_[i]) & mask;
      misread_[i] = 0;
    }
    in.counter[i] = v;
    in.counter_direction_negative[i] = r.direction_negative;
  }
  in.arc_ok = m_.torch.kind == executor::TorchSetup::Kind::plasma ? arc_burning_ : fire_;  // oxygen / spindle on
  in.estop = estop_;
  in.watchdog_tripped = watchdog_;
  in.op = op_;
  in.torch_height_mm = height_mm_;
  in.arc_voltage_v = arc_voltage_v_;
  in.torch_breakaway = breakaway_;
  in.float_switch = float_switch_;
  in.ohmic_sense = ohmic_sense_;
  return in;
}

hardware::Inputs SimBackend::initial_inputs() {
  // A session starts on a fresh sheet: the kerfs of an earlier run on this machine (the panel
  // runs many) are not under the torch.
  std::fill(kerf_cells_.begin(), kerf_cells_.end(), std::uint16_t{0});
  return sample();
}

void SimBackend::advance(const hardware::Outputs& out) {
  const double dt = period_s_;
  // Injected faults due at the start of this period.
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    if (fired_[k] || time_s_ + 0.5 * dt < pending_[k].at_s) continue;
    fired_[k] = 1;
    const FaultInjection& f = pending_[k];
    switch (f.kind) {
      case FaultInjection::Kind::encoder_glitch: plants_[f.axis]->glitch_counter(f.counts); break;
      case FaultInjection::Kind::counter_wrap_misread: misread_[f.axis] = (ticks_ % 2 == 0) ? 256 : -256; break;
      case FaultInjection::Kind::estop: estop_ = true; break;
      case FaultInjection::Kind::lost_backend: lost_ = true; break;
      case FaultInjection::Kind::stuck_axis: plants_[f.axis]->set_stuck(true); break;
      case FaultInjection::Kind::arc_loss: arc_loss_pending_ = true; break;
      case FaultInjection::Kind::arc_start_failure: arc_start_fails_ = true; break;
      case FaultInjection::Kind::watchdog: watchdog_ = true; break;
      case FaultInjection::Kind::probe_miss: sheet_gone_ = true; break;
      case FaultInjection::Kind::switch_stuck: float_stuck_ = true; break;
      case FaultInjection::Kind::breakaway: knock_left_s_ = kBreakawayKnockS; break;
      case FaultInjection::Kind::ohmic_miss: ohmic_dead_ = true; break;
    }
  }
  while (next_op_ < opt_.operator_events.size() && opt_.operator_events[next_op_].at_s <= time_s_ + 0.5 * dt)
    op_ = opt_.operator_events[next_op_++].inputs;
  // The watchdog (lost link) and the E-stop chain cut drives and torch in hardware too.
  const bool alive = !lost_ && !watchdog_;
  enabled_ = alive && !estop_ ? out.drives_enabled : false;
  const bool fire = alive && !estop_ && out.torch_fire;

  for (int i = 0; i < 2; ++i) plants_[i]->step(enabled_ ? out.dac_code[i] : 0, enabled_, dt, rng_);

  // Torch: an injected arc fault takes effect on the first arc it meets.
  const bool starting = fire && !fire_;
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    if (!fired_[k] || effective_[k]) continue;
    const FaultInjection::Kind kind = pending_[k].kind;
    if (kind == FaultInjection::Kind::arc_start_failure) effective_[k] = starting;
    else if (kind == FaultInjection::Kind::arc_loss) effective_[k] = fire;
    else if (kind == FaultInjection::Kind::ohmic_miss) effective_[k] = alive && out.ohmic_enable;
    else if (kind == FaultInjection::Kind::breakaway) effective_[k] = fire;
    else effective_[k] = 1;
  }
  if (starting) {
    arc_lost_ = false;  // a lost arc stays out until the torch fires again
    cut_id_ = static_cast<std::uint16_t>(cut_id_ == 65535 ? 1 : cut_id_ + 1);
    ++arc_starts_;
    arc_timer_s_ = 0.0;
    arc_fails_ = arc_start_fails_ || uniform_fail();
  }
  fire_ = fire;
  if (!fire_) {
    arc_burning_ = false;
  } else if (m_.torch.kind == executor::TorchSetup::Kind::plasma) {
    arc_timer_s_ += dt;
    arc_burning_ = !arc_fails_ && !arc_lost_ && arc_timer_s_ >= m_.torch.plasma.arc_start_delay_s;
    // An injected loss puts out the first arc it meets that has pierced (one that fired
    // between cuts waits for the next cut to start moving).
    const double pierced_s = m_.torch.plasma.arc_start_delay_s + m_.torch.plasma.pierce_delay_s + 0.1;
    if (arc_burning_ && arc_loss_pending_ && arc_timer_s_ >= pierced_s) {
      arc_burning_ = arc_loss_pending_ = false;
      arc_lost_ = true;
    }
  } else {
    arc_burning_ = true;
  }

  // Torch height axis and the sensors that find the plate.
  if (m_.torch_height.fitted) {
    height_target_mm_ = alive ? out.torch_height_target_mm : m_.torch_height.retract_height_mm;
    const double step = m_.torch_height.speed_mm_per_s * dt;
    height_mm_ += std::clamp(height_target_mm_ - height_mm_, -step, step);
    sense_plate(alive && out.ohmic_enable, alive && out.offset_probe, dt);
  }
  burn_and_measure(out);
  time_s_ += dt;
  ++ticks_;
}

void SimBackend::sense_plate(bool ohmic_on, bool offset_probe, double dt) noexcept {
  const executor::ProbeSetup& p = m_.torch_height.probe;
  // A dirty plate: drawn once per probe, as the ohmic sensing switches on.
  if (ohmic_on && !ohmic_on_) ohmic_dirty_ = m_.sheet_ohmic_miss_probability > 0 && axis::uniform01(process_rng_) < m_.sheet_ohmic_miss_probability;
  ohmic_on_ = ohmic_on;
  double gap = 0.0;
  const bool plate = true_torch_gap(gap);  // false: no sheet under the torch
  knock_left_s_ = std::max(0.0, knock_left_s_ - dt);
  // The offset probe, deployed, closes the same input over the plate beside the torch: its
  // tip level with the torch's, at the probe's offset.
  double probe_gap = gap;
  if (offset_probe && plate) {
    Eigen::Vector2d at;
    true_position(at);
    probe_gap = height_mm_ - plate_z_mm(at.x() + p.offset_x_mm, at.y() + p.offset_y_mm);
  }
  const bool float_contact = plate && (offset_probe ? probe_gap : gap) <= -p.float_travel_mm;
  float_switch_ = p.float_switch && (float_stuck_ || knock_left_s_ > 0 || float_contact);
  ohmic_sense_ = p.ohmic && ohmic_on && !ohmic_dirty_ && !ohmic_dead_ && plate && gap <= 0.0;
  // A torch that probes rides on a floating mount, with a switch or not; it gives past the
  // float's overtravel. A torch that does not probe is held rigidly: it gives as it touches.
  breakaway_ = plate && gap <= (p.fitted() ? -(p.float_travel_mm + kFloatOvertravelMm) : 0.0);
}

double SimBackend::plate_z_mm(double x, double y) const noexcept {
  if (opt_.sheet_map) return opt_.sheet_map->z_mm(x, y);
  if (warp_amplitude_mm_ == 0.0) return 0.0;
  const double k = 2 * M_PI / warp_wavelength_mm_;
  return warp_amplitude_mm_ * std::sin(k * x + warp_phase_x_) * std::sin(k * y + warp_phase_y_);
}

bool SimBackend::true_torch_gap(double& gap_mm) const noexcept {
  if (!m_.torch_height.fitted || sheet_gone_) return false;
  Eigen::Vector2d p;
  true_position(p);
  gap_mm = height_mm_ - plate_z_mm(p.x(), p.y());
  return true;
}

// The arc marks the cells it burns; over a kerf another cut left, its voltage jumps.
void SimBackend::burn_and_measure(const hardware::Outputs& out) noexcept {
  arc_voltage_v_ = 0.0;
  over_kerf_ = false;
  if (!arc_burning_ || m_.torch.kind != executor::TorchSetup::Kind::plasma) return;
  Eigen::Vector2d p;
  true_position(p);
  const long cx = std::lround(p.x() / 2.0) + 1, cy = std::lround(p.y() / 2.0) + 1;
  if (cx >= 0 && cy >= 0 && cx < kerf_nx_ && cy < kerf_ny_) {
    std::uint16_t& cell = kerf_cells_[static_cast<std::size_t>(cy * kerf_nx_ + cx)];
    if (cell == 0) cell = cut_id_;  // the first cut to burn it
    over_kerf_ = cell != cut_id_;
  }
  double gap = m_.torch_height.cut_height_mm;
  true_torch_gap(gap);
  const auto& pc = m_.torch.plasma;
  // With a material's cut chart in force the arc reads its CUT_VOLTS at its CUT_HEIGHT (the
  // chart's current sets the arc's base voltage); else the machine's base.
  const double base =
      out.chart_volts_v > 0.0 ? out.chart_volts_v - pc.volts_per_mm * out.chart_height_mm : pc.arc_volts_base_v;
  arc_voltage_v_ = base + pc.volts_per_mm * std::max(0.0, gap) + pc.arc_voltage_noise_v * axis::gaussian(process_rng_) +
                   (over_kerf_ ? pc.kerf_crossing_rise_v : 0.0);
}

void SimBackend::miss_exchanges(int n) {
  // Without a controller the hardware keeps its last outputs until the watchdog trips.
  for (int i = 0; i < n; ++i) {
    if (i >= opt_.watchdog_periods) watchdog_ = true;
    advance(last_out_);
  }
}

hardware::Health SimBackend::exchange(const hardware::Outputs& out, hardware::Inputs& in) noexcept {
  if (opt_.realtime) {
    const auto now = std::chrono::steady_clock::now();
    if (!started_) {
      t0_ = now;
      started_ = true;
    } else if (!watchdog_ && !lost_) {
      // Exchanges that came too late on the wall clock: the whole process stalled (the
      // simulated machine lives in it and did not move meanwhile). Past the watchdog the
      // simulated machine waits with the program, and the stall is told after the run, where
      // a real machine's watchdog would have stopped it.
      const double gap_s = std::chrono::duration<double>(now - last_return_).count();
      const long missed = static_cast<long>(gap_s * opt_.realtime_speed / period_s_);
      if (missed > opt_.watchdog_periods) {
        if (last_out_.drives_enabled) ++stalls_, longest_stall_s_ = std::max(longest_stall_s_, gap_s);
        t0_ += now - last_return_;  // keep pacing from here
      }
    }
  }
  last_out_ = out;
  advance(out);
  in = sample();
  if (opt_.realtime) {
    const auto deadline = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(time_s_ / opt_.realtime_speed));
    std::this_thread::sleep_until(deadline);
    last_return_ = std::chrono::steady_clock::now();
  }
  return lost_ ? hardware::Health::lost : hardware::Health::ok;
}

std::vector<std::string> SimBackend::notes() const {
  std::vector<std::string> out;
  if (stalls_ > 0)
    out.push_back(fmt::format("the program stalled {} time(s) past the watchdog's {} periods with the drives on (longest {:.0f} ms of "
                              "wall clock): the simulated machine, paced by the same process, waited; a real machine's watchdog "
                              "would have stopped it",
                              stalls_, opt_.watchdog_periods, 1e3 * longest_stall_s_));
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    const FaultInjection& f = pending_[k];
    if (!fired_[k])
      out.push_back(fmt::format("the injected fault {}@{:g} s never fired: the run ended at {:.3f} s", to_string(f.kind), f.at_s,
                                time_s_));
    else if (!effective_[k])
      out.push_back(fmt::format("the injected fault {}@{:g} s never took effect: {}", to_string(f.kind), f.at_s,
                                f.kind == FaultInjection::Kind::arc_start_failure ? "no arc was started after it"
                                : f.kind == FaultInjection::Kind::ohmic_miss      ? "no probe used ohmic sensing after it"
                                                                                  : "no arc burned after it"));
  }
  return out;
}

bool SimBackend::true_position(Eigen::Vector2d& out_mm) const noexcept {
  out_mm = {plants_[0]->load_position_mm(), plants_[1]->load_position_mm()};
  return true;
}

void SimBackend::coast(double seconds) {
  hardware::Outputs off;
  off.torch_height_target_mm = m_.torch_height.retract_height_mm;
  const long n = std::lround(seconds / period_s_);
  for (long i = 0; i < n; ++i) advance(off);
}

}  // namespace machplan::sim
