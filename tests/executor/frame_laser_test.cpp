// Framing with the laser pointer on the simulated gantry: the axes trace the outline less the
// pointer's offset (the machine file's laser block), the laser output on while the frame's
// moves run and off at the end, the torch never on.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "solvers/motion/run.h"
#include "solvers/session/machine_session.h"
#include "tests/support/datasets.h"

namespace machplan::motion {
namespace {

TEST(FrameLaser, TheDotTracesTheOutlineAndTheLaserIsOnOnlyWhileTheFrameMoves) {
  const cutting::MachineConfig m = test::gantry();
  ASSERT_TRUE(m.laser_offset_mm.has_value()) << "the bundled gantry has a laser pointer";
  const Eigen::Vector2d offset((*m.laser_offset_mm)[0], (*m.laser_offset_mm)[1]);
  RunOptions o;
  o.session.machine_config = m;
  const PlannedRun job = plan_program(test::part("triangle_45.ngc"), o, m);
  ASSERT_TRUE(job.summary.done()) << job.summary.full_report();
  FrameOptions fo;
  fo.feed_mm_per_s = 40.0;
  fo.pointer_offset_mm = offset;
  fo.laser = true;
  const FramePlan frame = plan_frame(job.job, o, fo, m);
  ASSERT_TRUE(frame.plan.summary.done()) << frame.plan.summary.full_report();

  session::MachineSession s(session_options_for(o));
  auto run = s.start(frame.plan.job, frame.plan.trajectories, {});
  bool on_at_rest = false, fired = false;
  double on_s = 0.0, worst_dot = 0.0;
  executor::LiveState last;
  const Eigen::AlignedBox2d& b = frame.outline;
  while (run->tick()) {
    last = s.live().read();
    fired = fired || last.torch_fire;
    if (!last.laser_on) continue;
    on_s += 0.001;
    on_at_rest = on_at_rest || last.step < 0;
    // On the outline's sides the dot (the commanded point plus the offset) lies on the rectangle.
    const Eigen::Vector2d dot = last.commanded_mm + offset;
    if (last.step == 1) {
      const double d = std::min({std::abs(dot.x() - b.min().x()), std::abs(dot.x() - b.max().x()),
                                 std::abs(dot.y() - b.min().y()), std::abs(dot.y() - b.max().y())});
      worst_dot = std::max(worst_dot, d);
    }
  }
  const executor::ExecutionResult r = run->finish();
  ASSERT_TRUE(r.summary.done()) << r.report();
  EXPECT_FALSE(fired);
  EXPECT_FALSE(on_at_rest);
  EXPECT_FALSE(last.laser_on) << "off at the end: step " << last.step << " run " << static_cast<int>(last.run);
  EXPECT_LT(worst_dot, 0.05);
  // On for the frame's moves: at least the outline's perimeter at 40 mm/s.
  EXPECT_GT(on_s, 2.0 * (b.sizes().x() + b.sizes().y()) / 40.0);
  EXPECT_LT(on_s, r.cycle_time_s);
}

}  // namespace
}  // namespace machplan::motion
