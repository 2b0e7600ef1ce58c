// The boundary between the executor and a machine, version 2: one exchange of signals per servo
// period.
//
// The executor never talks to drives, counters, the torch or the operator's panel in any other
// way. Per tick it hands the backend an `Outputs` and gets back an `Inputs` and a health
// verdict. A backend declares what it offers (`command_kind()`):
//
//   speed_dac   the executor closes the position loop: it sends a speed command per axis as a
//               signed DAC code and reads raw counter values with direction bits (the thermal
//               gantry's DAC80 and 8253 board; models/sim). Counters stay raw: the executor's
//               feedback adapter (engine/executor/feedback_adapter.h) decodes them, so the same
//               code checks them whatever sits behind this interface.
//   position    the drive (or a motion controller such as LinuxCNC's HAL motion module) closes
//               its own position loop: the executor sends a position command per axis and reads
//               the position feedback in mm.
//
// Operator inputs (jog deflection per axis, feed hold, cycle start) and the E-stop chain arrive
// in `Inputs` like every other signal, sampled with them.
//
// Timing contract of exchange(): the outputs take effect at the start of the period that the
// call begins, and the inputs are those sampled at its end; the call returns when that period
// is over. A simulator runs the period as fast as it can (or paces it to the wall clock); a
// real controller blocks until its servo thread has run the period. Either way the executor's
// loop is paced by the backend, and its own computation between two exchanges must fit in the
// period (see engine/executor/executor.h for the budget).
//
// Safety contract:
//   * watchdog: when no exchange arrives for `watchdog_periods()` periods the backend stops
//     the drives and the torch by itself and reports it in the next Inputs
//     (`watchdog_tripped`, latched: the drives stay off for the rest of the session);
//   * `lost` is final: once exchange() returned Health::lost it returns lost for ever, and the
//     executor makes no further exchange after it; a lost backend must have stopped the
//     machine on its own;
//   * the E-stop chain cuts drives and torch in hardware; `estop` reports it.
// The executor can only stop what it can still talk to.
//
// Threading: a backend is used by one thread, the executor's; the executor's request_stop()
// is the only cross-thread entry into a run.
//
// A new backend: implement this interface, add it to the factory
// (models/backends/backend_factory.h) and one line to the contract test suite
// (tests/hardware/backend_contract_test.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace machplan::hardware {

inline constexpr int kAxes = 2;  // X and Y; the torch height is a separate output

enum class CommandKind { speed_dac, position };
const char* to_string(CommandKind k);

// What the operator's panel says this period. Buttons are levels that the executor reads on
// their rising edge (a press must last at least one period; a HAL pin, a panel button, the
// simulator's timeline all hold it longer); overrides and switches are levels that last.
struct OperatorInputs {
  std::array<double, kAxes> jog{};  // joystick deflection per axis, -1 .. 1 (0: centred)
  bool feed_hold = false;           // button: bring the motion to rest along the path (GRBL '!')
  bool cycle_start = false;         // button: resume after a hold (GRBL '~'); ends a jog session
  bool stop = false;                // button: end the job with a controlled stop, torch off
  double feed_override_pct = 100.0;   // feed moves' speed, 0 .. 200 % of the programmed (0: as a hold)
  double rapid_override_pct = 100.0;  // rapids' speed, 1 .. 100 % of the planned
  // Paused motion (while a job is held: along the program's path, torch off), two ways:
  // - the total distance asked so far, mm (negative: back along the path). A counter, so that
  //   no request is lost between two samples: each change is a request of that many mm;
  // - a speed held while it is not 0, a fraction -1 .. 1 of the machine's paused-motion speed
  //   (QtPlasmaC's paused-motion-speed; negative: back).
  double paused_motion_mm = 0.0;
  double paused_motion_speed = 0.0;
  bool thc_enabled = true;          // torch height control allowed (plasma)
  // The torch may fire (QtPlasmaC's torch-enable; a level). Off: the job runs its motion dry,
  // its pierces skipped; turned off while the torch fires, it holds the job (the torch goes off
  // before rest) and the resume goes on dry.
  bool torch_enabled = true;
  // A level, not a button: the operator's E-stop (a panel's, a pendant's) is open. The
  // executor treats it as the E-stop chain opening (Inputs::estop): fault estop, torch off in
  // the same period, controlled stop. It stays open until the operator resets it.
  bool estop = false;
};

struct Outputs {
  std::array<std::int32_t, kAxes> dac_code{};        // speed_dac: speed command, signed DAC code
  std::array<double, kAxes> position_command_mm{};   // position: where each axis must be
  bool drives_enabled = false;                        // power relays / drive enable
  bool torch_fire = false;     // plasma: start and hold the arc; oxy-fuel: cutting oxygen
  // Where the torch height axis must be, mm in the machine's height frame: 0 is the sheet's
  // nominal surface (a flat sheet on the slats), up is positive. The executor adds the heights
  // above the plate to the surface its last probe found (engine/executor/torch_sequencer.h).
  double torch_height_target_mm = 0.0;
  // Ohmic sensing on: the torch's shield is energised so that touching the plate closes
  // `Inputs::ohmic_sense` (QtPlasmaC's ohmic-enable; on only while probing).
  bool ohmic_enable = false;
  // The offset probe deployed (ProbeSetup::offset_x_mm): down beside the torch, its contact
  // read on `Inputs::float_switch`; stowed otherwise.
  bool offset_probe = false;
  // The laser pointer on (framing with it: motion::Job::laser_pointer).
  bool laser_on = false;
  // Plasma: the cut chart of the material in force, the arc voltage it gives at its cut height
  // (0: no material, or one without CUT_VOLTS). A real arc's voltage is physics; the simulated
  // source and plate take the chart as theirs (models/sim/sim_backend.h), as a shop's chart is
  // made for its own source and plate. Real hardware ignores it.
  double chart_volts_v = 0.0, chart_height_mm = 0.0;
  // Position mode: where the plan puts the axes 1 .. ahead_count periods after this command,
  // for a backend whose hardware runs on without waiting for the program (HAL): when a command
  // comes late, the machine takes the planned position instead of coasting off the path. 0
  // whenever the executor cannot say (stopping, holding by its own law, a source without a
  // plan); a backend that waits for every command ignores them.
  static constexpr int kMaxAhead = 100;
  std::array<std::array<double, kAxes>, kMaxAhead> ahead_mm{};
  int ahead_count = 0;
};

struct Inputs {
  std::array<std::uint32_t, kAxes> counter{};             // speed_dac: raw counter values
  std::array<bool, kAxes> counter_direction_negative{};   // speed_dac: direction bits
  std::array<double, kAxes> position_feedback_mm{};       // position: measured axis positions
  bool arc_ok = false;             // plasma source reports a transferred arc
  bool estop = false;              // the E-stop chain is open
  bool watchdog_tripped = false;   // the backend stopped the machine: exchanges came too late
  double torch_height_mm = 0.0;    // torch height axis position, mm in the frame of Outputs::torch_height_target_mm
  double arc_voltage_v = 0.0;      // plasma: the arc's voltage while it burns (0: not measured)
  // The torch's breakaway switch is open: the torch met something (the plate, a tipped-up
  // part) and its mount gave way, QtPlasmaC's "breakaway". A collision: the executor stops.
  bool torch_breakaway = false;
  // The float switch is closed: the torch rests on something and its floating mount has risen
  // by the switch's travel (QtPlasmaC's float-switch). Probing looks for it; while the torch
  // fires it is a breakaway.
  bool float_switch = false;
  // The ohmic contact is made: with Outputs::ohmic_enable on, the torch's shield touches the
  // plate (QtPlasmaC's ohmic-sense-in). A dirty or painted plate may never close it.
  bool ohmic_sense = false;
  OperatorInputs op;
};

enum class Health { ok, lost };

// Static facts about one axis's signals, which the executor needs to interpret them. The
// executor checks them against the machine file at the start of a run.
struct AxisSignals {
  double mm_per_count = 0.0;             // speed_dac: travel per counted edge
  int counter_bits = 16;                 // speed_dac
  int dac_bits = 12;                     // speed_dac
  double dac_full_scale_mm_per_s = 0.0;  // speed commanded by the largest DAC code (nominal)
  int command_latency_ticks = 0;         // periods between exchange() and the drive acting
  int reading_latency_ticks = 0;         // age of the feedback exchange() returns, periods
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual const char* name() const = 0;
  virtual CommandKind command_kind() const = 0;
  virtual double period_s() const = 0;
  virtual AxisSignals axis_signals(int axis) const = 0;
  // Periods without an exchange after which the backend's watchdog stops the machine.
  virtual int watchdog_periods() const = 0;
  // True when each exchange takes one real period of wall-clock time (a machine, a paced
  // simulator). False for a simulator running as fast as it can: then nothing depends on the
  // loop's timing, and the executor may wait inside a tick (for its trace writer) without harm.
  virtual bool realtime() const { return true; }
  // How many periods of positions planned ahead (Outputs::ahead_mm) the backend plays when a
  // command comes late; 0: it waits for every command, and the executor does not plan them.
  virtual int plays_ahead_periods() const { return 0; }

  // The inputs before the first period (counters or positions as they stand), to set the
  // feedback adapter. Makes no exchange.
  virtual Inputs initial_inputs() = 0;

  // One servo period; see the timing contract above. Never throws.
  virtual Health exchange(const Outputs& out, Inputs& in) noexcept = 0;

  // Truth for traces and error figures, when the backend knows it (a simulator does; a real
  // machine does not): the load position of each axis. Returns false when unknown.
  virtual bool true_position(Eigen::Vector2d& out_mm) const noexcept {
    (void)out_mm;
    return false;
  }

  // Truth for THC figures, when the backend knows it: the torch's real distance to the plate
  // now, mm. Returns false when unknown (a real machine).
  virtual bool true_torch_gap(double& gap_mm) const noexcept {
    (void)gap_mm;
    return false;
  }

  // After a run (not real time): what the backend has to say about it that the executor
  // cannot know, one sentence each; e.g. a simulator's injected fault that never took effect.
  virtual std::vector<std::string> notes() const { return {}; }
};

}  // namespace machplan::hardware
