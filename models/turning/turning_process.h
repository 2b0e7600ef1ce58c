// A turning process for the adaptive control constraint (engine/control/acc.h): the plant the
// feed-override loop is tried and tuned on (solvers/tuning/acc_tuning.h, `machplan tune
// --acc`), and runs of the loop on it. After Koren's review "Control of Machine Tools"
// (section 4.2) and the turning systems of Masory and Koren it cites.
//
// The process (TurningProcess), simulated in steps of `dt_s`:
//
//     feed actually cut     df/dt = (f_cmd - f) / tau_feed          the feed drive follows the
//                                                                    commanded feed (mm/rev)
//     static force          F_s  = Ks a f^beta    (a > 0; 0 in air)  a: depth of cut, mm
//     force                 dF/dt = (F_s - F) / tau_force            the chip of one revolution
//                                                                    and the dynamometer's filter
//     measured force        F_c  = F + n,   n ~ N(0, sigma)          drawn at each sample
//
// Units: N, mm, mm/rev, s. Everything is deterministic for a given seed.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/control/acc.h"

namespace machplan::turning {

// The turning process. Ks and beta are reconstructed: the paper gives no process law, only
// that the feed falls from 0.5 to about 0.25 mm/rev at 1500 N after engagement; Ks is chosen
// so that the first depth (2 mm) cuts 1500 N at 0.25 mm/rev, and beta = 0.75 is a typical
// feed exponent for steel.
struct TurningProcess {
  double ks_n_per_mm = 1500.0 / (2.0 * 0.35355339059327373);  // Ks: 1500 N at a = 2 mm, f = 0.25 mm/rev
  double beta = 0.75;                  // feed exponent
  double feed_time_constant_s = 0.03;  // tau_feed: the feed drive
  double force_time_constant_s = 0.06; // tau_force: one revolution at 1000 rpm and the sensor
  double force_noise_n = 0.0;          // sigma of the measured force
  double dt_s = 0.001;                 // integration step
  // Throws InputError::field naming the field, its value and the rule.
  void validate() const;
  // The static force at depth `depth_mm` and feed `feed_mm_per_rev`, N.
  double static_force_n(double depth_mm, double feed_mm_per_rev) const;
  // The feed that cuts `force_n` at `depth_mm` (the loop's steady state), mm/rev.
  double feed_for_force(double depth_mm, double force_n) const;
};

// A depth of cut that holds from `from_s` on (a stepped shaft); 0 is air.
struct DepthChange {
  double from_s = 0.0;
  double depth_mm = 0.0;
};

struct AccSample {
  double t_s = 0.0, depth_mm = 0.0, feed_cmd_mm_per_rev = 0.0, feed_mm_per_rev = 0.0, force_n = 0.0,
         measured_force_n = 0.0;
};

// Runs the loop on the process for `duration_s` with the depth schedule `depths` (sorted by
// from_s; the depth is 0 before the first). One sample per control period (at its instant,
// after the update). Throws InputError::field on invalid options or schedule.
std::vector<AccSample> simulate_acc(const TurningProcess& process, const control::AccOptions& options,
                                    const std::vector<DepthChange>& depths, double duration_s, std::uint64_t seed = 1);

// The paper's test: engagement at 1 s at 2 mm, then +2 mm at 4 s and 7 s, 10 s in all.
std::vector<DepthChange> koren_depth_steps();

// How the force answers one depth change in a run: from the change on, settling time into
// +-band of F_r, and overshoot: the largest excursion past F_r on the far side from where the
// change pushed the force (the first excursion beyond the band in the direction the force
// moves from its value at the change), as a fraction of F_r.
struct AccStepResponse {
  double settling_s = 0.0;   // infinity if it never settles within the window
  double overshoot = 0.0;    // fraction of F_r
  double final_error = 0.0;  // |F - F_r| / F_r at the end of the window
};
AccStepResponse acc_step_response(const std::vector<AccSample>& run, double reference_force_n, double from_s,
                                  double to_s, double band = 0.02);

}  // namespace machplan::turning
