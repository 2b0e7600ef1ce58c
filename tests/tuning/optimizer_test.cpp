// The two-stage optimiser (solvers/tuning/optimizer.h) on functions with known minima, with and
// without constraints, and its budget and stop handling; and the ACC gain tuning.
#include <cmath>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "solvers/tuning/acc_tuning.h"
#include "solvers/tuning/optimizer.h"

namespace machplan::tuning {
namespace {

// These calls have no stop, deadline or budget of the caller's.
Termination never;

TEST(Optimizer, FindsTheMinimumOfAMultimodalFunction) {
  // Two basins; the global one at (2, -1) is not where the start is.
  Problem p;
  p.parameters = {{"a", -5, 5, -3, false}, {"b", -5, 5, 3, false}};
  p.evaluate = [](const std::vector<double>& x, std::vector<double>&) {
    const double d1 = std::pow(x[0] - 2, 2) + std::pow(x[1] + 1, 2), d2 = std::pow(x[0] + 3, 2) + std::pow(x[1] - 3, 2);
    return std::min(d1, 0.5 + d2);
  };
  OptimizerOptions o;
  o.max_evaluations = 400;
  const OptimizerResult r = optimize(p, o, never);
  ASSERT_TRUE(r.feasible);
  EXPECT_NEAR(r.x[0], 2.0, 1e-2);
  EXPECT_NEAR(r.x[1], -1.0, 1e-2);
  EXPECT_LE(r.evaluations, 400);
  EXPECT_EQ(r.global.algorithm, "DIRECT-L");
  EXPECT_EQ(r.local.algorithm, "COBYLA");
  EXPECT_FALSE(r.global.stop_reason.empty());
}

TEST(Optimizer, RespectsAConstraintAndLogScale) {
  // Minimise x on [0.01, 100] (log scale) subject to x >= 3: the answer is on the constraint.
  Problem p;
  p.parameters = {{"k", 0.01, 100, 50, true}};
  p.constraint_count = 1;
  p.evaluate = [](const std::vector<double>& x, std::vector<double>& g) {
    g[0] = 3.0 - x[0];
    return x[0];
  };
  OptimizerOptions o;
  o.max_evaluations = 200;
  const OptimizerResult r = optimize(p, o, never);
  ASSERT_TRUE(r.feasible);
  EXPECT_GE(r.x[0], 3.0 - 1e-6);
  EXPECT_NEAR(r.x[0], 3.0, 0.05);
}

TEST(Optimizer, ReportsInfeasibleProblemsAndKeepsTheBudget) {
  Problem p;
  p.parameters = {{"k", 0, 1, 0.5, false}};
  p.constraint_count = 1;
  int calls = 0;
  p.evaluate = [&](const std::vector<double>& x, std::vector<double>& g) {
    ++calls;
    g[0] = 1.0 + x[0];  // never <= 0
    return x[0];
  };
  OptimizerOptions o;
  o.max_evaluations = 60;  // the local stage runs twice (from the global best and from the start)
  const OptimizerResult r = optimize(p, o, never);
  EXPECT_FALSE(r.feasible);
  EXPECT_NEAR(r.x[0], 0.0, 1e-3) << "the least violating point";
  EXPECT_EQ(r.evaluations, calls);
  EXPECT_LE(calls, 60);
}

TEST(Optimizer, NeverEvaluatesBeyondTheBudget) {
  // DIRECT samples a whole division of the box before it checks its own limit: the budget
  // still holds, stage by stage and in total.
  Problem p;
  p.parameters = {{"a", 0, 1, 0.3, false}, {"b", 0, 1, 0.6, false}, {"c", 1, 100, 10, true}};
  p.constraint_count = 1;
  int calls = 0;
  p.evaluate = [&](const std::vector<double>& x, std::vector<double>& g) {
    ++calls;
    g[0] = x[0] - 0.9;
    return (x[0] - 0.5) * (x[0] - 0.5) + (x[1] - 0.2) * (x[1] - 0.2) + std::log(x[2]);
  };
  for (int budget : {1, 2, 3, 5, 8, 13, 40}) {
    calls = 0;
    OptimizerOptions o;
    o.max_evaluations = budget;
    const OptimizerResult r = optimize(p, o, never);
    EXPECT_LE(calls, budget) << budget;
    EXPECT_EQ(r.evaluations, calls) << budget;
    EXPECT_TRUE(r.feasible) << budget;  // the start is feasible
  }
}

TEST(Optimizer, StopsOnRequest) {
  Problem p;
  p.parameters = {{"k", 0, 1, 0.5, false}};
  StopSource stop;
  p.evaluate = [&](const std::vector<double>& x, std::vector<double>&) {
    stop.request_stop();
    return (x[0] - 0.3) * (x[0] - 0.3);
  };
  OptimizerOptions o;
  o.max_evaluations = 1000;
  Termination t(stop.token());
  const OptimizerResult r = optimize(p, o, t);
  EXPECT_TRUE(r.stopped());
  EXPECT_EQ(r.ended_by, Termination::Reason::stop_requested);
  EXPECT_LT(r.evaluations, 10);
}

TEST(Optimizer, RejectsMalformedProblemsAndOptions) {
  Problem p;
  p.evaluate = [](const std::vector<double>&, std::vector<double>&) { return 0.0; };
  EXPECT_THROW(optimize(p, {}, never), InternalError);
  p.parameters = {{"k", 1, 1, 1, false}};
  EXPECT_THROW(optimize(p, {}, never), InternalError);
  p.parameters = {{"k", 0, 1, 0.5, true}};
  EXPECT_THROW(optimize(p, {}, never), InternalError);
  p.parameters = {{"k", 0, 1, 0.5, false}};
  OptimizerOptions o;
  o.max_evaluations = 0;
  EXPECT_THROW(optimize(p, o, never), InputError);
}

TEST(AccTuning, VariableGainSettlesFasterThanTheTunedFixedGainWithoutOvershoot) {
  AccTuningOptions o;
  o.optimizer.max_evaluations = 60;
  const AccTuningResult fixed = tune_acc(o, never);
  o.acc.variable_gain = true;
  const AccTuningResult variable = tune_acc(o, never);
  ASSERT_TRUE(fixed.summary.done()) << fixed.summary.full_report();
  ASSERT_TRUE(variable.summary.done()) << variable.summary.full_report();
  for (const AccTuningResult* r : {&fixed, &variable}) {
    EXPECT_LE(r->after.worst_overshoot, o.max_overshoot + 1e-3);
    // Never worse than a feasible start.
    if (r->before.worst_overshoot <= o.max_overshoot) { EXPECT_LE(r->after.worst_settling_s, r->before.worst_settling_s + 1e-9); }
  }
  // Koren's Kc = 0.5 overshoots on the deepest step here; the tuned fixed gain is lower.
  EXPECT_LT(fixed.gain, 0.5);
  // A constant open-loop gain lets every depth settle as fast as the deepest allows.
  EXPECT_LT(variable.after.worst_settling_s, 0.5 * fixed.after.worst_settling_s);
}

}  // namespace
}  // namespace machplan::tuning
