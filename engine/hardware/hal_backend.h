// A machine reached through LinuxCNC's HAL: the backend behind `--backend hal`.
//
// Two halves. On the servo thread, the real-time component `machplan`
// (engine/hardware/hal/machplan.comp, installed by scripts/setup) owns the pins a machine's HAL
// file nets to its hardware (docs/hal.md lists them) and the watchdog. In the machplan program,
// this backend exchanges one command and one sample per servo period with the component
// through a block of RTAPI shared memory (engine/hardware/hal/exchange_block.h). Nothing in
// this header needs HAL's headers: they are included by hal_backend.cpp only.
//
// How the executor's loop and the servo thread meet. The component never waits for the
// program; the program waits for the component. Every period p the component
//   1. takes the command the program wrote for period p (a slot tagged with p), if it is
//      there and complete, and drives the output pins with it;
//   2. writes the input pins into sample p and publishes p as the newest period.
// exchange(out) writes `out` as the command for period s + Q, where s is the sample it is
// about to return and Q the command queue (below), then sleeps until sample s is due (an
// absolute-time wait on CLOCK_MONOTONIC, predicted from the component's time stamps), reads it
// and returns. The next exchange returns sample s + 1. So the executor's loop runs at the
// servo thread's pace, one exchange per period, and each command is in place Q periods before
// the period it is meant for.
//
// Why it is correct. Commands and samples are tagged with the period they belong to, and each
// ring slot is guarded by a sequence number (written odd, then even): the component takes a
// command only when its tag is the period it is running and the slot was not being written,
// and the program takes a sample only when its tag is the one it waits for. Neither side takes
// a lock, so neither can block the other; a torn or stale slot is simply not taken. The
// program sees every period's sample, in order, exactly once, so the positions it decodes never
// jump however late it runs; the safety flags (E-stop, watchdog) are taken from the newest
// sample instead, so that a trip is reported in the next exchange, as the contract asks.
//
// What happens when machplan is late. A command written after its period began is too late:
// it is counted (`timing().late`), and the component has already filled that period by itself
// - the position commands take the positions the executor planned for those periods
// (Outputs::ahead_mm, written into those periods' slots with each command, up to
// Outputs::kMaxAhead periods ahead) and, beyond them or without a plan, go on at their last
// speed (less `stop-decel`); a speed command is held; the torch and the drives stay as they
// were. The program then finds the samples it missed waiting, returns them one after the
// other without sleeping, and is back in step after a few exchanges; its late commands in the
// meantime are dropped by the component, which goes on as above until one arrives in time.
// When no command arrives in time for more than `watchdog_periods()` periods in a row while
// the drives or the torch are on (machplan killed, hung, or far too slow; a period played from
// the plan counts as missed), the component trips by itself: torch-on and enable FALSE in that
// period, the position commands held (or ramped to rest at `stop-decel`), watchdog-ok FALSE
// until watchdog-reset or the next session. Late exchanges are thus counted and absorbed up to
// the watchdog, and only the watchdog ends a run.
//
// The latency it adds. A sample is taken when the period starts, before that period's command
// acts on the machine, so the feedback exchange() returns is one period old against the
// contract's ideal (`reading_latency_ticks` = 1), as on any controller that reads the hardware,
// computes and writes within one servo period. Commands are queued Q periods ahead, Q being the
// machine file's `command_latency_ticks` (1 for the bundled machines): `command_latency_ticks` =
// Q. The program therefore has Q + 1 periods from a sample to the command that depends on it;
// with the thermal gantry, 2 ms at 1 kHz. The machine file must say reading_ticks 1 (and the
// same command_ticks on both axes): the backend refuses to open otherwise, naming the axis.
//
// Drives. The component's `velocity-mode` parameter, set by the machine's HAL file, chooses
// the command kind: FALSE, `position` (pos-cmd out, pos-fb in: drives that close their own
// position loop, or LinuxCNC's pid components doing it on the servo thread); TRUE, `speed_dac`
// (vel-cmd out in mm/s at the drive's nominal scaling, the executor's DAC code times the
// machine file's full-scale speed over the code's range; counts in, raw encoder counts
// presented to the executor as the machine file's counter: `counter_bits` wide, counting down
// with a direction bit, so that its decoder and plausibility checks apply unchanged).
// In velocity mode pos-fb, when linked, is a second and independent measurement of each axis
// (a linear scale, or the simulation's load position): true_position() returns it, so that a
// calibration session has its ruler and a run its true contour error.
// Position mode needs the axes to stand where the job starts (within `start_tolerance_mm`):
// the machine is where it is, and the backend refuses to open a job elsewhere rather than jump.
// Velocity mode has no absolute position: the machine is taken to stand at the job's start, as
// the paper's machine stood at its work reference point.
//
// Torch and operator signals. Every command carries torch-on and ohmic-enable
// (Outputs::ohmic_enable), which the component gates with the E-stop chain, the operator's
// E-stop and the watchdog in the same period. Every sample carries the torch height, arc-ok,
// the arc voltage, the float switch, the ohmic contact and the breakaway (Inputs), and the
// operator's pins (OperatorInputs: jog, feed hold, cycle start, stop, the two overrides, cut
// recovery, THC allowed, the operator's E-stop). The overrides are clamped to their ranges
// (not a number: 100 %); cut recovery, a counter, is reported from where it stood when the
// session opened. docs/hal.md lists the pins and the plasmac pins they stand for.
//
// Real time on the program's side. When the process may (root or CAP_SYS_NICE, and
// RLIMIT_MEMLOCK), opening locks its memory (mlockall) and moves the calling thread, the one
// that then runs the executor, to SCHED_FIFO at `fifo_priority`; when it may not, it says so
// once on stderr and in notes(), and runs anyway. notes() after a run gives the exchange
// jitter (how far each interval between two exchanges strayed from the period: p50, p99,
// p99.9, max) and the late exchanges, so that an operator sees whether this PC keeps up.
//
// Bad setups throw InputError when the backend opens, never hang: HAL not running, the
// component missing, its function not running in a thread, a second machplan already driving
// the machine, a pin the machine needs not linked (named, with what to net it to), a servo
// period that differs from the machine file's (both values), the axes away from the job's
// start. Once open, a component that stops running (HAL stopped, unloaded, crashed) makes
// exchange() return Health::lost after `lost_after_s`, and lost is final.
//
// Threading: the thread that constructs the backend must be the one that exchanges (it is the
// one made real-time). exchange() allocates nothing, takes no lock and makes no system call
// but the clock and the sleep.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/hardware/backend.h"

namespace machplan::hardware {

struct HalOptions {
  // The machine file's servo period: the HAL thread that runs machplan must have it.
  double period_s = 0.001;
  // The machine file's axis signals: the latencies (both modes), the DAC scale and counter
  // width (velocity mode).
  std::array<AxisSignals, kAxes> signals{};
  bool torch = false;          // the machine has a torch: torch-on must be linked
  bool arc_ok_signal = false;  // plasma: arc-ok must be linked
  bool torch_height = false;   // a torch height axis: torch-height-cmd and -fb must be linked
  // Position mode: where the job starts, and how far from it the axes may stand, mm.
  Eigen::Vector2d start_mm = Eigen::Vector2d::Zero();
  double start_tolerance_mm = 0.05;  // the executor refuses a first feedback further than ~0.13 mm
  // Opening: how long HAL has to show the component running and to take the session, s.
  double connect_timeout_s = 2.0;
  // No new sample for this long once open: the link is lost (final), s. Longer than any
  // watchdog the component allows (200 periods).
  double lost_after_s = 0.5;
  // Lock the memory and run the calling thread SCHED_FIFO when the process may.
  bool realtime = true;
  int fifo_priority = 70;  // 1 .. 99
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// The exchange's timing over the session so far.
struct HalTiming {
  long exchanges = 0;
  long late = 0;              // commands written after their period had begun
  long played_ahead = 0;      // periods without a command in time where the axes took the planned position
  long coasted = 0;           // periods without a command in time, and without a plan: the axes coasted
  long samples_skipped = 0;   // samples the program fell so far behind that the ring overwrote them
  double jitter_p50_s = 0.0, jitter_p99_s = 0.0, jitter_p999_s = 0.0, jitter_max_s = 0.0;
  bool realtime = false;      // SCHED_FIFO and locked memory in force
  std::string realtime_note;  // what was done, or why not
  std::string summary() const;  // one sentence
};

class HalBackend final : public Backend {
 public:
  // Opens a session with the running `machplan` component; see the file comment for what is
  // checked. Throws InputError with what to do about it.
  explicit HalBackend(const HalOptions& options);
  // Ends the session: the component goes idle (outputs off) without tripping the watchdog.
  ~HalBackend() override;
  HalBackend(const HalBackend&) = delete;
  HalBackend& operator=(const HalBackend&) = delete;

  const char* name() const override { return "hal"; }
  CommandKind command_kind() const override;
  double period_s() const override;  // the HAL thread's, as the component measured it
  AxisSignals axis_signals(int axis) const override;
  int watchdog_periods() const override;
  int plays_ahead_periods() const override;  // Outputs::kMaxAhead in position mode  // the component's watchdog-periods parameter
  Inputs initial_inputs() override;
  Health exchange(const Outputs& out, Inputs& in) noexcept override;
  // Velocity mode with pos-fb linked: pos-fb of the last sample returned. False otherwise.
  bool true_position(Eigen::Vector2d& out_mm) const noexcept override;
  std::vector<std::string> notes() const override;

  HalTiming timing() const;
  // The servo period the last returned sample was taken in (the component's period count).
  std::uint32_t last_period() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace machplan::hardware
