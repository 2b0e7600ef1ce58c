// The boundary between the executor and a machine: one exchange of signals per servo period.
//
// The executor never talks to drives, counters or the torch in any other way. Per tick it
// hands the backend an `Outputs` (speed command per axis as a DAC code, drive enable, torch
// and torch-height commands) and gets back an `Inputs` (raw counter values with direction
// bits, arc OK, E-stop, torch height) and a health verdict. Everything raw stays raw: the
// executor decodes counters itself (engine/control/counter_decoder.h) so that the same code
// checks them whatever sits behind this interface.
//
// Timing contract of exchange(): the outputs take effect at the start of the period that the
// call begins, and the inputs are those sampled at its end; the call returns when that period
// is over. A simulator runs the period as fast as it can (or paces it to the wall clock); a
// real controller (a later issue connects LinuxCNC through its HAL shared memory or a
// realtime component) blocks until its servo thread has run the period. Either way the
// executor's loop is paced by the backend, and its own computation between two exchanges must
// fit in the period (see engine/executor/executor.h for the budget).
//
// Safety contract: a backend must stop the drives and the torch on its own (a watchdog) when
// exchanges stop arriving or when it reports `lost`; the executor can only stop what it can
// still talk to. `lost` is final: the executor makes no further exchange after it.
//
// Threading: a backend is used by one thread, the executor's; request_stop() on the executor
// is the only cross-thread entry.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

namespace machplan::hardware {

inline constexpr int kAxes = 2;  // X and Y; the torch height is a separate output

struct Outputs {
  std::array<std::int32_t, kAxes> dac_code{};  // speed command, signed DAC code
  bool drives_enabled = false;                  // power relays / drive enable
  bool torch_fire = false;                      // plasma: start and hold the arc; oxy-fuel: cutting oxygen
  double torch_height_target_mm = 0.0;          // height of the torch above the plate
};

struct Inputs {
  std::array<std::uint32_t, kAxes> counter{};   // raw counter values
  std::array<bool, kAxes> counter_direction_negative{};  // direction bits
  bool arc_ok = false;                          // plasma source reports a transferred arc
  bool estop = false;                           // the E-stop chain is open
  double torch_height_mm = 0.0;                 // torch height axis position
};

enum class Health { ok, lost };

// Static facts about the hardware the executor needs to interpret raw signals.
struct AxisSignals {
  double mm_per_count = 0.0;             // travel per counted edge
  int counter_bits = 16;
  int dac_bits = 12;
  double dac_full_scale_mm_per_s = 0.0;  // speed commanded by the largest DAC code (nominal)
  int command_latency_ticks = 0;         // periods between exchange() and the drive acting
  int reading_latency_ticks = 0;         // age of the counter values exchange() returns, periods
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual double period_s() const = 0;
  virtual AxisSignals axis_signals(int axis) const = 0;

  // The inputs before the first period (counters as they stand), to set the decoders.
  virtual Inputs initial_inputs() = 0;

  // One servo period; see the timing contract above. Never throws.
  virtual Health exchange(const Outputs& out, Inputs& in) noexcept = 0;

  // Truth for traces and error figures, when the backend knows it (a simulator does; a real
  // machine does not): the load position of each axis. Returns false when unknown.
  virtual bool true_position(Eigen::Vector2d& out_mm) const noexcept {
    (void)out_mm;
    return false;
  }
};

}  // namespace machplan::hardware
