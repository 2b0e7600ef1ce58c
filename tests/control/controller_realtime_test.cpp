// The real-time half of the controller contract: update() of every kind the factory builds
// allocates nothing, with the path and the preview given and without them, the position
// observer on and off.
#include <cmath>
#include <cstdlib>
#include <new>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/control/controller_factory.h"
#include "tests/support/allocation_counter.h"

namespace machplan::control {
namespace {

TEST(ControllerRealtime, UpdateAllocatesNothing) {
  ControllerPlant plant;
  for (int i = 0; i < kAxes; ++i) {
    plant.output_limit_mm_per_s[i] = 1200;
    plant.drive_time_constant_s[i] = 0.004;
    plant.command_latency_ticks[i] = plant.reading_latency_ticks[i] = 1;
  }
  const Segment arc = make_segment({20, 0}, {-20, 0}, 1.0);
  for (int i = 0; i < kAxes; ++i) {
    plant.position_quantum_mm[i] = 0.002;
    plant.coulomb_friction_mm_per_s[i] = 2.0;
    plant.backlash_mm[i] = 0.002;
  }
  // Every kind at its defaults, and the axial loops' optional parts on where the kind has them.
  std::vector<std::pair<std::string, Gains>> cases;
  for (const std::string& kind : controller_kinds()) cases.push_back({kind, {}});
  for (const char* kind : {"p", "pid", "ccc"})
    cases.push_back({kind, {{"friction_ff_mm_per_s", 2.0}, {"backlash_ff_mm", 0.002}, {"observer_per_s", 150.0}}});
  for (const auto& [kind, gains] : cases) {
    auto c = make_controller(kind, gains, plant);
    ControllerOutput out;
    for (bool with_path : {true, false}) {
      c->reset();
      g_allocations = 0;
      for (int k = 0; k < 2000; ++k) {
        const double t = k * 0.001, w = 0.8;
        ControllerInput in;
        in.r_mm = {20 * std::cos(w * t), 20 * std::sin(w * t)};
        in.v_ff_mm_per_s = {-16 * std::sin(w * t), 16 * std::cos(w * t)};
        in.a_ff_mm_per_s2 = {-12.8 * std::cos(w * t), -12.8 * std::sin(w * t)};
        in.y_mm = {in.r_mm[0] * 1.0001, in.r_mm[1] * 0.9999};
        if (with_path) {
          in.path = &arc;
          in.preview_ticks = ControllerInput::kMaxPreviewTicks;
          for (int j = 0; j < in.preview_ticks; ++j)
            in.r_preview_mm[j] = {20 * std::cos(w * (t + (j + 1) * 0.001)), 20 * std::sin(w * (t + (j + 1) * 0.001))};
        }
        g_counting = true;
        c->update(in, out);
        g_counting = false;
        ASSERT_TRUE(std::isfinite(out.u_mm_per_s[0]) && std::isfinite(out.u_mm_per_s[1])) << kind;
      }
      EXPECT_EQ(g_allocations, 0) << kind << (with_path ? " with path" : " without path");
    }
  }
}

}  // namespace
}  // namespace machplan::control
