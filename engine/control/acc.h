// Adaptive control with a force constraint (ACC) for turning: the feed is raised or lowered
// every sample so that the main cutting force holds a reference value, whatever the depth of
// cut does. After Koren's review "Control of Machine Tools" (section 4.2) and the turning
// systems of Masory and Koren it cites.
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
// The loop (AccController), once per sample period T (Koren: T = 0.1 s):
//
//     E[k] = F_r - F_c[k]                                   force error, N
//     fixed gain      f_cmd[k] = f_cmd[k-1] + Kc (E[k] / F_r) f_step
//     variable gain   f_cmd[k] = f_cmd[k-1] + L0 E[k] f_cmd[k-1] / (beta F_c[k])
//     f_cmd clamped to [f_min, f_max]; f_max is the programmed feed (Koren: 0.5 mm/rev)
//
// Why the variable gain. Around an operating point the process gain is dF/df = beta F / f,
// so the fixed law's open-loop gain is L = Kc beta f_step / f: it grows as the feed falls,
// and a deeper cut (lower feed at the same force) drives the loop toward instability, as the
// paper warns. The variable-gain law divides by the process gain estimated from the measured
// force and the current feed, so its open-loop gain stays L0 at every depth (while the cut
// holds force; in air, where F_c is near zero, the estimate is bounded below by
// `min_force_for_estimate_n` and the law falls back to the fixed one).
//
// Units: N, mm, mm/rev, s. Everything is deterministic for a given seed.
#pragma once

#include <cstdint>
#include <vector>

namespace machplan::control {

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
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
  // The static force at depth `depth_mm` and feed `feed_mm_per_rev`, N.
  double static_force_n(double depth_mm, double feed_mm_per_rev) const;
  // The feed that cuts `force_n` at `depth_mm` (the loop's steady state), mm/rev.
  double feed_for_force(double depth_mm, double force_n) const;
};

struct AccOptions {
  double sample_s = 0.1;               // T (Koren: 0.1 s)
  double reference_force_n = 1500.0;   // F_r (Koren: 1500 N)
  bool variable_gain = false;
  double kc = 0.5;                     // fixed-gain law's Kc (Koren: 0.5), dimensionless
  // Feed change per sample at Kc = 1 and a force error of F_r. Reconstructed: 0.1 mm/rev makes
  // Kc = 0.5 settle the paper's 2 mm depth steps (open-loop gain 0.15 .. 0.65) without overshoot.
  double feed_step_mm_per_rev = 0.1;
  double open_loop_gain = 0.5;         // L0 of the variable-gain law
  double max_feed_mm_per_rev = 0.5;    // programmed feed (Koren: 0.5 mm/rev before engagement)
  double min_feed_mm_per_rev = 0.01;
  double min_force_for_estimate_n = 100.0;
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// The feed-override loop of the file comment. Real time: update() is O(1), allocates nothing.
class AccController {
 public:
  explicit AccController(const AccOptions& o, double beta) : o_(o), beta_(beta) { reset(); }
  void reset() { feed_ = o_.max_feed_mm_per_rev; }
  // One sample: the measured force in, the commanded feed out, mm/rev.
  double update(double measured_force_n) noexcept;
  double feed_mm_per_rev() const { return feed_; }
  // The open-loop gain the law has at (force, feed): Kc beta f_step / f, or L0.
  double open_loop_gain(double feed_mm_per_rev) const;

 private:
  AccOptions o_;
  double beta_;
  double feed_ = 0.5;
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
// after the update). Throws InputError on invalid options or schedule.
std::vector<AccSample> simulate_acc(const TurningProcess& process, const AccOptions& options,
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

}  // namespace machplan::control
