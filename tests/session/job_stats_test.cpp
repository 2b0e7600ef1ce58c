// Job statistics in the store (solvers/session/job_stats.h): a job's row read back as written,
// the per-machine sums, a consumable change that restarts the counters since the change and
// keeps the lifetime totals, and a file that is not a store.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "solvers/common/internal/sqlite_db.h"
#include "solvers/session/job_stats.h"
#include "tests/support/temp_dir.h"

namespace machplan::stats {
namespace {

std::string stats_db(const test::TempDir& dir) { return (dir.path() / "stats.db").string(); }

JobRecord stats_job(const std::string& machine, std::int64_t pierces, double arc_on_s) {
  JobRecord j;
  j.machine = machine;
  j.program = "/parts/bracket.ngc";
  j.program_hash = "0123456789abcdef";
  j.started_utc = "2026-11-28T08:00:00Z";
  j.status = "done";
  j.figures = {.jobs = 1, .pierces = pierces, .probes = pierces, .probes_skipped = 1, .faults = 0,
               .arc_on_s = arc_on_s, .cycle_s = 2 * arc_on_s, .cut_mm = 10 * arc_on_s, .rapid_mm = 100.0, .probe_s = 0.5};
  return j;
}

TEST(JobStats, AJobReadsBackAsRecorded) {
  const test::TempDir dir;
  StatsStore store(stats_db(dir));
  JobRecord j = stats_job("gantry", 7, 12.5);
  j.status = "faulted";
  j.fault = "torch_breakaway";
  j.figures.faults = 1;
  const std::int64_t id = store.record(j);
  const std::vector<JobRecord> rows = store.jobs("gantry");
  ASSERT_EQ(rows.size(), 1u);
  const JobRecord& r = rows[0];
  EXPECT_EQ(r.id, id);
  EXPECT_EQ(r.machine, "gantry");
  EXPECT_EQ(r.program, j.program);
  EXPECT_EQ(r.program_hash, j.program_hash);
  EXPECT_EQ(r.started_utc, j.started_utc);
  EXPECT_EQ(r.status, "faulted");
  EXPECT_EQ(r.fault, "torch_breakaway");
  EXPECT_EQ(r.figures.jobs, 1);
  EXPECT_EQ(r.figures.pierces, 7);
  EXPECT_EQ(r.figures.probes, 7);
  EXPECT_EQ(r.figures.probes_skipped, 1);
  EXPECT_EQ(r.figures.faults, 1);
  EXPECT_DOUBLE_EQ(r.figures.arc_on_s, 12.5);
  EXPECT_DOUBLE_EQ(r.figures.cycle_s, 25.0);
  EXPECT_DOUBLE_EQ(r.figures.rapid_mm, 100.0);
  EXPECT_DOUBLE_EQ(r.figures.cut_mm, 125.0);
  EXPECT_DOUBLE_EQ(r.figures.probe_s, 0.5);
}

TEST(JobStats, TotalsSumOneMachinesJobs) {
  const test::TempDir dir;
  StatsStore store(stats_db(dir));
  store.record(stats_job("gantry", 3, 10.0));
  store.record(stats_job("other", 100, 1000.0));
  store.record(stats_job("gantry", 4, 5.0));
  const MachineTotals t = store.totals("gantry");
  EXPECT_EQ(t.lifetime.jobs, 2);
  EXPECT_EQ(t.lifetime.pierces, 7);
  EXPECT_DOUBLE_EQ(t.lifetime.arc_on_s, 15.0);
  EXPECT_DOUBLE_EQ(t.lifetime.rapid_mm, 200.0);
  EXPECT_DOUBLE_EQ(t.lifetime.cut_mm, 150.0);
  EXPECT_EQ(t.lifetime.probes_skipped, 2);
  // Never changed: since the change is the lifetime.
  EXPECT_FALSE(t.last_change_utc);
  EXPECT_EQ(t.since_change.pierces, 7);
  // Newest first, the other machine's job left out.
  const auto rows = store.jobs("gantry");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].figures.pierces, 4);
  EXPECT_EQ(store.jobs("", 1).size(), 1u);
  EXPECT_EQ(store.totals("nobody").lifetime.jobs, 0);
}

TEST(JobStats, AConsumableChangeRestartsItsCountersAndKeepsTheLifetime) {
  const test::TempDir dir;
  const std::string path = stats_db(dir);
  {
    StatsStore store(path);
    store.record(stats_job("gantry", 3, 10.0));
    store.record(stats_job("gantry", 4, 5.0));
    store.consumables_changed("gantry", "ana");
    store.record(stats_job("other", 9, 9.0));  // another machine's change is not this one's
  }
  StatsStore store(path);  // reopened: the change is stored, not remembered
  MachineTotals t = store.totals("gantry");
  ASSERT_TRUE(t.last_change_utc);
  EXPECT_EQ(t.last_change_who, "ana");
  EXPECT_EQ(t.since_change.jobs, 0);
  EXPECT_EQ(t.since_change.pierces, 0);
  EXPECT_DOUBLE_EQ(t.since_change.arc_on_s, 0.0);
  EXPECT_EQ(t.lifetime.pierces, 7);
  store.record(stats_job("gantry", 5, 2.0));
  t = store.totals("gantry");
  EXPECT_EQ(t.since_change.jobs, 1);
  EXPECT_EQ(t.since_change.pierces, 5);
  EXPECT_DOUBLE_EQ(t.since_change.arc_on_s, 2.0);
  EXPECT_EQ(t.lifetime.jobs, 3);
  EXPECT_EQ(t.lifetime.pierces, 12);
  EXPECT_EQ(store.totals("other").since_change.pierces, 9);
}

TEST(JobStats, AFileThatIsNotAStoreIsRefusedNamingTheDb) {
  const test::TempDir dir;
  const std::string path = dir.write("notes.db", std::string(4096, 'x'));
  try {
    StatsStore store(path);
    FAIL() << "opened a file that is not a store";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("db_path"), std::string::npos) << e.what();
  }
}

// A store written before the jobs kept their cut length (layout 1): it opens, its job counts with
// a cut length of 0 (not known), and new jobs add theirs.
TEST(JobStats, AStoreFromBeforeTheCutLengthGainsIt) {
  const test::TempDir dir;
  {
    const store::SqliteDb old(stats_db(dir), R"sql(
CREATE TABLE jobs (id INTEGER PRIMARY KEY, machine TEXT NOT NULL, program TEXT NOT NULL,
  program_hash TEXT NOT NULL, started_utc TEXT NOT NULL, status TEXT NOT NULL, fault TEXT NOT NULL,
  pierces INTEGER NOT NULL, arc_on_s REAL NOT NULL, cycle_s REAL NOT NULL, rapid_mm REAL NOT NULL,
  probes INTEGER NOT NULL, probes_skipped INTEGER NOT NULL, probe_s REAL NOT NULL, faults INTEGER NOT NULL);
INSERT INTO jobs VALUES (1, 'gantry', '/parts/a.ngc', 'ff', '2026-11-27T08:00:00Z', 'done', '', 3, 4.0, 9.0, 50.0,
  3, 0, 0.3, 0);
PRAGMA user_version = 1;
)sql");
  }
  StatsStore store(stats_db(dir));
  store.record(stats_job("gantry", 2, 5.0));
  const MachineTotals t = store.totals("gantry");
  EXPECT_EQ(t.lifetime.jobs, 2);
  EXPECT_EQ(t.lifetime.pierces, 5);
  EXPECT_DOUBLE_EQ(t.lifetime.cut_mm, 50.0);  // the new job's 10 x 5.0; the old one's unknown
  const std::vector<JobRecord> rows = store.jobs("gantry");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_DOUBLE_EQ(rows[1].figures.cut_mm, 0.0);
  EXPECT_DOUBLE_EQ(rows[1].figures.rapid_mm, 50.0);
}

}  // namespace
}  // namespace machplan::stats
