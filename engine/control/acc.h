// Adaptive control with a force constraint (ACC) for turning: the feed is raised or lowered
// every sample so that the main cutting force holds a reference value, whatever the depth of
// cut does. After Koren's review "Control of Machine Tools" (section 4.2) and the turning
// systems of Masory and Koren it cites. The turning process it is tried on, and the runs of
// the loop on it, are a model: models/turning/turning_process.h.
//
// The loop (AccController), once per sample period T (Koren: T = 0.1 s), on the measured
// force F_c:
//
//     E[k] = F_r - F_c[k]                                   force error, N
//     fixed gain      f_cmd[k] = f_cmd[k-1] + Kc (E[k] / F_r) f_step
//     variable gain   f_cmd[k] = f_cmd[k-1] + L0 E[k] f_cmd[k-1] / (beta F_c[k])
//     f_cmd clamped to [f_min, f_max]; f_max is the programmed feed (Koren: 0.5 mm/rev)
//
// Why the variable gain. Around an operating point the process gain is dF/df = beta F / f
// (for the static force F_s = Ks a f^beta of the process), so the fixed law's open-loop gain
// is L = Kc beta f_step / f: it grows as the feed falls, and a deeper cut (lower feed at the
// same force) drives the loop toward instability, as the paper warns. The variable-gain law
// divides by the process gain estimated from the measured force and the current feed, so its
// open-loop gain stays L0 at every depth (while the cut holds force; in air, where F_c is
// near zero, the estimate is bounded below by `min_force_for_estimate_n` and the law falls
// back to the fixed one).
//
// Units: N, mm, mm/rev, s.
#pragma once

namespace machplan::control {

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

}  // namespace machplan::control
