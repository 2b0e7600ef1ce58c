// Fitting a machine's axis factors to a calibration session log.
//
// Per axis the fit finds
//
//   mm_per_count        encoder scale: travel per counted edge
//   feed_factor         speed gain k: real speed / commanded speed (the paper's drives: 0.7)
//   dead_band_mm_per_s  the speed the drive loses to Coulomb friction, d
//   lag_s               the drive's first-order velocity lag, tau
//   latency_s           the delay from a command to the counter showing its effect, L
//                       (command and reading latency together: this data cannot tell them apart)
//   backlash_mm         the gap b between motor and load, taken up at each reversal
//
// in two stages.
//
// 1. Encoder scale. The counters are unwrapped (a 16-bit down counter moves n = (previous -
//    current) mod 65536 edges between two reads, signed by the direction bit; a read that
//    jumps further than the axis can move in one period is rejected and counted, the way the
//    executor's decoder does). The reference readings r_j are fitted as r_j = x0 + s n_j with
//    a Cauchy loss, so a misread ruler does not drag the scale.
//
// 2. Dynamics. The commanded speed u = dac / 2048 * U_fs (U_fs: the machine file's nominal DAC
//    full scale) drives the model
//
//        w   = k u(t - L) - d sgn(v)          (while at rest the axis sticks when |k u| <= d)
//        dv/dt = (w - v) / tau                (clamped to the machine file's drive current limit)
//        x_motor' = v,   x_load = clamp(x_load, x_motor - b/2, x_motor + b/2)
//
//    integrated exactly over each period (the command is piecewise constant; a fractional
//    latency splits the period in two). The session is cut into strokes at the dwells; each
//    stroke starts at rest from its measured position, with the gap on the side of the last
//    motion (the direction bit), and is one residual block of the position residuals s n_k -
//    x_load,k with a Huber loss over the stroke, so a stroke spoiled by a slip or a bump
//    weighs less. Ceres (Levenberg-Marquardt, automatic derivatives) solves it; the
//    uncertainties are the square roots of the covariance diagonal scaled by the residual
//    variance.
//
// 3. Gain against speed. The model has one feed factor; the steady speed of every held command
//    is measured as well (`by_speed`), so a gain that varies with speed (a drive reaching its
//    top speed, a non-linear amplifier) shows as a spread (`by_speed_spread`) instead of hiding
//    in the one number.
//
// What the data must hold, and what the fit says otherwise (summary infeasible, "not
// identifiable" in the report and the JSON, with the parameter named in the message; never a
// silent default): motion on the axis (feed factor), two reference readings at different
// places (encoder scale), strokes at two or more speeds (dead band vs feed factor), a reversal
// (backlash), steps of speed command (lag and latency).
//
// Ceres stays inside fit.cpp: this header shows only machplan's types.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "engine/calibration/session_log.h"
#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"
#include "models/cutting/machine_config.h"

namespace machplan::calibration {

struct FitOptions {
  double huber_mm = 0.05;       // RMS residual of a stroke beyond which it is down-weighted
  double ruler_cauchy_mm = 0.05;  // scale of the Cauchy loss on reference readings
  int max_iterations = 100;
  double min_dwell_s = 0.05;    // zero command at rest this long splits strokes; > latency
  // A parameter whose standard deviation exceeds this fraction of its value (or, for backlash
  // and latency, the absolute bounds below) is reported as not identifiable.
  double max_relative_sigma = 0.05;
  double max_backlash_sigma_mm = 0.02;
  double max_latency_sigma_s = 0.005;
  void validate() const;        // throws InputError naming the field
};

struct AxisSigma {
  double mm_per_count = 0.0, feed_factor = 0.0, dead_band_mm_per_s = 0.0, backlash_mm = 0.0, lag_s = 0.0,
         latency_s = 0.0;
};

// The speed gain measured on one held speed, from the steady part of the hold: whether the
// gain varies with speed (a drive saturating near its top speed, a non-linear amplifier)
// shows as these disagreeing with the one fitted feed factor.
struct SpeedLevel {
  double command_mm_per_s = 0.0;   // signed commanded speed
  double feed_factor = 0.0;        // (measured speed + dead band) / commanded, dead band from the fit
  double seconds = 0.0;            // steady time it was measured over (all holds at this command)
};

struct AxisFit {
  std::string axis;  // "x", "y"
  bool fitted = false;
  double mm_per_count = 0.0;
  double feed_factor = 0.0;
  double dead_band_mm_per_s = 0.0;
  double backlash_mm = 0.0;
  double lag_s = 0.0;
  double latency_s = 0.0;
  AxisSigma sigma;
  double rms_residual_mm = 0.0;   // dynamics residual of this axis
  double ruler_rms_mm = 0.0;      // reference readings against the fitted scale
  int ruler_outliers = 0;         // readings further than 5 robust standard deviations
  int samples = 0, references = 0, strokes = 0, rejected_reads = 0, iterations = 0;
  std::vector<std::string> not_identifiable;  // "PARAMETER: why", one per problem
  std::vector<SpeedLevel> by_speed;  // per held command, sorted by command
  double by_speed_spread = 0.0;      // (largest - smallest) / fitted feed factor
};

struct CalibrationFit {
  std::string machine;
  std::array<AxisFit, 2> axes;
  double rms_residual_mm = 0.0;   // over both axes
  double period_s = 0.0;          // sampling period found in the log
  // How the fit ended: done (every factor determined), infeasible (the log does not determine
  // a parameter: the message names each as AXIS.PARAMETER with the reason; the figures are
  // where the solver ended, not a calibration), or cancelled / deadline / budget (the
  // Termination ended it: an axis it had not finished is not fitted). brief_report() is one
  // line, full_report() what `machplan calibrate fit` prints.
  Summary summary;

  // The --json form, with the summary's status in its own spelling (to_string(Status)), as
  // the calibration store keeps it.
  std::string json() const;
};

// Fits `log` against the nominal machine `machine` (DAC scale, drive current limit, counter
// width, and the starting point of the search). Throws InputError naming the log line for
// logs the fit cannot use at all (irregular sampling, an axis absent); returns an infeasible
// summary for logs that do not determine a parameter.
//
// The work is the dynamics fit, one Ceres iteration after another, each integrating the whole
// session once more: each iteration charges `term` one unit ("iterations") and the seconds of
// session it integrated, and reports to `progress` (may be null; each axis is half). When
// `term` ends, the solve stops after the current iteration and the fit is not done.
CalibrationFit fit_session(const SessionLog& log, const cutting::MachineConfig& machine, const FitOptions& o,
                           Termination& term, Progress* progress = nullptr);
// The same without a stop, deadline or budget: runs to the end (at most
// FitOptions::max_iterations iterations per axis).
CalibrationFit fit_session(const SessionLog& log, const cutting::MachineConfig& machine, const FitOptions& o = {});

// The true factors of a simulated machine, in the fit's terms (feed factor, dead band and lag
// include the viscous friction the model folds into them; latency is command plus reading):
// what a perfect fit of a session recorded on `truth` against the nominal machine
// `nominal` would return.
AxisFit true_factors(const cutting::MachineConfig& truth, const cutting::MachineConfig& nominal, int axis);

}  // namespace machplan::calibration
