// The simulated machine behind the executor's Backend interface: two axis plants
// (models/axis/plant.h), a plasma or oxy-fuel torch, a torch height axis, an E-stop input, a
// hardware watchdog, and fault injection for tests.
//
// Torch model. Plasma: on a rising `torch_fire` the arc starts after `arc_start_delay_s`
// unless the start fails (probability `arc_start_failure_probability`, drawn from the seeded
// RNG), and `arc_ok` is reported while the arc burns; dropping `torch_fire` ends the arc at
// once. Oxy-fuel: the cutting oxygen follows `torch_fire`; there is no arc-OK signal (the
// input reads true while firing). The height axis moves to its target at `speed_mm_per_s`, in
// the height frame of engine/hardware/backend.h (0: the sheet's nominal surface). The arc's
// voltage grows by `volts_per_mm` per mm of gap from the machine's `arc_volts_base_v`, or,
// while a material's cut chart is in force (Outputs::chart_volts_v), from the base that gives
// the chart's CUT_VOLTS at its CUT_HEIGHT: the simulated source and plate are the ones the
// chart was made for, so THC holds the torch at the chart's height. Over a kerf cut earlier in
// the session the voltage rises by `kerf_crossing_rise_v`; each session starts on a fresh sheet
// (initial_inputs()), as an operator loads one for each job.
//
// The sheet and its sensors: the plate's surface is flat at 0 or warped (plate_z_mm); the
// torch's gap is its height minus the surface under it. With the machine's probe sensors
// (torch_height.probe): the float switch reads closed once the gap is -float_travel_mm or less
// (the torch rests on the plate and its float has risen by the travel); the ohmic sense, while
// Outputs::ohmic_enable is on, once the gap is 0 or less, unless the plate is dirty at that
// probe (chance `sheet.ohmic_miss_probability`, drawn as the ohmic sensing switches on). The
// executor debounces both. The torch's breakaway switch opens past the float's overtravel (2 mm
// beyond where its switch closes) on a machine that probes, and as soon as the gap is 0 or less
// on one that does not (its torch is held rigidly).
//
// Watchdog: once the link is lost (injected) the simulated hardware disables the drives and
// the torch by itself, as a real controller's watchdog must; `coast()` lets a test run the
// machine on after the executor has gone. When no exchange arrives for more than
// `watchdog_periods` periods (simulated by `miss_exchanges()` or an injected `watchdog` fault)
// while the drives are enabled, the watchdog trips: drives and torch off, latched, and
// `Inputs::watchdog_tripped` reports it. Paced with `realtime`, a longer gap on the wall clock
// is the whole process stalling, the simulated machine with it: nothing moved, so nothing
// trips; notes() tells how often and how long, where a real machine would have stopped.
//
// Collision: the breakaway switch (`Inputs::torch_breakaway`) stays open as long as the torch
// presses on the plate as said above, as QtPlasmaC's breakaway input does. The simulator does
// not stop anything by itself: that is the executor's job.
//
// Operator inputs: `operator_events` (time-stamped states of the joystick, feed hold and cycle
// start) are applied at their times; set_operator() changes them at once.
//
// Fault injection (inject() before the run; each fires once at its time):
//   encoder_glitch       the counter of `axis` jumps by `counts` and stays off (lost pulses)
//   counter_wrap_misread one read of `axis` returns the value with its high byte off by one,
//                        as when the two bytes of an 8253 are read across a carry
//   estop                the E-stop input opens and stays open
//   lost_backend         exchange() returns Health::lost from then on
//   stuck_axis           `axis` jams (its load cannot move) from then on
//   arc_loss             the plasma arc goes out from then on
//   arc_start_failure    every arc start fails from then on
//   watchdog             the controller misses exchanges for longer than the watchdog allows
//   probe_miss           the sheet is gone from under the torch: no sensor finds it, nothing
//                        touches it (a probe runs to its depth limit)
//   switch_stuck         the float switch reads closed from then on
//   breakaway            the float switch is pushed closed for 0.5 s (a part tipped up under a
//                        torch that fires: QtPlasmaC reads it as a breakaway)
//   ohmic_miss           the ohmic contact never closes from then on (the float switch must
//                        take over)
//
// Determinism: one std::mt19937_64 seeded from SimOptions::seed drives all randomness.
// Real time: exchange() allocates nothing. With `realtime`, it sleeps until the period's
// deadline on the steady clock before returning.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <random>
#include <vector>

#include "engine/common/names.h"
#include "engine/hardware/backend.h"
#include "engine/hardware/operator_events.h"
#include "models/axis/plant.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sheet_map.h"

namespace machplan::sim {

struct FaultInjection {
  enum class Kind {
    encoder_glitch, counter_wrap_misread, estop, lost_backend, stuck_axis, arc_loss, arc_start_failure, watchdog,
    probe_miss, switch_stuck, breakaway, ohmic_miss
  };
  Kind kind = Kind::estop;
  double at_s = 0.0;
  int axis = 0;
  std::int32_t counts = 100;  // encoder_glitch only
};
// "jam", "encoder-glitch", "counter-misread", "estop", "lost-backend", "arc-loss",
// "arc-start-failure", "watchdog", "probe-miss", "switch-stuck", "breakaway", "ohmic-miss"
// (what `machplan run --inject` takes).
const char* to_string(FaultInjection::Kind k);
// The inverse of to_string; InputError::field("faults", ...) listing the kinds otherwise.
Parsed<FaultInjection::Kind> parse_fault_kind(std::string_view text);

using hardware::OperatorEvent;

// The simulator's own settings (the executor's options know nothing of them).
struct SimOptions {
  std::uint64_t seed = 1;
  bool realtime = false;                  // pace exchange() to the wall clock
  double realtime_speed = 1.0;            // with realtime: simulated seconds per wall second (tests: > 1)
  Eigen::Vector2d start_mm = Eigen::Vector2d::Zero();
  // Counter values at start: arbitrary, and not zero, so runs exercise the wrap.
  std::array<std::uint32_t, 2> counter_start{{40000u, 123u}};
  // 200 ms at 1 kHz, as the HAL simulation's (datasets/hal/README.md). Paced to the wall clock
  // (`machplan serve`, run --realtime), a stall of the process is told, not tripped on (see
  // the class comment).
  int watchdog_periods = 200;
  std::vector<FaultInjection> faults;     // injected at their times
  std::vector<OperatorEvent> operator_events;
  // The sheet's warp, amplitude and wavelength, mm; unset: the machine file's (sheet block).
  std::optional<std::pair<double, double>> sheet_warp_mm;
  // The sheet as a measured height map (models/sim/sheet_map.h); in place of any warp.
  std::shared_ptr<const SheetMap> sheet_map;
  void validate() const;                  // throws InputError naming the field
};

class SimBackend final : public hardware::Backend {
 public:
  explicit SimBackend(const cutting::MachineConfig& machine, const SimOptions& options = {});

  void inject(const FaultInjection& f);
  void set_operator(const hardware::OperatorInputs& op) { op_ = op; }
  // `n` periods pass without an exchange (the controller stalled); past the watchdog's limit
  // the watchdog trips.
  void miss_exchanges(int n);

  const char* name() const override { return "sim"; }
  hardware::CommandKind command_kind() const override { return hardware::CommandKind::speed_dac; }
  int watchdog_periods() const override { return opt_.watchdog_periods; }
  bool realtime() const override { return opt_.realtime; }
  double period_s() const override { return period_s_; }
  hardware::AxisSignals axis_signals(int axis) const override;
  hardware::Inputs initial_inputs() override;
  hardware::Health exchange(const hardware::Outputs& out, hardware::Inputs& in) noexcept override;
  bool true_position(Eigen::Vector2d& out_mm) const noexcept override;
  bool true_torch_gap(double& gap_mm) const noexcept override;
  // The simulated plate's height at (x, y), mm (0 on a flat sheet).
  double plate_z_mm(double x_mm, double y_mm) const noexcept;
  // Injected faults that never fired (the run ended before their time) or never took effect
  // (an arc fault with no arc after it).
  std::vector<std::string> notes() const override;

  // Runs the machine on for `seconds` with the drives disabled and the torch off (what the
  // hardware does once the controller is gone or finished).
  void coast(double seconds);

  double time_s() const { return time_s_; }
  const axis::AxisPlant& plant(int axis) const { return *plants_[axis]; }
  bool arc_burning() const { return arc_burning_; }
  bool torch_firing() const { return fire_; }
  double torch_height_mm() const { return height_mm_; }
  bool drives_enabled() const { return enabled_; }
  bool link_lost() const { return lost_; }
  bool watchdog_tripped() const { return watchdog_; }
  int arc_starts() const { return arc_starts_; }

 private:
  void advance(const hardware::Outputs& out);
  hardware::Inputs sample();
  bool uniform_fail() {
    const double p = m_.torch.kind == executor::TorchSetup::Kind::plasma ? m_.torch.plasma.arc_start_failure_probability : 0.0;
    return p > 0 && axis::uniform01(rng_) < p;
  }

  cutting::MachineConfig m_;
  SimOptions opt_;
  double period_s_;
  std::mt19937_64 rng_;
  std::array<std::unique_ptr<axis::AxisPlant>, 2> plants_;
  std::vector<FaultInjection> pending_;
  std::vector<char> fired_;
  std::vector<char> effective_;  // a fired injection changed what the machine did
  double time_s_ = 0.0;
  long ticks_ = 0;
  bool enabled_ = false, fire_ = false, arc_burning_ = false, arc_fails_ = false, arc_lost_ = false,
       arc_loss_pending_ = false;
  double arc_timer_s_ = 0.0;
  int arc_starts_ = 0;
  double height_mm_ = 0.0, height_target_mm_ = 0.0;
  bool breakaway_ = false;              // the torch presses on the plate past what its mount takes
  bool float_switch_ = false, ohmic_sense_ = false;
  bool ohmic_on_ = false, ohmic_dirty_ = false;  // ohmic sensing on; this probe's plate too dirty
  bool sheet_gone_ = false, float_stuck_ = false, ohmic_dead_ = false;  // injected
  double knock_left_s_ = 0.0;           // an injected breakaway still pushing the float
  int stalls_ = 0;                      // paced: gaps past the watchdog with the drives on
  double longest_stall_s_ = 0.0;
  void sense_plate(bool ohmic_on, bool offset_probe, double dt) noexcept;
  bool estop_ = false, lost_ = false, watchdog_ = false, arc_start_fails_ = false;
  hardware::OperatorInputs op_{};
  hardware::Outputs last_out_{};
  std::size_t next_op_ = 0;
  std::chrono::steady_clock::time_point last_return_;
  std::array<int, 2> misread_{{0, 0}};  // pending misread per axis: +-256 counts on the next read
  // The plasma process: the warped plate, the arc's voltage, the kerfs cut so far.
  std::mt19937_64 process_rng_;         // its own stream: the axes' noise draws stay as they were
  double warp_amplitude_mm_ = 0.0, warp_wavelength_mm_ = 500.0, warp_phase_x_ = 0.0, warp_phase_y_ = 0.0;
  double arc_voltage_v_ = 0.0;
  std::vector<std::uint16_t> kerf_cells_;  // the cut that burned each 2 mm cell (0: none)
  long kerf_nx_ = 0, kerf_ny_ = 0;
  std::uint16_t cut_id_ = 0;
  bool over_kerf_ = false;
  void burn_and_measure(const hardware::Outputs& out) noexcept;
  std::chrono::steady_clock::time_point t0_;
  bool started_ = false;
};

}  // namespace machplan::sim
