#include "solvers/calibration/apply.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::calibration {

executor::MachineSetup apply_calibration(executor::MachineSetup setup, const StoredFit& c) {
  const auto bad = [&](const std::string& what) {
    throw InputError::field("calibration", fmt::format("stored fit {} has {}", c.fit_id, what));
  };
  for (int a = 0; a < hardware::kAxes; ++a) {
    const char* axis = a == 0 ? "x" : "y";
    const double k = c.feed_factor[a], b = c.backlash_mm[a];
    if (!(std::isfinite(k) && k > 0.05 && k < 20)) bad(fmt::format("axis {} feed factor {}, outside (0.05, 20)", axis, k));
    if (!(std::isfinite(b) && b >= 0 && b < 10)) bad(fmt::format("axis {} backlash {} mm, outside [0, 10)", axis, b));
    const double q = c.mm_per_count[a], nominal = setup.signals[a].mm_per_count;
    // 0: the fit holds no encoder scale; the declared one stays.
    if (!(std::isfinite(q) && q >= 0 && (q == 0 || std::abs(q / nominal - 1) <= 0.1)))
      bad(fmt::format("axis {} encoder scale {} mm per count, more than 10 % from the machine file's {}", axis, q,
                      nominal));
    setup.calibrated_mm_per_count[a] = q;
    setup.servo[a].velocity_ff = 1.0 / k;
    setup.servo[a].backlash_compensation_mm = b;
  }
  return setup;
}

}  // namespace machplan::calibration
