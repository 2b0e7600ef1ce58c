// The hybrid guard (engine/executor/guard.h) on an ideal plant (the table is where the setpoint
// was one period ago): the paper's stop arrives late by its link latency, the predictive
// strategy stops or slides in time under the same latency, a late link stops the axes, and a
// tick allocates nothing. The closed loop on the simulated table is in tests/guard/.
#include <cmath>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/datasets.h"
#include "engine/executor/executor.h"
#include "engine/executor/guard.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "tests/support/allocation_counter.h"

namespace machplan::executor {
namespace {



// A 100 x 100 mm square part at the origin; with R = 5 the limit is 5 mm outside it (outside
// machining) or inside it (a pocket).
ProhibitedRegion square_region(MachiningSide side) {
  const Contour c({{0, 0}, {100, 0}, {100, 100}, {0, 100}}, {0, 0, 0, 0});
  RegionOptions o;
  o.side = side;
  o.tool_radius_mm = 5.0;
  return ProhibitedRegion::build({c}, o);
}

// Drives the guard with an operator pushing `v_in` (mm/s) and an ideal plant; returns the
// least signed distance seen and leaves the final position in `at`.
struct Drive {
  const ProhibitedRegion& region;
  Guard& guard;
  Eigen::Vector2d at, prev;
  double closest = 1e9;
  void run(const Eigen::Vector2d& v_in, double seconds) {
    const int n = static_cast<int>(std::lround(seconds / 0.001));
    for (int k = 0; k < n; ++k) step(v_in);
  }
  void step(const Eigen::Vector2d& v_in, const Eigen::Vector2d* measured = nullptr) {
    Demand d;
    d.kind = Demand::Kind::track;
    for (int i = 0; i < 2; ++i) d.track.v_ff_mm_per_s[i] = v_in[i];
    guard.filter(d, measured ? *measured : at, Eigen::Vector2d::Zero());
    at = prev;
    prev = d.commanded_mm;
    closest = std::min(closest, region.query(at).signed_distance_mm);
  }
};

GuardOptions options(GuardStrategy s, double T, double L = kPaperLatencyS) {
  GuardOptions o;
  o.strategy = s;
  o.tolerance_mm = T;
  o.latency_s = L;
  return o;
}

TEST(Guard, PaperStopArrivesLateByOneToTwoRoundTrips) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  const double v = 12.0, L = kPaperLatencyS, brake = v * v / (2 * test::xy_table_setup().max_acceleration_mm_per_s2);
  for (double T : {1.0, 2.0, 3.0}) {
    Guard g(region, options(GuardStrategy::paper, T), test::xy_table_setup(), 0.001);
    g.reset({130, 50});
    Drive dr{region, g, {130, 50}, {130, 50}};
    dr.run({-v, 0}, 3.0);
    const double d = region.query(dr.at).signed_distance_mm;
    SCOPED_TRACE(T);
    // Detected on an answer up to one round trip old, acted on one round trip later.
    EXPECT_LE(d, T - v * L + 0.02);
    EXPECT_GE(d, T - 2 * v * L - brake - 0.02);
    EXPECT_TRUE(g.holding());
    EXPECT_EQ(g.setpoint_velocity_mm_per_s().norm(), 0.0);
    if (T == 1.0) { EXPECT_LT(dr.closest, 0.0) << "at T = 1 mm the paper's stop must come too late"; }
  }
}

TEST(Guard, PaperReleasesWhenTheOperatorTurnsAway) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  Guard g(region, options(GuardStrategy::paper, 4.0), test::xy_table_setup(), 0.001);
  g.reset({130, 50});
  Drive dr{region, g, {130, 50}, {130, 50}};
  dr.run({-12, 0}, 3.0);
  const double x_stop = dr.at.x();
  ASSERT_TRUE(g.holding());
  dr.run({12, 0}, 1.0);
  EXPECT_FALSE(g.holding());
  EXPECT_GT(dr.at.x(), x_stop + 5.0);
}

TEST(Guard, PredictiveStopsBeforeTheBoundaryAtAnySpeedUnderTheSameLatency) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  for (double v : {12.0, 18.0, 100.0, 400.0}) {
    Guard g(region, options(GuardStrategy::predictive, 0.5), test::xy_table_setup(), 0.001);
    g.reset({160, 50});
    Drive dr{region, g, {160, 50}, {160, 50}};
    dr.run({-v, 0}, 60.0 / v + 1.0);
    SCOPED_TRACE(v);
    EXPECT_GE(dr.closest, 0.0);
    EXPECT_LE(region.query(dr.at).signed_distance_mm, 0.1);
    EXPECT_TRUE(g.holding());
  }
}

TEST(Guard, PredictiveSlidesAlongTheBoundary) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  Guard g(region, options(GuardStrategy::predictive, 0.5), test::xy_table_setup(), 0.001);
  g.reset({110, 20});
  Drive dr{region, g, {110, 20}, {110, 20}};
  const double a = 30.0 * M_PI / 180.0;  // 30 degrees off the wall, toward it
  const Eigen::Vector2d v_in = 20.0 * Eigen::Vector2d(-std::cos(a), std::sin(a));
  dr.run(v_in, 1.0);
  const double y0 = dr.at.y();
  dr.run(v_in, 1.0);
  EXPECT_GE(dr.closest, 0.0);
  EXPECT_LT(region.query(dr.at).signed_distance_mm, 0.1);
  // The tangential part passes: 20 sin 30 = 10 mm/s along the wall.
  EXPECT_NEAR(dr.at.y() - y0, 10.0, 0.3);
  EXPECT_FALSE(g.holding());
}

TEST(Guard, PredictiveNeverEntersAPocketCorner) {
  const ProhibitedRegion region = square_region(MachiningSide::inside);  // allowed: [5, 95]^2
  for (double deg : {10.0, 45.0, 80.0}) {
    for (double v : {18.0, 100.0}) {
      Guard g(region, options(GuardStrategy::predictive, 0.5), test::xy_table_setup(), 0.001);
      g.reset({60, 60});
      Drive dr{region, g, {60, 60}, {60, 60}};
      const double a = deg * M_PI / 180.0;
      dr.run(v * Eigen::Vector2d(std::cos(a), std::sin(a)), 40.0 / (v * std::min(std::sin(a), std::cos(a))) + 1.0);
      SCOPED_TRACE(deg);
      SCOPED_TRACE(v);
      EXPECT_GE(dr.closest, 0.0);
      EXPECT_NEAR(dr.at.x(), 95.0, 0.15);  // slid into the corner and held there
      EXPECT_NEAR(dr.at.y(), 95.0, 0.15);
    }
  }
}

TEST(Guard, ALostLinkStopsTheAxesFarFromTheRegion) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  for (GuardStrategy s : {GuardStrategy::paper, GuardStrategy::predictive}) {
    Guard g(region, options(s, 2.0), test::xy_table_setup(), 0.001);
    g.reset({300, 50});
    Drive dr{region, g, {300, 50}, {300, 50}};
    dr.run({50, 0}, 0.5);
    ASSERT_NEAR(g.setpoint_velocity_mm_per_s().x(), 50.0, 1e-9);
    g.drop_answers(true);
    // The budget: one answer period (L) and a tick, then the ramp down at A.
    dr.run({50, 0}, kPaperLatencyS + 0.002 + 50.0 / test::xy_table_setup().max_acceleration_mm_per_s2 + 0.002);
    EXPECT_EQ(g.setpoint_velocity_mm_per_s().norm(), 0.0) << to_string(s);
    EXPECT_TRUE(g.holding());
    EXPECT_GT(g.counters().failsafe_ticks, 0);
    g.drop_answers(false);
    dr.run({50, 0}, 0.5);
    EXPECT_GT(g.setpoint_velocity_mm_per_s().x(), 40.0) << to_string(s);
  }
}

TEST(Guard, PredictiveHoldsWhenTheTableDoesNotFollow) {
  // A jammed table: the answers stay where it stuck while the setpoint runs on.
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  Guard g(region, options(GuardStrategy::predictive, 1.0), test::xy_table_setup(), 0.001);
  g.reset({300, 50});
  Drive dr{region, g, {300, 50}, {300, 50}};
  const Eigen::Vector2d stuck(300, 50);
  for (int k = 0; k < 400; ++k) dr.step({20, 0}, &stuck);
  EXPECT_TRUE(g.holding());
  EXPECT_EQ(g.setpoint_velocity_mm_per_s().norm(), 0.0);
  EXPECT_GT(g.counters().failsafe_ticks, 0);
}

TEST(Guard, ANonFinitePositionHoldsTheAxes) {
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  Guard g(region, options(GuardStrategy::predictive, 1.0), test::xy_table_setup(), 0.001);
  g.reset({300, 50});
  Drive dr{region, g, {300, 50}, {300, 50}};
  dr.run({50, 0}, 0.2);
  const Eigen::Vector2d nan(std::nan(""), 0.0);
  for (int k = 0; k < 100; ++k) dr.step({50, 0}, &nan);
  EXPECT_EQ(g.setpoint_velocity_mm_per_s().norm(), 0.0);
  EXPECT_TRUE(g.holding());
}

TEST(Guard, ATickAllocatesNothing) {
  const ProhibitedRegion region = square_region(MachiningSide::inside);
  for (GuardStrategy s : {GuardStrategy::paper, GuardStrategy::predictive}) {
    Guard g(region, options(s, 1.0), test::xy_table_setup(), 0.001);
    g.reset({50, 50});
    Drive dr{region, g, {50, 50}, {50, 50}};
    g_allocations = 0;
    g_counting = true;
    dr.run({80, 30}, 2.0);
    g_counting = false;
    EXPECT_EQ(g_allocations, 0) << to_string(s);
  }
}

TEST(Guard, AJogSessionUnderTheGuardAllocatesNothingPerTickAndStaysOut) {
  // The closed loop: jog source -> guard -> controller -> simulated table, ticked by hand.
  const ProhibitedRegion region = square_region(MachiningSide::outside);
  const auto m = cutting::load_machine(cutting::find_machine("xy_table"));
  for (GuardStrategy s : {GuardStrategy::paper, GuardStrategy::predictive}) {
    sim::SimOptions so;
    so.start_mm = {130, 50};
    sim::SimBackend be(m, so);
    ExecutorOptions eo;
    eo.mode = Mode::jog;
    eo.jog.speed_mm_per_s = 18;
    eo.record_trace = false;
    Executor ex(m.setup(), eo);
    Guard g(region, options(s, s == GuardStrategy::paper ? 5.0 : 0.5), m.setup(), be.period_s());
    motion::Job job;
    job.source = "jog";
    job.start_mm = so.start_mm;
    static const Trajectories kNone;
    RunParts parts;
    parts.filter = &g;
    Session session(ex, job, kNone, be, parts);
    hardware::OperatorInputs push;
    push.jog = {-1.0, 0.0};
    be.set_operator(push);
    double closest = 1e9;
    g_allocations = 0;
    for (int k = 0; k < 3000; ++k) {
      g_counting = true;
      const bool more = session.tick();
      g_counting = false;
      ASSERT_TRUE(more);
      Eigen::Vector2d p;
      ASSERT_TRUE(be.true_position(p));
      closest = std::min(closest, region.query(p).signed_distance_mm);
    }
    EXPECT_EQ(g_allocations, 0) << to_string(s);
    EXPECT_GE(closest, 0.0) << to_string(s);
    EXPECT_TRUE(g.holding()) << to_string(s);
    hardware::OperatorInputs done;
    done.cycle_start = true;
    be.set_operator(done);
    for (int k = 0; k < 5000 && session.tick(); ++k) {
    }
    EXPECT_EQ(session.finish().summary.status, Status::done) << to_string(s);
  }
}

TEST(Guard, OptionsAreValidatedByName) {
  EXPECT_THROW(parse_guard_strategy("fast"), InputError);
  try {
    parse_guard_strategy("fast");
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "strategy");
  }
  EXPECT_EQ(parse_guard_strategy("paper").value, GuardStrategy::paper);
  GuardOptions o;
  o.latency_s = -1;
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("latency_s"), std::string::npos);
  }
  o = {};
  o.braking_fraction = 0;
  EXPECT_THROW(o.validate(), InputError);
}

}  // namespace
}  // namespace machplan::executor
