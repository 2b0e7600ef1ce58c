// The demand filter contract (engine/executor/setpoint_source.h, DemandFilter), one suite run
// against every filter. A new filter is one more entry in kFilters: how to build it, where the
// machine starts and what the operator asks of it.
//
// The demands come from an operator's joystick source (engine/executor/jog_source.h) driving an
// ideal machine (the table is where the filtered setpoint was one period ago), as a guard session
// runs: the stick pushed for three seconds, then let go.
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/executor/guard.h"
#include "tests/support/datasets.h"
#include "engine/executor/jog_source.h"
#include "engine/executor/setpoint_source.h"
#include "models/cutting/machine_config.h"
#include "tests/support/allocation_counter.h"

namespace machplan::executor {
namespace {

constexpr double kPeriod = 0.001;

// The controller input's per-axis arrays as vectors.
Eigen::Vector2d vec(const std::array<double, control::kAxes>& a) { return {a[0], a[1]}; }




// A 100 x 100 mm square part at the origin, machined from outside or as a pocket, with a 5 mm
// tool.
const ProhibitedRegion& square(MachiningSide side) {
  auto build = [](MachiningSide s) {
    RegionOptions o;
    o.side = s;
    o.tool_radius_mm = 5.0;
    return ProhibitedRegion::build({Contour({{0, 0}, {100, 0}, {100, 100}, {0, 100}}, {0, 0, 0, 0})}, o);
  };
  static const ProhibitedRegion outside = build(MachiningSide::outside), inside = build(MachiningSide::inside);
  return side == MachiningSide::outside ? outside : inside;
}

struct Rig {
  std::unique_ptr<DemandFilter> filter;
  Eigen::Vector2d start{0, 0};
  Eigen::Vector2d stick{0, 0};  // the deflection the operator holds for the first 3 s
};

struct Entry {
  const char* name;
  std::function<Rig()> make;
};

Rig guard_rig(GuardStrategy s, MachiningSide side, const Eigen::Vector2d& start, const Eigen::Vector2d& stick) {
  GuardOptions o;
  o.strategy = s;
  o.tolerance_mm = 1.0;
  Rig r;
  r.filter = std::make_unique<Guard>(square(side), o, test::xy_table_setup(), kPeriod);
  r.start = start;
  r.stick = stick;
  return r;
}

const Entry kFilters[] = {
    {"guard_paper_outside",
     [] { return guard_rig(GuardStrategy::paper, MachiningSide::outside, {130, 50}, {-1, 0}); }},
    {"guard_predictive_outside",
     [] { return guard_rig(GuardStrategy::predictive, MachiningSide::outside, {130, 50}, {-1, 0.3}); }},
    {"guard_predictive_pocket",
     [] { return guard_rig(GuardStrategy::predictive, MachiningSide::inside, {60, 60}, {0.7, 0.7}); }},
};

// One run: per period the source's demand, filtered. `measured(k, table)` may replace what the
// machine reports in period k.
struct FilterSession {
  std::vector<Demand> in, out;
  long allocations = 0;
};

FilterSession run(Rig& rig, int ticks = 4000,
            const std::function<Eigen::Vector2d(int, const Eigen::Vector2d&)>& measured = nullptr) {
  JogOptions jo;
  jo.speed_mm_per_s = 12.0;  // the paper's operator
  JogSource source(jo);
  motion::Job none;
  source.prepare({&none, nullptr, &test::xy_table_setup(), kPeriod}, rig.start);
  rig.filter->reset(rig.start);
  FilterSession s;
  s.in.reserve(ticks);
  s.out.reserve(ticks);
  Eigen::Vector2d at = rig.start, next = rig.start;
  Demand d;
  g_allocations = 0;
  for (int k = 0; k < ticks; ++k) {
    hardware::OperatorInputs op;
    if (k < 3000) op.jog = {rig.stick.x(), rig.stick.y()};
    source.advance(at, op);
    source.demand(d);
    s.in.push_back(d);
    const Eigen::Vector2d seen = measured ? measured(k, at) : at;
    g_counting = true;
    rig.filter->filter(d, seen, Eigen::Vector2d::Zero());
    g_counting = false;
    s.out.push_back(d);
    at = next;  // the ideal machine: where the setpoint was one period ago
    next = d.commanded_mm;
  }
  s.allocations = g_allocations;
  return s;
}

bool finite(const Demand& d) {
  return d.commanded_mm.allFinite() && d.speed_mm_per_s.allFinite() && vec(d.track.r_mm).allFinite() &&
         vec(d.track.v_ff_mm_per_s).allFinite() && vec(d.track.a_ff_mm_per_s2).allFinite();
}

class DemandFilterContract : public ::testing::TestWithParam<Entry> {};

TEST_P(DemandFilterContract, AMachineAskedToStandStillStaysStill) {
  Rig rig = GetParam().make();
  rig.stick = {0, 0};
  const FilterSession s = run(rig, 1000);
  for (std::size_t k = 0; k < s.out.size(); ++k) {
    ASSERT_EQ(s.out[k].commanded_mm, rig.start) << k;
    ASSERT_EQ(vec(s.out[k].track.r_mm), rig.start) << k;
    ASSERT_TRUE(vec(s.out[k].track.v_ff_mm_per_s).isZero(0.0)) << k;
  }
}

TEST_P(DemandFilterContract, TheOperatorsMotionGetsThroughAwayFromWhatItGuards) {
  // The first tenth of a second, far from the region: the machine moves as the stick asks.
  Rig rig = GetParam().make();
  const FilterSession s = run(rig, 100);
  const Eigen::Vector2d moved_in = s.in.back().commanded_mm - rig.start, moved_out = s.out.back().commanded_mm - rig.start;
  ASSERT_GT(moved_in.norm(), 0.1);
  EXPECT_NEAR((moved_out - moved_in).norm(), 0.0, 1e-9);
}

TEST_P(DemandFilterContract, ResetRepeatsTheSameDemandsExactly) {
  Rig rig = GetParam().make();
  const FilterSession a = run(rig), b = run(rig);  // run() resets the filter
  ASSERT_EQ(a.out.size(), b.out.size());
  for (std::size_t k = 0; k < a.out.size(); ++k) {
    ASSERT_EQ(a.out[k].commanded_mm, b.out[k].commanded_mm) << k;
    ASSERT_EQ(vec(a.out[k].track.r_mm), vec(b.out[k].track.r_mm)) << k;
    ASSERT_EQ(vec(a.out[k].track.v_ff_mm_per_s), vec(b.out[k].track.v_ff_mm_per_s)) << k;
    ASSERT_EQ(vec(a.out[k].track.a_ff_mm_per_s2), vec(b.out[k].track.a_ff_mm_per_s2)) << k;
  }
}

TEST_P(DemandFilterContract, DemandsStayFiniteAndOfTheirKindWhateverTheMeasurement) {
  Rig rig = GetParam().make();
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const FilterSession s = run(rig, 4000, [&](int k, const Eigen::Vector2d& at) {
    if (k >= 1000 && k < 1100) return Eigen::Vector2d(nan, at.y());
    if (k >= 2000 && k < 2010) return Eigen::Vector2d(at.x(), -inf);
    return at;
  });
  for (std::size_t k = 0; k < s.out.size(); ++k) {
    ASSERT_TRUE(finite(s.out[k])) << k;
    ASSERT_EQ(s.out[k].kind, s.in[k].kind) << k;
  }
}

TEST_P(DemandFilterContract, FilteringAllocatesNothing) {
  Rig rig = GetParam().make();
  const FilterSession s = run(rig);
  EXPECT_EQ(s.allocations, 0);
}

INSTANTIATE_TEST_SUITE_P(Every, DemandFilterContract, ::testing::ValuesIn(kFilters),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace machplan::executor
