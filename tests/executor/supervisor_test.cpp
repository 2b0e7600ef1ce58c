// The supervisor alone: the first fault wins, the controlled stop ramps at the machine's
// acceleration keeping the direction and ends in a disable only at rest, and the checks that
// need no plant (arc loss debounce, stalled axis, saturated drive off the contour).
#include <gtest/gtest.h>

#include "engine/executor/supervisor.h"

namespace machplan::executor {
namespace {

MachineSetup machine() {
  MachineSetup m;
  m.name = "test";
  m.max_acceleration_mm_per_s2 = 500;
  m.contour_error_limit_mm = 0.3;
  m.torch.kind = TorchSetup::Kind::plasma;
  m.torch.arc_loss_debounce_s = 0.02;
  for (int i = 0; i < hardware::kAxes; ++i) m.servo[i].following_error_limit_mm = 2.0;
  return m;
}

Supervisor make(const SupervisorOptions& o = {}) {
  Supervisor s;
  s.configure(machine(), o, 0.001, {0.025, 0.025});
  s.reset({100, 100});
  return s;
}

TEST(Supervisor, FirstFaultWins) {
  Supervisor s = make();
  Supervisor::Where w;
  w.t_s = 1.0;
  s.raise(FaultKind::estop, -1, 0, w);
  w.t_s = 2.0;
  s.raise(FaultKind::following_error, 0, 3.0, w);
  EXPECT_TRUE(s.faulted());
  EXPECT_EQ(s.kind(), FaultKind::estop);
  EXPECT_EQ(s.where().t_s, 1.0);
}

TEST(Supervisor, StopTurnsTheTorchOffRampsAlongTheDirectionAndDisablesAtRest) {
  Supervisor s = make();
  TorchSequencer torch;
  TorchSetup ts;
  ts.kind = TorchSetup::Kind::plasma;
  ts.retract_height_mm = 15;
  torch.configure(ts, 0.001);
  hardware::Outputs out;
  out.torch_fire = true;
  const Eigen::Vector2d u0(60, 80);  // 100 mm/s
  s.begin_stop(u0, torch, out);
  EXPECT_FALSE(out.torch_fire);
  EXPECT_DOUBLE_EQ(out.torch_height_target_mm, 15);
  EXPECT_EQ(s.state(), Supervisor::State::ramp);
  // 100 mm/s at 500 mm/s^2: 0.2 s of ramp, speed falling 0.5 mm/s per period, same direction.
  Eigen::Vector2d pos(100, 100), u = u0;
  int ramp_ticks = 0;
  while (s.state() == Supervisor::State::ramp) {
    const Eigen::Vector2d next = s.stop_tick(pos, true);
    if (next.norm() > 0) {
      EXPECT_NEAR(u.norm() - next.norm(), 0.5, 1e-9);
      EXPECT_NEAR(next.normalized().dot(u0.normalized()), 1.0, 1e-12);
    }
    u = next;
    pos += u * 0.001;
    ++ramp_ticks;
  }
  EXPECT_NEAR(ramp_ticks, 200, 1);
  // Settle: a moving axis keeps it there; standing still for rest_window_s lets it disable.
  for (int k = 0; k < 100; ++k) {
    pos.x() += 0.05;  // still drifting, two counts per period
    s.stop_tick(pos, true);
  }
  EXPECT_EQ(s.state(), Supervisor::State::settle);
  int settle_ticks = 0;
  while (s.state() == Supervisor::State::settle && settle_ticks < 10000) {
    s.stop_tick(pos, true);
    ++settle_ticks;
  }
  EXPECT_EQ(s.state(), Supervisor::State::disable);
  EXPECT_NEAR(settle_ticks, 50, 2);  // rest_window_s
  EXPECT_TRUE(s.stopped_at_rest());
}

TEST(Supervisor, UntrustedFeedbackWaitsTheSettleTime) {
  SupervisorOptions o;
  o.stop_settle_s = 0.3;
  Supervisor s = make(o);
  TorchSequencer torch;
  hardware::Outputs out;
  s.begin_stop(Eigen::Vector2d::Zero(), torch, out);
  int n = 0;
  while (s.state() != Supervisor::State::disable && n < 10000) {
    s.stop_tick({100 + n * 0.1, 100}, false);  // readings are nonsense: not used
    ++n;
  }
  EXPECT_NEAR(n, 301, 2);
}

TEST(Supervisor, ArcLossIsDebounced) {
  Supervisor s = make();
  int n = 0;
  while (!s.arc_lost(true, false) && n < 1000) ++n;
  EXPECT_NEAR(n, 20, 1);  // about 20 periods of 1 ms, then the low time exceeds 0.02 s
  Supervisor s2 = make();
  for (int k = 0; k < 1000; ++k) EXPECT_FALSE(s2.arc_lost(true, k % 10 != 0));  // short drops only
}

TEST(Supervisor, StalledAxisUnderOpenLoopCommand) {
  Supervisor s = make();
  Eigen::Vector2d y(100, 100);
  const Eigen::Vector2d u(4, 4);  // the paper's 4 mm/s
  int n = 0, stalled = -1;
  while (stalled < 0 && n < 5000) {
    y.x() += 0.7 * 4 * 0.001;  // X moves at 70 %; Y is jammed
    stalled = s.stalled_axis(u, y, false);
    ++n;
  }
  EXPECT_EQ(stalled, 1);
  EXPECT_NEAR(n, 250, 2);  // 1 mm of commanded travel at 4 mm/s
}

TEST(Supervisor, NoStallWhenTheAxisFollowsSlowlyOrReverses) {
  Supervisor s = make();
  Eigen::Vector2d y(100, 100);
  for (int k = 0; k < 20000; ++k) {
    const double v = (k / 1500) % 2 ? -3.0 : 3.0;  // reversals every 1.5 s
    // Backlash: 60 ms of no motion after each reversal, then 40 % of the command.
    const bool in_gap = k % 1500 < 60;
    y.x() += in_gap ? 0.0 : 0.4 * v * 0.001;
    y.y() += 0.3 * 0.6 * 0.001;
    ASSERT_EQ(s.stalled_axis({v, 0.6}, y, false), -1) << k;
  }
}

TEST(Supervisor, TrackingStallNeedsTwiceTheFollowingErrorLimit) {
  Supervisor s = make();
  const Eigen::Vector2d y(100, 100);
  int n = 0;
  while (s.stalled_axis({80, 0}, y, true) < 0 && n < 1000) ++n;
  EXPECT_NEAR(n, 51, 2);  // 4 mm at 80 mm/s after the first period
}

TEST(Supervisor, SaturationOffTheContourIsAFaultOnlyWhenBothHold) {
  Supervisor a = make();
  bool fault = false;
  for (int k = 0; k < 2000 && !fault; ++k) fault = a.saturated_off_contour(true, true, 0.1);  // within the limit
  EXPECT_FALSE(fault);
  Supervisor b = make();
  for (int k = 0; k < 2000 && !fault; ++k) fault = b.saturated_off_contour(true, k % 4 == 0, 1.0);  // 25 % saturated
  EXPECT_FALSE(fault);
  Supervisor c = make();
  int n = 0;
  while (!c.saturated_off_contour(true, true, 1.0) && n < 5000) ++n;
  EXPECT_GT(n, 100);  // the share has to build up over the window (0.25 s)
  EXPECT_LT(n, 300);
  Supervisor d = make();
  for (int k = 0; k < 2000 && !fault; ++k) fault = d.saturated_off_contour(false, true, 1.0);  // not cutting
  EXPECT_FALSE(fault);
}

}  // namespace
}  // namespace machplan::executor
