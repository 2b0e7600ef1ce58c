// Hybrid manual / servo-assisted machining on the simulated XY table (solvers/guard/
// guard_run.h), closed loop: the reproduction of the trend of Franco Garcia and Horikawa's
// Tables 2 and 3 with the paper's strategy and latency, the predictive strategy's zero
// invasions at T = 0.5 mm under the same latency, the automatic finishing pass within
// 0.05 mm of the offset profile, and the scripted operator.
//
// Reproduction tests (Reproduction*) run a few hundred strokes each: tens of seconds under
// ASan.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/programs/dxf.h"
#include "solvers/guard/guard_run.h"

namespace machplan::guard {
namespace {

// These runs have no stop, deadline or budget of the caller's.
Termination never;

std::string data(const std::string& rel) { return std::string(MACHPLAN_SOURCE_DIR) + "/" + rel; }
std::string profile(const std::string& name) { return data("datasets/profiles/" + name + ".dxf"); }

GuardRunOptions paper_run(MachiningSide side, double feed, double T, int strokes, std::uint64_t seed = 1) {
  GuardRunOptions o;
  o.region.side = side;
  o.region.tool_radius_mm = 5.0;
  o.region.method = OffsetMethod::paper;
  o.guard.strategy = executor::GuardStrategy::paper;
  o.guard.tolerance_mm = T;
  o.feed_mm_per_s = feed;
  o.op.kind = OperatorSpec::Kind::random;
  o.op.strokes = strokes;
  o.seed = seed;
  return o;
}

struct Row {
  double T, success, undercut;
};

// The paper's strategy at one feed over T = 1 .. 5 mm on the triangle from outside.
std::vector<Row> paper_table(double feed) {
  std::vector<Row> rows;
  for (double T : {1.0, 2.0, 3.0, 4.0, 5.0}) {
    const GuardRunResult r = run_guard_file(profile("paper_triangle"), paper_run(MachiningSide::outside, feed, T, 40), never);
    EXPECT_EQ(r.attempts.size(), 40u) << "every stroke reaches the part";
    rows.push_back({T, r.success_percent(), r.mean_undercut_mm});
    std::printf("  %5.1f mm/s  T %3.1f  success %6.2f %%  under-cut %5.2f mm  max invasion %5.2f mm\n", feed, T,
                r.success_percent(), r.mean_undercut_mm, r.max_invasion_mm);
  }
  return rows;
}

// Table 2 (a): success rises with T from (almost) none at 1 mm to about all at 4-5 mm, and the
// under-cut of the successes grows with T.
void expect_paper_trend(const std::vector<Row>& t) {
  EXPECT_LE(t[0].success, 25.0) << "T = 1 mm: the paper has 0 and 6.7 %";
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_GE(t[i].success, t[i - 1].success - 7.5) << "T = " << t[i].T;
  EXPECT_GE(t[3].success, 65.0) << "T = 4 mm: the paper has 88.9 and 89.5 %";
  EXPECT_GE(t[4].success, 90.0) << "T = 5 mm: the paper has 100 and 95 %";
  EXPECT_LE(t[1].success, 60.0) << "T = 2 mm: the paper has 17.65 and 21.05 %";
  EXPECT_LT(t[4].success - t[0].success, 101.0);
  EXPECT_GT(t[4].success - t[0].success, 60.0);
  for (std::size_t i = 2; i < t.size(); ++i) EXPECT_GT(t[i].undercut, t[i - 1].undercut) << "T = " << t[i].T;
  EXPECT_GT(t[4].undercut, 1.0) << "T = 5 mm: the paper has 2.50 and 2.63 mm";
  EXPECT_LT(t[4].undercut, 4.0);
}

TEST(ReproductionGuard, PaperStrategyTable2TriangleAt12) { expect_paper_trend(paper_table(12.0)); }
TEST(ReproductionGuard, PaperStrategyTable2TriangleAt18) { expect_paper_trend(paper_table(18.0)); }

TEST(ReproductionGuard, PaperStrategyTable2QuadrilateralPocket) {
  // Table 2 (b): 95.65 .. 100 % at T = 4 .. 5 mm, under-cut 1.1 .. 2.5 mm. Ours falls short at
  // 18 mm/s and T = 4 mm (about 77 %): one fixed latency costs 1.5 times the distance at
  // 18 mm/s, which the paper's figures do not show (bench/results/guard_paper.md).
  for (double feed : {12.0, 18.0}) {
    for (double T : {4.0, 5.0}) {
      const GuardRunResult r = run_guard_file(profile("paper_quadrilateral"), paper_run(MachiningSide::inside, feed, T, 30), never);
      SCOPED_TRACE(feed);
      SCOPED_TRACE(T);
      std::printf("  quadrilateral %5.1f mm/s  T %3.1f  success %6.2f %%  under-cut %5.2f mm\n", feed, T, r.success_percent(),
                  r.mean_undercut_mm);
      EXPECT_GE(r.success_percent(), T == 5.0 ? 85.0 : 65.0);
      EXPECT_GT(r.mean_undercut_mm, 0.3);
      EXPECT_LT(r.mean_undercut_mm, 4.0);
    }
  }
  // And at T = 1 mm the same latency invades most of the time.
  const GuardRunResult r = run_guard_file(profile("paper_quadrilateral"), paper_run(MachiningSide::inside, 12.0, 1.0, 30), never);
  EXPECT_LE(r.success_percent(), 30.0);
  EXPECT_GT(r.max_invasion_mm, 0.3);
}

// Beyond the paper: the predictive strategy under the same latency, T = 0.5 mm, 200 random
// strokes per profile and side: no invasion, mean under-cut <= 0.1 mm.
void expect_predictive_clean(double feed) {
  struct Case {
    const char* name;
    MachiningSide side;
  };
  for (const Case c : {Case{"paper_triangle", MachiningSide::outside}, Case{"paper_quadrilateral", MachiningSide::inside},
                       Case{"paper_heptagon", MachiningSide::outside}, Case{"paper_heptagon", MachiningSide::inside}}) {
    GuardRunOptions o = paper_run(c.side, feed, 0.5, 200, 7);
    o.guard.strategy = executor::GuardStrategy::predictive;
    o.region.method = OffsetMethod::robust;
    const GuardRunResult r = run_guard_file(profile(c.name), o, never);
    SCOPED_TRACE(c.name);
    SCOPED_TRACE(to_string(c.side));
    std::printf("  predictive %5.1f mm/s %-20s %-7s attempts %zu invasions %d (max %.4f mm) under-cut mean %.4f max %.4f mm\n",
                feed, c.name, to_string(c.side), r.attempts.size(), r.invasions, r.max_invasion_mm, r.mean_undercut_mm,
                r.max_undercut_mm);
    EXPECT_GE(r.attempts.size(), 200u);
    EXPECT_EQ(r.invasions, 0);
    EXPECT_EQ(r.max_invasion_mm, 0.0);
    EXPECT_LE(r.mean_undercut_mm, 0.1);
    EXPECT_EQ(r.guard_failsafe_ticks, 0);
  }
}

TEST(ReproductionGuard, PredictiveNoInvasionAt12) { expect_predictive_clean(12.0); }
TEST(ReproductionGuard, PredictiveNoInvasionAt18) { expect_predictive_clean(18.0); }
TEST(ReproductionGuard, PredictiveNoInvasionAt100) { expect_predictive_clean(100.0); }

TEST(GuardRun, FinishingContoursTheOffsetProfileWithin50Micrometres) {
  for (const char* name : {"paper_triangle", "arc_profile"}) {
    for (double allowance : {0.0, 0.3}) {
      GuardRunOptions o = paper_run(MachiningSide::outside, 12.0, 0.5, 3, 3);
      o.guard.strategy = executor::GuardStrategy::predictive;
      o.region.method = OffsetMethod::robust;
      o.finish = true;
      o.finish_allowance_mm = allowance;
      const GuardRunResult r = run_guard_file(profile(name), o, never);
      SCOPED_TRACE(name);
      SCOPED_TRACE(allowance);
      ASSERT_EQ(r.finish.size(), allowance > 0 ? 2u : 1u);
      for (const FinishPass& f : r.finish) {
        EXPECT_TRUE(f.completed) << f.fault;
        EXPECT_GT(f.samples, 1000u);
        EXPECT_LE(f.max_deviation_mm, 0.05);
      }
      EXPECT_LE(r.finish.back().max_from_profile_mm, 0.05);
      EXPECT_GT(r.finishing_time_s, 0.0);
    }
  }
}

TEST(GuardRun, FinishingAPocketFromInside) {
  GuardRunOptions o = paper_run(MachiningSide::inside, 18.0, 0.5, 2, 5);
  o.guard.strategy = executor::GuardStrategy::predictive;
  o.region.method = OffsetMethod::robust;
  o.finish = true;
  const GuardRunResult r = run_guard_file(profile("paper_quadrilateral"), o, never);
  ASSERT_EQ(r.finish.size(), 1u);
  EXPECT_TRUE(r.finish[0].completed) << r.finish[0].fault;
  EXPECT_LE(r.finish[0].max_from_profile_mm, 0.05);
}

TEST(GuardRun, ScriptedOperatorRoughsTheTriangle) {
  GuardRunOptions o;
  o.region.side = MachiningSide::outside;
  o.region.tool_radius_mm = 5.0;
  o.guard.tolerance_mm = 0.5;
  o.op = operator_from_string(data("datasets/operators/triangle_roughing.csv"));
  const GuardRunResult r = run_guard_file(profile("paper_triangle"), o, never);
  EXPECT_GE(r.attempts.size(), 4u);
  EXPECT_EQ(r.invasions, 0);
  EXPECT_LE(r.max_undercut_mm, 0.2);
  // The same script under the paper's strategy at T = 1 mm invades: the guard is what keeps
  // the predictive run clean, not the script.
  o.guard.strategy = executor::GuardStrategy::paper;
  o.guard.tolerance_mm = 1.0;
  o.region.method = OffsetMethod::paper;
  const GuardRunResult p = run_guard_file(profile("paper_triangle"), o, never);
  EXPECT_GT(p.invasions, 0);
}

TEST(GuardRun, SameSeedSameRun) {
  const GuardRunOptions o = paper_run(MachiningSide::outside, 18.0, 3.0, 5, 11);
  const GuardRunResult a = run_guard_file(profile("paper_heptagon"), o, never);
  const GuardRunResult b = run_guard_file(profile("paper_heptagon"), o, never);
  ASSERT_EQ(a.attempts.size(), b.attempts.size());
  for (std::size_t i = 0; i < a.attempts.size(); ++i) EXPECT_EQ(a.attempts[i].closest_mm, b.attempts[i].closest_mm);
}

TEST(GuardRun, BadOptionsNameTheField) {
  const auto where = [](auto&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return e.where();
    }
    return std::string("no error");
  };
  EXPECT_EQ(where([] { operator_from_string("random:0"); }), "op");
  EXPECT_EQ(where([] { operator_from_string("random:x"); }), "op");
  EXPECT_EQ(where([] { operator_from_string(""); }), "op");
  EXPECT_EQ(operator_from_string("joystick:/dev/input/js3").path, "/dev/input/js3");
  EXPECT_EQ(operator_from_string("random:12").strokes, 12);
  GuardRunOptions o;
  o.feed_mm_per_s = 0;
  EXPECT_EQ(where([&] { o.validate(); }), "feed_mm_per_s");
  o = {};
  o.guard.tolerance_mm = -1;
  EXPECT_EQ(where([&] { o.validate(); }), "guard.tolerance_mm");
  o = {};
  o.guard.latency_s = 2;
  EXPECT_EQ(where([&] { o.validate(); }), "guard.latency_s");
  o = {};
  o.region.tool_radius_mm = std::nan("");
  EXPECT_EQ(where([&] { o.validate(); }), "region.tool_radius_mm");
  // A script without a start row, naming the script.
  o = {};
  o.region.tool_radius_mm = 5;
  o.op.kind = OperatorSpec::Kind::script;
  o.op.path = data("tests/fuzz/corpus/operator_script_fuzz/bad_order.csv");
  EXPECT_NE(where([&] { run_guard_file(profile("paper_triangle"), o, never); }).find("bad_order.csv"), std::string::npos);
}

}  // namespace
}  // namespace machplan::guard
