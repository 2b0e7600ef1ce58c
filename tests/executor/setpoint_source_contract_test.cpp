// The setpoint source contract (engine/executor/setpoint_source.h), one suite run against every
// source. A new source is one more entry in kSources: how to build it, the job it runs (or, for
// a source that runs no job, what the operator does) and where the motion should end.
//
// Each source runs on an ideal machine (a track demand's setpoint is where the machine is the
// next period; a speed demand moves it by speed x period), with the executor's call order:
// begin_move() of the job's move step, then per period advance() and demand(), until the move
// is done and the demand at rest.
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/executor/blu_vector_source.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/planned_source.h"
#include "engine/executor/setpoint_source.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_trajectory.h"

namespace machplan::executor {
namespace {

constexpr double kPeriod = 0.001;

// The controller input's per-axis arrays as vectors.
Eigen::Vector2d vec(const std::array<double, control::kAxes>& a) { return {a[0], a[1]}; }

constexpr int kMaxTicks = 60000;  // a minute of machine time: far beyond any motion below

MachineSetup contract_machine() {
  MachineSetup m;
  m.name = "contract";
  for (int i = 0; i < hardware::kAxes; ++i) {
    m.signals[i].reading_latency_ticks = 1;
    m.signals[i].command_latency_ticks = 1;
    m.max_speed_mm_per_s[i] = 100;
  }
  m.max_acceleration_mm_per_s2 = 500;
  m.max_jerk_mm_per_s3 = 20000;
  return m;
}

struct Rig {
  MachineSetup machine = contract_machine();
  test::OneCut cut;  // the job; step 1 is its move (a source that runs no job is given it too)
  std::unique_ptr<SetpointSource> source;
  Eigen::Vector2d start{0, 0};  // where the machine stands
  Eigen::Vector2d end{0, 0};    // where the motion must end on the ideal machine
  double end_tolerance_mm = 0.0;
  std::function<hardware::OperatorInputs(int tick)> op = [](int) { return hardware::OperatorInputs{}; };
};

struct Entry {
  const char* name;
  std::function<Rig()> make;
};

// A line cut from a to b at `feed` mm/s, with a planned trajectory.
test::OneCut line_cut(double feed, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return test::one_cut(test::make_stretch(test::polyline_segments({a, b}, false), feed, true),
                       std::make_unique<test::LineTrajectory>(a, b, feed, 500));
}

// The 10 mm line from (20, 30) to (26, 38).
Rig line_rig(double feed) {
  Rig r;
  r.start = {20, 30};
  r.end = {26, 38};
  r.cut = line_cut(feed, r.start, r.end);
  return r;
}

Rig blu_rig(bool closed) {
  Rig r = line_rig(4.0);
  BluVectorOptions o;
  o.closed_loop = closed;
  o.blu_mm = 3.0;
  r.source = std::make_unique<BluVectorSource>(o);
  // Time control: each vector ends within one period's travel (4 mm/s x 1 ms) of its point.
  // The closed loop re-aims from a reading `compute_s` old while the last command runs on,
  // so on any machine it may end up to the feed times that time past the end (the paper's
  // +-1 mm).
  r.end_tolerance_mm = 4.0 * (kPeriod + (closed ? o.compute_s : 0.0));
  return r;
}

const Entry kSources[] = {
    {"planned",
     [] {
       Rig r = line_rig(80.0);
       r.source = std::make_unique<PlannedSource>();
       r.end_tolerance_mm = 1e-9;
       return r;
     }},
    {"paper_open", [] { return blu_rig(false); }},
    {"paper_closed", [] { return blu_rig(true); }},
    {"jog",
     [] {
       // The stick pushed fully along (3, 4)/5 for 0.5 s, then let go: a jerk-limited ramp up
       // and the same ramp down, so the tool travels the stick's speed times 0.5 s.
       Rig r = line_rig(80.0);
       JogOptions o;
       o.speed_mm_per_s = 20.0;
       r.source = std::make_unique<JogSource>(o);
       r.op = [](int tick) {
         hardware::OperatorInputs in;
         if (tick < 500) in.jog = {0.6, 0.8};
         return in;
       };
       r.end = r.start + 0.5 * Eigen::Vector2d(12.0, 16.0);
       r.end_tolerance_mm = 20.0 * kPeriod;
       return r;
     }},
};

bool at_rest(const Demand& d) {
  return d.kind == Demand::Kind::speed ? d.speed_mm_per_s.isZero(0.0)
                                       : vec(d.track.v_ff_mm_per_s).isZero(0.0) && vec(d.track.a_ff_mm_per_s2).isZero(0.0);
}

bool finite(const Demand& d) {
  return d.commanded_mm.allFinite() && d.speed_mm_per_s.allFinite() && vec(d.track.r_mm).allFinite() &&
         vec(d.track.v_ff_mm_per_s).allFinite() && vec(d.track.a_ff_mm_per_s2).allFinite();
}

// What a run of the motion on the ideal machine gave.
struct Motion {
  std::vector<Demand> demands;  // one per period: the motion, then `hold` more
  int motion_ticks = -1;        // periods until the motion ended; -1: it never did
  Eigen::Vector2d measured{0, 0};
  long allocations = 0;         // in the real-time members
};

// Runs the job's move (or the operator's motion) until the move is done, the demand at rest and
// the stick let go; then `hold` periods more.
Motion run(Rig& rig, int hold = 200) {
  SetpointSource& s = *rig.source;
  s.prepare({&rig.cut.job, &rig.cut.trajectories, &rig.machine, kPeriod}, rig.start);
  Motion m;
  m.demands.reserve(kMaxTicks + hold);
  m.measured = rig.start;
  g_allocations = 0;
  if (s.runs_job()) {
    g_counting = true;
    s.begin_move(1, m.measured);
    g_counting = false;
  }
  Demand d;
  int after = -1;
  for (int k = 0; k < kMaxTicks && after < hold; ++k) {
    const hardware::OperatorInputs op = rig.op(k);
    g_counting = true;
    s.advance(m.measured, op);
    s.demand(d);
    const bool done = s.move_done();
    g_counting = false;
    m.demands.push_back(d);
    m.measured = d.kind == Demand::Kind::speed ? Eigen::Vector2d(m.measured + kPeriod * d.speed_mm_per_s)
                                                : vec(d.track.r_mm);
    if (after >= 0) {
      ++after;
    } else if (done && at_rest(d) && op.jog[0] == 0.0 && op.jog[1] == 0.0) {
      m.motion_ticks = k + 1;
      after = 0;
    }
  }
  m.allocations = g_allocations;
  return m;
}

class SetpointSourceContract : public ::testing::TestWithParam<Entry> {};

TEST_P(SetpointSourceContract, HoldsTheStartUntilAMotionBegins) {
  Rig rig = GetParam().make();
  SetpointSource& s = *rig.source;
  s.prepare({&rig.cut.job, &rig.cut.trajectories, &rig.machine, kPeriod}, rig.start);
  Demand d;
  s.demand(d);
  EXPECT_EQ(d.commanded_mm, rig.start);
  EXPECT_TRUE(at_rest(d));
  for (int k = 0; k < 100; ++k) {
    s.advance(rig.start, {});
    s.demand(d);
    ASSERT_EQ(d.commanded_mm, rig.start) << k;
    ASSERT_TRUE(at_rest(d)) << k;
    if (d.kind == Demand::Kind::track) { ASSERT_EQ(vec(d.track.r_mm), rig.start) << k; }
  }
}

TEST_P(SetpointSourceContract, OnAnIdealMachineTheMotionEndsWhereItShould) {
  Rig rig = GetParam().make();
  const Motion m = run(rig);
  ASSERT_GT(m.motion_ticks, 0) << "the motion never ended";
  EXPECT_LE((m.measured - rig.end).norm(), rig.end_tolerance_mm)
      << "ended at (" << m.measured.x() << ", " << m.measured.y() << ")";
  EXPECT_LE((m.demands.back().commanded_mm - rig.end).norm(), rig.end_tolerance_mm);
}

TEST_P(SetpointSourceContract, HoldsWhereTheMotionEnded) {
  Rig rig = GetParam().make();
  const Motion m = run(rig, 300);
  ASSERT_GT(m.motion_ticks, 0);
  const Demand& last = m.demands[m.motion_ticks - 1];
  for (std::size_t k = m.motion_ticks; k < m.demands.size(); ++k) {
    ASSERT_EQ(m.demands[k].commanded_mm, last.commanded_mm) << k;
    ASSERT_TRUE(at_rest(m.demands[k])) << k;
  }
}

TEST_P(SetpointSourceContract, DemandsAreFiniteAndOfOneKindPerMove) {
  Rig rig = GetParam().make();
  const Motion m = run(rig);
  ASSERT_FALSE(m.demands.empty());
  for (std::size_t k = 0; k < m.demands.size(); ++k) {
    ASSERT_TRUE(finite(m.demands[k])) << k;
    ASSERT_EQ(m.demands[k].kind, m.demands.front().kind) << k;
  }
}

TEST_P(SetpointSourceContract, TheSameInputsGiveTheSameDemands) {
  Rig a = GetParam().make(), b = GetParam().make();
  const Motion ma = run(a), mb = run(b);
  ASSERT_EQ(ma.demands.size(), mb.demands.size());
  for (std::size_t k = 0; k < ma.demands.size(); ++k) {
    const Demand &x = ma.demands[k], &y = mb.demands[k];
    ASSERT_EQ(x.commanded_mm, y.commanded_mm) << k;
    ASSERT_EQ(x.speed_mm_per_s, y.speed_mm_per_s) << k;
    ASSERT_EQ(vec(x.track.r_mm), vec(y.track.r_mm)) << k;
    ASSERT_EQ(vec(x.track.v_ff_mm_per_s), vec(y.track.v_ff_mm_per_s)) << k;
    ASSERT_EQ(vec(x.track.a_ff_mm_per_s2), vec(y.track.a_ff_mm_per_s2)) << k;
  }
}

TEST_P(SetpointSourceContract, TheRealTimeMembersAllocateNothing) {
  Rig rig = GetParam().make();
  const Motion m = run(rig);
  ASSERT_GT(m.motion_ticks, 0);
  EXPECT_EQ(m.allocations, 0);
}

INSTANTIATE_TEST_SUITE_P(Every, SetpointSourceContract, ::testing::ValuesIn(kSources),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace machplan::executor
