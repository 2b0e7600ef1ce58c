// Ramp pierces for thick plate on the simulated gantry: the torch moves along its cut while the
// arc pierces, at the material's gouge and creep speeds, and the job's time bound counts it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "models/cutting/machine_config.h"
#include "solvers/motion/run.h"
#include "tests/support/datasets.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using executor::TraceSample;

// Material 5 pierces 20 mm plate standing; material 6 is the same with a ramp: moving from 40 %
// of the 1.5 s delay, 4 mm at 5 mm/s, 5 mm at 10 mm/s, then the cut's 20 mm/s.
constexpr const char* kMaterials = R"([MATERIAL_NUMBER_5]
NAME = Mild steel 20 mm, standing pierce
PIERCE_HEIGHT = 6
PIERCE_DELAY = 1.5
CUT_HEIGHT = 2
CUT_SPEED = 1200
[MATERIAL_NUMBER_6]
NAME = Mild steel 20 mm, ramp pierce
PIERCE_HEIGHT = 6
PIERCE_DELAY = 1.5
CUT_HEIGHT = 2
CUT_SPEED = 1200
PIERCE_TYPE = 2
PIERCE_MOTION_DELAY = 40
PIERCE_END_HEIGHT = 3
CUT_HEIGHT_DELAY = 0.1
GOUGE_SPEED = 300
GOUGE_SPEED_DISTANCE = 4
CREEP_SPEED = 600
CREEP_SPEED_DISTANCE = 5
)";

// A 100 mm straight cut pierced at (100, 100), then 50 mm up.
constexpr const char* kCut = R"(G21 G90 G17 G40 G94
G0 X100 Y100
M3 S1
G1 X200 Y100 F1200
G1 X200 Y150
M5
G0 X0 Y0
M2
)";

class RampPierce : public ::testing::Test {
 protected:
  RunOutcome run(int material) const {
    const std::string mats = (dir_.path() / "m.cfg").string(), prog = (dir_.path() / "cut.ngc").string();
    std::ofstream(mats) << kMaterials;
    std::ofstream(prog) << kCut;
    RunOptions o;
    o.session.machine_config = test::gantry();
    o.session.executor.record_trace = true;
    o.materials_path = mats;
    o.default_material = material;
    return run_program(prog, o);
  }
  test::TempDir dir_;
};

// Along the cut from the pierce point, from the trace's commanded points.
struct Along {
  double arc_on_s = NAN, moves_s = NAN;
  double top_gouge = 0.0, top_creep = 0.0, top_after = 0.0;  // commanded speeds, mm/s
};
Along along(const std::vector<TraceSample>& trace) {
  Along a;
  const Eigen::Vector2d pierce(100.0, 100.0);
  std::size_t back = 0;  // the sample 20 ms or more before: speeds over that window
  for (std::size_t i = 0; i < trace.size(); ++i) {
    const TraceSample& s = trace[i];
    if (std::isnan(a.arc_on_s) && s.arc_ok) a.arc_on_s = s.t_s;
    while (back < i && trace[back + 1].t_s <= s.t_s - 0.02) ++back;
    if (std::isnan(a.arc_on_s) || !s.torch_fire || back == i) continue;
    const double d = (s.commanded_mm - pierce).norm();
    if (std::isnan(a.moves_s) && d > 1e-3) a.moves_s = s.t_s;
    const double v = (s.commanded_mm - trace[back].commanded_mm).norm() / (s.t_s - trace[back].t_s);
    double& top = d < 4.0 ? a.top_gouge : d < 9.0 ? a.top_creep : a.top_after;
    top = std::max(top, v);
  }
  return a;
}

TEST_F(RampPierce, MovesAlongTheCutFromItsMotionDelayAtTheGougeAndCreepSpeeds) {
  const RunOutcome ramp = run(6);
  ASSERT_TRUE(ramp.summary.done()) << ramp.summary.full_report();
  EXPECT_EQ(ramp.result.ramp_pierces, 1);
  const Along a = along(ramp.result.trace);
  std::printf("ramp pierce: moves %.3f s after the arc; top speeds %.2f (gouge), %.2f (creep), %.2f mm/s after\n",
              a.moves_s - a.arc_on_s, a.top_gouge, a.top_creep, a.top_after);
  EXPECT_NEAR(a.moves_s - a.arc_on_s, 0.4 * 1.5, 0.04);  // and the start from rest
  EXPECT_LE(a.top_gouge, 5.0 * 1.01);
  EXPECT_LE(a.top_creep, 10.0 * 1.01);
  EXPECT_GT(a.top_creep, 9.0);  // it did creep at its speed
  EXPECT_NEAR(a.top_after, 20.0, 0.2);
  // The cut follows its path while it ramps.
  ASSERT_FALSE(ramp.result.cuts.empty());
  EXPECT_LT(ramp.result.cuts.front().max_true_mm, 0.1);
  // The bound counts the ramp: the cycle is at or above it, and near the expected time.
  EXPECT_GE(ramp.result.cycle_time_s, ramp.lower_bound_s);
  EXPECT_NEAR(ramp.result.cycle_time_s, ramp.expected_s(), 0.02 * ramp.expected_s());
  // Standing, the same material waits the whole delay and never moves under the arc before it.
  const RunOutcome standing = run(5);
  ASSERT_TRUE(standing.summary.done()) << standing.summary.full_report();
  EXPECT_EQ(standing.result.ramp_pierces, 0);
  const Along b = along(standing.result.trace);
  EXPECT_GT(b.moves_s - b.arc_on_s, 1.5);
  EXPECT_GT(b.top_gouge, 5.0 * 1.5);  // no speed cap at the start
}

}  // namespace
}  // namespace machplan::motion
