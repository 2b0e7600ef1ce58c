// The calibration routine: drives each axis through strokes at several speeds in both
// directions and writes what it commanded and read as a session log
// (engine/calibration/session_log.h).
//
// It talks to the machine only through hardware::Backend (speed_dac backends: a DAC code out,
// a raw counter and direction bit in, per axis and period), so the same routine runs on the
// simulator and on a real controller. The machine file gives the nominal DAC scale; the
// routine commands fractions of the DAC's full scale and never needs the machine's true
// factors, which are what the fit finds.
//
// The program, run on both axes at once:
//   * drives enabled with a zero command for `settle_s` (a zero first command arms the drive
//     without the start shock the paper saw), then a reference reading;
//   * for each speed in `speed_fractions` (of DAC full scale): a positive stroke and a negative
//     stroke. Each stroke climbs to its speed in stairs of at most `stair_fraction` of full
//     scale held `stair_hold_s` each (the step responses that show lag and latency, small
//     enough to stay under the drive's current limit), holds the speed for `stroke_hold_s`,
//     steps down the same way, and dwells `dwell_s` at zero command; a reference reading is
//     taken at the end of each dwell. Each stroke reverses the previous one (backlash);
//   * the whole program repeats `repeats` times.
//
// Reference readings ("ruler"): a real machine needs an independent measurement (a ruler, dial
// or laser) at the stroke ends. A backend that knows its true positions (the simulator) is
// read as that ruler, with Gaussian reading noise `ruler_noise_mm` drawn from the routine's
// own RNG seeded with `seed`; a backend that does not is logged without reference readings
// (the fit then reports the encoder scale as not identifiable).
#pragma once

#include <cstdint>
#include <vector>

#include "engine/calibration/session_log.h"
#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "engine/hardware/backend.h"
#include "models/cutting/machine_config.h"

namespace machplan::calibration {

struct RecordOptions {
  std::vector<double> speed_fractions{0.15, 0.3, 0.5, 0.7};  // of DAC full scale, each in (0, 1]
  double stair_fraction = 0.2;    // largest command step, of full scale, in (0, 1]
  double stair_hold_s = 0.08;     // long against the drive's lag, so each step settles
  double stroke_hold_s = 1.2;     // the steady part of a stroke: the speed gain
  double dwell_s = 0.4;           // at rest between strokes: the axis settles before the ruler
  double settle_s = 0.2;          // zero command after enabling
  int repeats = 1;                // >= 1
  double ruler_noise_mm = 0.005;  // std dev of a reference reading, >= 0
  std::uint64_t seed = 1;         // the ruler's noise
  // After a stop request (or the deadline or budget of the routine's Termination, charged one
  // period per period): zero speed for this long, then drives off.
  double stop_s = 0.3;            // > several lags of the drive, so the axes are at rest
  void validate() const;          // throws InputError naming the field
};

// Length of the program in periods of `period_s`.
long record_periods(const RecordOptions& o, double period_s);

// A recorded session and how the recording ended: done (the whole routine); faulted (the
// backend was lost, the E-stop opened or the watchdog tripped); cancelled, deadline or budget
// (`termination` ended it, after the axes were stopped). Anything but done is no calibration
// session: the log holds the samples read until then.
struct Recording {
  SessionLog log;
  Summary summary;
};

// Runs the routine on `backend` (speed_dac only; InputError otherwise). `nominal` is the
// machine file (names, DAC scale); its comments go into the log. Each period is charged to
// `termination` (one unit and the period's seconds). `progress` (may be null) follows the
// routine's periods.
Recording record_session(hardware::Backend& backend, const cutting::MachineConfig& nominal, const RecordOptions& o,
                         Termination& termination, Progress* progress = nullptr);

}  // namespace machplan::calibration
