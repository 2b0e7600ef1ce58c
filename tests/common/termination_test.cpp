// Termination, Progress and Summary: the one way long work stops, says how far it came and says
// how it ended.
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/progress.h"
#include "engine/common/summary.h"
#include "engine/common/termination.h"

namespace machplan {
namespace {

TEST(Termination, WithoutLimitsNeverEnds) {
  Termination t;
  for (int i = 0; i < 1000; ++i) t.charge(1, 1.0);
  EXPECT_FALSE(t.should_end());
  EXPECT_EQ(t.reason(), Termination::Reason::none);
  EXPECT_EQ(t.describe(), "");
  EXPECT_EQ(t.units_spent(), 1000);
  EXPECT_DOUBLE_EQ(t.work_s_spent(), 1000.0);
}

TEST(Termination, RecordsWhichLimitEndedTheWork) {
  Termination budget;
  budget.set_budget(3, "samples");
  budget.charge(2);
  EXPECT_FALSE(budget.should_end());
  budget.charge(1);
  EXPECT_TRUE(budget.should_end());
  EXPECT_EQ(budget.reason(), Termination::Reason::budget);
  EXPECT_EQ(budget.describe(), "the budget of 3 samples was spent");

  Termination deadline;
  deadline.set_deadline(0.5, "machine time");
  deadline.charge(1, 0.25);
  EXPECT_FALSE(deadline.should_end());
  deadline.charge(1, 0.25);
  EXPECT_TRUE(deadline.should_end());
  EXPECT_EQ(deadline.reason(), Termination::Reason::deadline);
  EXPECT_EQ(deadline.describe(), "the deadline of 0.5 s of machine time was reached");

  StopSource source;
  Termination stop(source.token());
  EXPECT_FALSE(stop.should_end());
  source.request_stop();
  EXPECT_TRUE(stop.should_end());
  EXPECT_EQ(stop.reason(), Termination::Reason::stop_requested);
  EXPECT_EQ(stop.describe(), "stopped on request");
}

TEST(Termination, TheFirstReasonIsKept) {
  StopSource source;
  Termination t(source.token());
  t.set_budget(1, "evaluations");
  t.charge(1);
  EXPECT_TRUE(t.should_end());
  source.request_stop();
  EXPECT_TRUE(t.should_end());
  EXPECT_EQ(t.reason(), Termination::Reason::budget);
}

TEST(Termination, AChildEndsWithItsParentAndChargesIt) {
  StopSource source;
  Termination parent(source.token());
  parent.set_budget(10, "periods");
  Termination child(parent);
  child.set_budget(4, "samples");
  child.charge(3);
  EXPECT_EQ(parent.units_spent(), 3);
  EXPECT_FALSE(child.should_end());
  child.charge(1);
  EXPECT_TRUE(child.should_end());
  EXPECT_EQ(child.reason(), Termination::Reason::budget);
  EXPECT_FALSE(parent.should_end()) << "the parent does not learn the child's own limits";

  Termination second(parent);
  EXPECT_EQ(second.stop_token().bound(), true) << "a child obeys its parent's stop request";
  source.request_stop();
  EXPECT_TRUE(second.should_end());
  EXPECT_EQ(second.reason(), Termination::Reason::stop_requested);
  EXPECT_EQ(second.describe(), parent.describe());
}

TEST(Termination, RequestStopEndsTheWork) {
  Termination t;
  t.request_stop();
  EXPECT_TRUE(t.should_end());
  EXPECT_EQ(t.reason(), Termination::Reason::stop_requested);
}

TEST(Termination, SeveralThreadsMayCharge) {
  Termination t;
  t.set_budget(40000, "units");
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([&] {
      for (int i = 0; i < 10000; ++i) t.charge(1, 1e-3);
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(t.units_spent(), 40000);
  EXPECT_NEAR(t.work_s_spent(), 40.0, 1e-9);
  EXPECT_TRUE(t.should_end());
}

TEST(Progress, ASliceReportsIntoItsParent) {
  Progress overall;
  {
    Progress first(&overall, 0.0, 0.5), second(&overall, 0.5, 1.0);
    first.report(0.5);
    EXPECT_DOUBLE_EQ(overall.share(), 0.25);
    first.finish();
    second.report(0.5);
    EXPECT_DOUBLE_EQ(overall.share(), 0.75);
    EXPECT_DOUBLE_EQ(second.share(), 0.5);
  }
  overall.report(2.0);
  EXPECT_DOUBLE_EQ(overall.share(), 1.0) << "clamped";
  overall.report(std::numeric_limits<double>::quiet_NaN());
  EXPECT_DOUBLE_EQ(overall.share(), 1.0) << "NaN ignored";
  report_progress(nullptr, 0.5);  // nobody watching: nothing happens
}

TEST(Summary, StatusesAreKeptApart) {
  EXPECT_EQ(status_of(Termination::Reason::none), Status::done);
  EXPECT_EQ(status_of(Termination::Reason::stop_requested), Status::cancelled);
  EXPECT_EQ(status_of(Termination::Reason::deadline), Status::deadline);
  EXPECT_EQ(status_of(Termination::Reason::budget), Status::budget);
  Summary s;
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.exit_code(), 0);
  for (Status st : {Status::infeasible, Status::faulted, Status::cancelled, Status::deadline, Status::budget}) {
    s.status = st;
    EXPECT_FALSE(s.done());
    EXPECT_EQ(s.exit_code(), 3) << to_string(st);
  }
  EXPECT_STREQ(to_string(Status::faulted), "faulted");
}

TEST(Summary, ADeadlineOrBudgetWithAUsableAnswerIsNoFailure) {
  Summary s;
  s.usable = true;
  for (Status st : {Status::deadline, Status::budget}) {
    s.status = st;
    EXPECT_FALSE(s.done()) << "the status still says what ended the work";
    EXPECT_TRUE(s.usable_answer()) << to_string(st);
    EXPECT_EQ(s.exit_code(), 0) << to_string(st);
  }
  // A stop request, a fault or no answer stay failures whatever the flag says.
  for (Status st : {Status::infeasible, Status::faulted, Status::cancelled}) {
    s.status = st;
    EXPECT_FALSE(s.usable_answer()) << to_string(st);
    EXPECT_EQ(s.exit_code(), 3) << to_string(st);
  }
}

}  // namespace
}  // namespace machplan
