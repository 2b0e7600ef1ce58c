#include "solvers/calibration/apply.h"

#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::calibration {

executor::MachineSetup apply_calibration(executor::MachineSetup setup, const StoredFit& c) {
  for (int a = 0; a < hardware::kAxes; ++a) {
    const double k = c.feed_factor[a], b = c.backlash_mm[a];
    if (!(std::isfinite(k) && k > 0.05 && k < 20))
      throw InputError("--db", 0, fmt::format("stored fit {} has axis {} feed factor {}, outside (0.05, 20)", c.fit_id,
                                              a == 0 ? "x" : "y", k));
    if (!(std::isfinite(b) && b >= 0 && b < 10))
      throw InputError("--db", 0, fmt::format("stored fit {} has axis {} backlash {} mm, outside [0, 10)", c.fit_id,
                                              a == 0 ? "x" : "y", b));
    const double q = c.mm_per_count[a], nominal = setup.signals[a].mm_per_count;
    // 0: the fit holds no encoder scale; the declared one stays.
    if (!(std::isfinite(q) && q >= 0 && (q == 0 || std::abs(q / nominal - 1) <= 0.1)))
      throw InputError("--db", 0, fmt::format("stored fit {} has axis {} encoder scale {} mm per count, more than 10 % "
                                              "from the machine file's {}",
                                              c.fit_id, a == 0 ? "x" : "y", q, nominal));
    setup.calibrated_mm_per_count[a] = q;
    setup.servo[a].velocity_ff = 1.0 / k;
    setup.servo[a].backlash_compensation_mm = b;
  }
  return setup;
}

}  // namespace machplan::calibration
