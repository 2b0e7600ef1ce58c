// The calibration store (SQLite): apply, history, the active calibration, refusal of a fit
// that is not ok, a process killed mid-write; and what the stored calibration is for: one
// session calibrates the paper's open-loop mode at every feed.
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <vector>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "models/cutting/machine_config.h"
#include "models/sim/sim_backend.h"
#include "solvers/calibration/apply.h"
#include "solvers/calibration/fit.h"
#include "solvers/calibration/record.h"
#include "solvers/calibration/store.h"
#include "solvers/motion/run.h"
#include "tests/support/temp_dir.h"

namespace machplan::calibration {
namespace {

cutting::MachineConfig nominal_gantry() {
  return cutting::load_machine(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
}

// Each test's store lives in a fresh temporary folder (removed at exit).
std::string temp_db(const char* name) {
  static std::vector<std::unique_ptr<test::TempDir>> dirs;
  dirs.push_back(std::make_unique<test::TempDir>());
  return (dirs.back()->path() / fmt::format("{}.db", name)).string();
}

struct Session {
  SessionLog log;
  std::string bytes;
  CalibrationFit fit;
};

Session session(const cutting::MachineConfig& truth, std::uint64_t seed) {
  sim::SimOptions so;
  so.seed = seed;
  sim::SimBackend backend(truth, so);
  RecordOptions o;
  o.seed = seed;
  Session s;
  Termination never;
  s.log = record_session(backend, nominal_gantry(), o, never).log;
  std::ostringstream out;
  write_session_log(out, s.log);
  s.bytes = out.str();
  s.fit = fit_session(s.log, nominal_gantry());
  return s;
}

TEST(CalibrationStore, AppliesListsAndActivates) {
  const std::string db = temp_db("apply");
  auto truth = nominal_gantry();
  const auto a = session(truth, 1);
  truth.axes[0].plant.gain_factor = 0.65;
  const auto b = session(truth, 2);
  ASSERT_EQ(a.fit.summary.status, Status::done) << a.fit.summary.message;
  ASSERT_EQ(b.fit.summary.status, Status::done) << b.fit.summary.message;
  {
    CalibrationStore store(db);
    EXPECT_FALSE(store.active("thermal_gantry"));
    const auto id1 = store.apply(a.fit, "/logs/a.csv", a.bytes, "alice");
    const auto id2 = store.apply(b.fit, "/logs/b.csv", b.bytes, "bob");
    EXPECT_NE(id1, id2);
  }
  CalibrationStore again(db);  // survives reopening
  const auto rows = again.history();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].who, "bob");  // newest first
  EXPECT_TRUE(rows[0].active);
  EXPECT_FALSE(rows[1].active);
  EXPECT_EQ(rows[1].log_path, "/logs/a.csv");
  EXPECT_EQ(rows[1].log_hash, log_hash(a.bytes));
  EXPECT_NE(rows[0].log_hash, rows[1].log_hash);
  const auto active = again.active("thermal_gantry");
  ASSERT_TRUE(active);
  EXPECT_EQ(active->who, "bob");
  EXPECT_DOUBLE_EQ(active->feed_factor[0], b.fit.axes[0].feed_factor);
  EXPECT_DOUBLE_EQ(active->backlash_mm[1], b.fit.axes[1].backlash_mm);
  EXPECT_TRUE(again.history("xy_table").empty());
}

TEST(CalibrationStore, RefusesAFitThatIsNotOk) {
  const std::string db = temp_db("refuse");
  auto s = session(nominal_gantry(), 3);
  s.fit.summary.status = Status::infeasible;
  s.fit.summary.message = "x.backlash_mm: the axis never reversed";
  CalibrationStore store(db);
  EXPECT_THROW(store.apply(s.fit, "a.csv", s.bytes, "carol"), Infeasible);
  EXPECT_TRUE(store.history().empty());
}

TEST(CalibrationStore, AProcessKilledMidWriteLeavesThePreviousCalibrationActive) {
  const std::string db = temp_db("killed");
  const auto a = session(nominal_gantry(), 4);
  auto truth = nominal_gantry();
  truth.axes[1].plant.gain_factor = 0.74;
  const auto b = session(truth, 5);
  std::int64_t first = 0;
  {
    CalibrationStore store(db);
    first = store.apply(a.fit, "a.csv", a.bytes, "dave");
  }
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The child dies inside the transaction, after every row is written, before COMMIT.
    CalibrationStore store(db);
    store.apply(b.fit, "b.csv", b.bytes, "eve", [] { ::_exit(7); });
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 7);  // it really died mid-write
  CalibrationStore store(db);
  const auto rows = store.history();
  ASSERT_EQ(rows.size(), 1u);
  const auto active = store.active("thermal_gantry");
  ASSERT_TRUE(active);
  EXPECT_EQ(active->fit_id, first);
  EXPECT_EQ(active->who, "dave");
  // And the store still takes writes.
  EXPECT_GT(store.apply(b.fit, "b.csv", b.bytes, "eve"), first);
}

TEST(CalibrationStore, AnUnreadableStoreIsNamed) {
  test::TempDir dir;
  const auto path = dir.write("not_a_db", "this is not an SQLite file, and it is long enough to have a header of sorts......\n");
  EXPECT_THROW(CalibrationStore{path}, InputError);
}

// A --db in a folder that does not exist is refused (a typing mistake must not create folders);
// only the default location creates its folder.
TEST(CalibrationStore, AFolderIsCreatedOnlyForTheDefaultLocation) {
  test::TempDir dir;
  const auto missing = dir.path() / "no_such_folder";
  const std::string msg = test::error_of([&] { CalibrationStore s((missing / "calibration.db").string()); });
  EXPECT_NE(msg.find("no_such_folder"), std::string::npos) << msg;
  EXPECT_FALSE(std::filesystem::exists(missing));

  const char* old = std::getenv("XDG_DATA_HOME");
  const std::string saved = old ? old : "";
  ::setenv("XDG_DATA_HOME", (dir.path() / "xdg").c_str(), 1);
  const std::string path = default_store_path();
  if (old) ::setenv("XDG_DATA_HOME", saved.c_str(), 1); else ::unsetenv("XDG_DATA_HOME");
  EXPECT_EQ(path, (dir.path() / "xdg" / "machplan" / "calibration.db").string());
  EXPECT_TRUE(std::filesystem::is_directory(dir.path() / "xdg" / "machplan"));
  CalibrationStore s(path);
  EXPECT_TRUE(s.history().empty());
}

// One session, fitted and stored, calibrates the paper's open-loop mode at every feed: the
// contour error on the rebuilt 45 degree triangle drops at least five-fold at three feeds.
TEST(CalibrationStore, OneSessionCalibratesPaperOpenLoopAtThreeFeeds) {
  const std::string db = temp_db("paper");
  const auto s = session(nominal_gantry(), 6);
  ASSERT_EQ(s.fit.summary.status, Status::done) << s.fit.summary.message;
  CalibrationStore store(db);
  store.apply(s.fit, "session.csv", s.bytes, "frank");
  const auto active = store.active("thermal_gantry");
  ASSERT_TRUE(active);
  const std::string part = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/triangle_45.ngc";
  for (double feed : {4.0, 8.0, 16.0}) {
    motion::RunOptions o;
    o.session.machine = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml";
    o.session.executor.mode = executor::Mode::paper_open;
    o.feed_override_mm_per_s = feed;
    const double e0 = motion::run_program(part, o).result.max_true_contour_error_mm();
    o.session.executor.calibration_factor = open_loop_factor(*active, feed);
    const double e1 = motion::run_program(part, o).result.max_true_contour_error_mm();
    RecordProperty(fmt::format("feed_{}_before_mm", feed), fmt::format("{:.3f}", e0));
    RecordProperty(fmt::format("feed_{}_after_mm", feed), fmt::format("{:.3f}", e1));
    std::printf("paper-open triangle at %g mm/s: max contour error %.3f mm uncalibrated, %.3f mm calibrated (factor %.5f)\n",
                feed, e0, e1, o.session.executor.calibration_factor);
    EXPECT_GT(e0, 5.0 * e1) << "feed " << feed;
  }
}

}  // namespace
}  // namespace machplan::calibration

namespace machplan::calibration {
namespace {

TEST(CalibrationApply, FeedFactorAndBacklashGoIntoTheServo) {
  const auto m = nominal_gantry();
  StoredFit c;
  c.fit_id = 9;
  c.feed_factor[0] = 0.68;
  c.feed_factor[1] = 0.71;
  c.backlash_mm[0] = 0.06;
  c.backlash_mm[1] = 0.12;
  const auto s = apply_calibration(m.setup(), c);
  EXPECT_NEAR(s.servo[0].velocity_ff, 1 / 0.68, 1e-12);
  EXPECT_NEAR(s.servo[1].velocity_ff, 1 / 0.71, 1e-12);
  EXPECT_DOUBLE_EQ(s.servo[1].backlash_compensation_mm, 0.12);
  EXPECT_NO_THROW(s.validate());
  // Everything else stays as the machine file says.
  EXPECT_DOUBLE_EQ(s.servo[0].kp_per_s, m.setup().servo[0].kp_per_s);
  EXPECT_DOUBLE_EQ(s.signals[0].mm_per_count, m.setup().signals[0].mm_per_count);
  EXPECT_EQ(s.calibrated_mm_per_count[0], 0.0);  // no scale in this fit: the declared one decodes
  // A fitted encoder scale decodes the counters; the declared one stays what the backend is checked against.
  c.mm_per_count[0] = 1.002 * m.setup().signals[0].mm_per_count;
  const auto t = apply_calibration(m.setup(), c);
  EXPECT_DOUBLE_EQ(t.calibrated_mm_per_count[0], c.mm_per_count[0]);
  EXPECT_DOUBLE_EQ(t.signals[0].mm_per_count, m.setup().signals[0].mm_per_count);
  c.mm_per_count[0] = 1.5 * m.setup().signals[0].mm_per_count;  // no encoder is 50 % off its pinion
  EXPECT_THROW(apply_calibration(m.setup(), c), InputError);
  c.mm_per_count[0] = 0.0;
  c.feed_factor[1] = 0.0;
  EXPECT_THROW(apply_calibration(m.setup(), c), InputError);
}

}  // namespace
}  // namespace machplan::calibration
