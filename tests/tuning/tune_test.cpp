// solvers/tuning: the evaluation on the simulated machine (contours, determinism, the
// constraint measures), a small tuning, and the store of tuned gains. Budgets are small (the
// tests run under ASan); full tunings are in bench/tuning_bench.cpp.
#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/json/tuning.h"
#include "engine/common/error.h"
#include "solvers/calibration/store.h"
#include "solvers/common/internal/sqlite_db.h"
#include "solvers/session/tuning_store.h"
#include "solvers/tuning/tune.h"
#include "tests/support/temp_dir.h"

namespace machplan::tuning {
namespace {

// These calls have no stop, deadline or budget of the caller's.
Termination no_stop_yet;

Evaluator circle_on(const std::string& machine, bool constraints = true) {
  EvaluationOptions o;
  o.machine = machine;
  o.constraints = constraints;
  return Evaluator(o, {parse_contour("circle:20:960")});
}

// One built-in contour on the XY table, without the step tests.
Evaluator table_contour(const char* spec) {
  EvaluationOptions o;
  o.machine = "xy_table";
  o.constraints = false;
  return Evaluator(o, {parse_contour(spec)});
}

TEST(TuningContour, ParsesTheCommandLineForms) {
  const TestContour l = parse_contour("line:26.6:1200");
  EXPECT_EQ(l.kind, TestContour::Kind::line);
  EXPECT_DOUBLE_EQ(l.angle_deg, 26.6);
  EXPECT_DOUBLE_EQ(l.feed_mm_per_min, 1200);
  const TestContour c = parse_contour("circle:20:960");
  EXPECT_EQ(c.kind, TestContour::Kind::circle);
  EXPECT_DOUBLE_EQ(c.radius_mm, 20);
  EXPECT_EQ(parse_contour("program:a.ngc").path, "a.ngc");
  const TestContour q = parse_contour("square:20:960");
  EXPECT_EQ(q.kind, TestContour::Kind::square);
  EXPECT_DOUBLE_EQ(q.length_mm, 20);
  for (const char* bad : {"", "triangle:1:2", "square:0.1:960", "line:26.6", "line:x:1200", "circle:20:0", "circle:-1:960", "program:",
                          "circle:20:960:5", "line:1e400:5"}) {
    try {
      parse_contour(bad);
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "contours") << bad;
    }
  }
  EXPECT_THROW(parse_objective("mean"), InputError);
  EXPECT_EQ(parse_objective("itae").value, Objective::itae);
}

TEST(TuningEvaluate, IsDeterministicAndMeasuresTheWholeCircle) {
  const Evaluator ev = circle_on("xy_table");
  const Evaluation a = ev.evaluate("p", {}), b = ev.evaluate("p", {});
  EXPECT_EQ(a.max_mm, b.max_mm);
  EXPECT_EQ(a.rms_mm, b.rms_mm);
  ASSERT_EQ(a.contours.size(), 1u);
  // 125.7 mm at 16 mm/s: at least 7.85 s of samples at 1 kHz, all of the move.
  EXPECT_GT(a.contours[0].samples, 7850u);
  EXPECT_LT(a.contours[0].samples, 9000u);
  EXPECT_GT(a.max_mm, 0.0);
  EXPECT_LT(a.max_mm, 0.5);
  EXPECT_LE(a.rms_mm, a.max_mm);
  EXPECT_GT(a.itae_mm_s2, 0.0);
  EXPECT_FALSE(a.faulted);
  EXPECT_TRUE(std::isfinite(a.overshoot));
  EXPECT_LT(a.margin_residual, 0.05) << "the machine's hand-tuned P is stable with the margin";
  // A much softer P lags more: the contour error grows.
  const auto specs = control::gain_specs("p", ev.plant());
  ASSERT_FALSE(specs.empty());
  control::Gains soft;
  soft[specs[0].name] = std::max(specs[0].min_value, specs[0].default_value / 5);
  EXPECT_GT(ev.evaluate("p", soft).max_mm, a.max_mm);
}

TEST(TuningEvaluate, ConstraintsFlagFaultsAndViolations) {
  EvaluationOptions o;
  Evaluation e;
  e.faulted = true;
  e.overshoot = 0.5;
  e.margin_residual = std::numeric_limits<double>::infinity();
  const auto g = constraint_values(e, o, 3.0);
  ASSERT_EQ(g.size(), 5u);
  EXPECT_GT(g[0], 0);  // unstable at the margin
  EXPECT_GT(g[1], 0);  // 50 % overshoot
  EXPECT_LE(g[2], 0);
  EXPECT_LE(g[3], 0);
  EXPECT_GT(g[4], 0);  // faulted
}

TEST(TuningEvaluate, RefusesAContourOutsideTheTravel) {
  EvaluationOptions o;
  o.machine = "xy_table";
  EXPECT_THROW(Evaluator(o, {parse_contour("circle:500:960")}), Infeasible);
  o.machine = "no_such_machine";
  EXPECT_THROW(Evaluator(o, {parse_contour("circle:20:960")}), InputError);
}

TEST(Tuning, ASmallBudgetImprovesOnTheStartWithinTheConstraints) {
  const Evaluator ev = circle_on("xy_table");
  TuneOptions o;
  o.kind = "p";
  o.optimizer.max_evaluations = 12;
  const TuneResult r = tune(ev, o, no_stop_yet);
  ASSERT_TRUE(r.summary.done()) << r.report();
  EXPECT_LE(r.tuned.max_mm, r.start.max_mm + 1e-12);
  EXPECT_LE(r.optimizer.evaluations, 12);
  const auto g = constraint_values(r.tuned, o.evaluation, 3.0);
  for (double v : g) EXPECT_LE(v, 1e-6);
  // The start is p with the drive model's feed-forward; the baseline p at its defaults.
  EXPECT_NEAR(r.start_gains.at("velocity_ff"), 1.0, 1e-12);
  EXPECT_NEAR(r.start_gains.at("acceleration_ff_s"), 0.004, 1e-12);
  EXPECT_NEAR(r.start_gains.at("friction_ff_mm_per_s"), 2.0, 1e-12);
  EXPECT_NEAR(r.start_gains.at("backlash_ff_mm"), 0.002, 1e-12);
  EXPECT_LT(r.start.max_mm, r.baseline.max_mm);
  TuneOptions plain = o;
  plain.model_start = false;
  plain.fresh_check = false;
  plain.optimizer.max_evaluations = 1;
  EXPECT_EQ(r.start_from, "drive-model feed-forward");
  // Checked under noise the tuning never saw: the seeds after its own.
  EXPECT_EQ(r.fresh_seed, o.evaluation.seed + static_cast<std::uint64_t>(o.evaluation.noise_runs));
  ASSERT_EQ(r.fresh_tuned.contours.size(), 1u);
  EXPECT_GT(r.fresh_tuned.max_mm, 0.0);
  EXPECT_NE(r.fresh_baseline.max_mm, r.baseline.max_mm) << "another draw of the noise";
  EXPECT_TRUE(cli::to_json(r).contains("fresh"));
  EXPECT_NE(r.report().find("under noise it was not tuned on"), std::string::npos);
  const TuneResult rp = tune(ev, plain, no_stop_yet);
  EXPECT_EQ(rp.start_from, "defaults");
  EXPECT_EQ(rp.fresh_seed, 0u);
  EXPECT_FALSE(cli::to_json(rp).contains("fresh"));
  EXPECT_EQ(rp.start.max_mm, r.baseline.max_mm) << "p at its defaults is the baseline";
  const auto j = cli::to_json(r);
  for (const char* k : {"gains", "baseline", "tuned", "status"}) EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(j["baseline"]["max_contour_error_mm"].is_number());
  EXPECT_TRUE(j["tuned"]["rms_contour_error_mm"].is_number());
}

TEST(Tuning, CrossCoupledWithFeedForwardBeatsTheAxialPOnTheCircle) {
  // From a hand start (the table's friction fed forward, velocity and acceleration feed-forward,
  // a contour integral), 25 evaluations (the bench runs 600): never worse than the start, and
  // far below the hand-tuned axial P.
  const Evaluator ev = circle_on("xy_table");
  TuneOptions o;
  o.kind = "ccc";
  o.start = {{"friction_ff_mm_per_s", 2.0}, {"friction_ff_band_mm_per_s", 0.05}, {"velocity_ff", 1.0},
             {"acceleration_ff_s", 0.006}, {"ccc_ki_per_s2", 10000.0}};
  o.optimizer.max_evaluations = 25;
  const TuneResult r = tune(ev, o, no_stop_yet);
  ASSERT_TRUE(r.summary.done()) << r.report();
  EXPECT_LE(r.tuned.max_mm, r.start.max_mm + 1e-12) << r.report();
  EXPECT_LT(r.tuned.max_mm, r.baseline.max_mm / 3.0) << r.report();
  EXPECT_LT(r.tuned.rms_mm, r.baseline.rms_mm / 3.0) << r.report();
  // The feed-forward stays in its physical range (g = 1, Coulomb friction 2 mm/s here).
  EXPECT_LE(r.gains.at("velocity_ff"), 1.25 + 1e-9);
  EXPECT_LE(r.gains.at("friction_ff_mm_per_s"), 2.5 + 1e-9);
  // A start value for a gain the kind does not have is refused.
  o.start = {{"no_such_gain", 1.0}};
  EXPECT_THROW(tune(ev, o, no_stop_yet), InputError);
}

TEST(TuningContour, SquareIsOneClosedStretchOfFourSides) {
  const Evaluator ev = table_contour("square:20:960");
  const motion::Job& j = ev.job(0);
  ASSERT_EQ(j.stretches.size(), 1u);
  const auto& segs = j.stretches[0].segments;
  ASSERT_EQ(segs.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR((segs[i].end - segs[i].start).norm(), 20.0, 1e-9);
    EXPECT_NEAR((segs[(i + 1) % 4].start - segs[i].end).norm(), 0.0, 1e-9);
  }
  EXPECT_NEAR((segs[0].end - segs[0].start).x(), 20.0, 1e-9);  // counter-clockwise: +X first
  EXPECT_NEAR((segs[1].end - segs[1].start).y(), 20.0, 1e-9);
}

TEST(TuningEvaluate, NoiseRunsTakeTheWorstOfTheirRunsAndSayWhere) {
  EvaluationOptions o;
  o.machine = "xy_table";
  o.constraints = false;
  const auto with = [&](std::uint64_t seed, int runs) {
    EvaluationOptions e = o;
    e.seed = seed;
    e.noise_runs = runs;
    return Evaluator(e, {parse_contour("circle:20:960")}).evaluate("p", {}).contours.at(0);
  };
  const ContourScore a = with(1, 1), b = with(2, 1), both = with(1, 2);
  EXPECT_NE(a.max_mm, b.max_mm) << "two draws of the noise";
  EXPECT_EQ(both.max_mm, std::max(a.max_mm, b.max_mm));
  EXPECT_EQ(both.samples, a.samples + b.samples);
  EXPECT_NEAR(both.itae_mm_s2, (a.itae_mm_s2 + b.itae_mm_s2) / 2, 1e-12);
  EXPECT_NEAR(both.rms_mm * both.rms_mm * both.samples, a.rms_mm * a.rms_mm * a.samples + b.rms_mm * b.rms_mm * b.samples,
              1e-12);
  // Where: on the circle (radius 20 about the travel's centre), during the move, line 1.
  const ContourScore& w = a.max_mm >= b.max_mm ? a : b;
  EXPECT_EQ(both.max_at_s, w.max_at_s);
  EXPECT_NEAR(std::hypot(both.max_at_x_mm - 200.0, both.max_at_y_mm - 175.0), 20.0, both.max_mm + 1e-9);
  EXPECT_GT(both.max_at_s, 0.0);
  EXPECT_LT(both.max_at_s, 9.0);
  EXPECT_EQ(both.max_at_line, 1);
  o.noise_runs = 0;
  EXPECT_THROW(o.validate(), InputError);
}

TEST(Tuning, FixedGainsAreHeldAndNotSearched) {
  const Evaluator ev = circle_on("xy_table");
  TuneOptions o;
  o.kind = "p";
  o.fixed = {{"kp_per_s", 100.0}, {"observer_per_s", 0.0}};
  o.optimizer.max_evaluations = 8;
  const TuneResult r = tune(ev, o, no_stop_yet);
  EXPECT_EQ(r.gains.at("kp_per_s"), 100.0);
  EXPECT_EQ(r.gains.at("observer_per_s"), 0.0);
  EXPECT_EQ(cli::to_json(r)["fixed"].size(), 2u);
  EXPECT_NE(r.report().find("(fixed)"), std::string::npos);
  o.fixed = {{"no_such_gain", 1.0}};
  try {
    tune(ev, o, no_stop_yet);
    ADD_FAILURE() << "an unknown gain was fixed";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "fixed");
  }
  o.fixed = {{"kp_per_s", 100.0}};
  o.start = {{"kp_per_s", 90.0}};
  EXPECT_THROW(tune(ev, o, no_stop_yet), InputError);
}

TEST(TuningContour, CornerIsTwoLegsThroughTheCentre) {
  const Evaluator ev = table_contour("corner:90:960");
  const motion::Job& j = ev.job(0);
  ASSERT_EQ(j.stretches.size(), 1u);
  ASSERT_EQ(j.stretches[0].segments.size(), 2u);
  const Segment& a = j.stretches[0].segments[0];
  const Segment& b = j.stretches[0].segments[1];
  EXPECT_NEAR((a.end - a.start).norm(), 25.0, 1e-9);
  EXPECT_NEAR((b.end - b.start).dot(a.end - a.start), 0.0, 1e-9);
  EXPECT_GT(ev.evaluate("p", {}).max_mm, 0.0);
  EXPECT_THROW(parse_contour("corner:0:960"), InputError);
  EXPECT_THROW(parse_contour("corner:180:960"), InputError);
}

TEST(TuningStoreTest, SavesActivatesAndRefusesFailedTunings) {
  test::TempDir dir;
  const std::string db = (dir.path() / "store.db").string();
  TuningStore s(db);
  EXPECT_FALSE(s.active("xy_table"));
  const Summary done;
  const auto id1 = s.save("xy_table", "p", {{"kp_per_s", 100}}, done, "{}", "tester");
  const auto id2 = s.save("xy_table", "pid", {{"kp_per_s", 120}, {"ki_per_s2", 900}}, done, "{}", "tester");
  EXPECT_NE(id1, id2);
  Summary failed;
  failed.status = Status::infeasible;
  EXPECT_THROW(s.save("xy_table", "p", {}, failed, "{}", "tester"), Infeasible);
  failed.status = Status::deadline;  // ended by its deadline, not usable
  EXPECT_THROW(s.save("xy_table", "p", {}, failed, "{}", "tester"), Infeasible);
  const auto a = s.active("xy_table");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->id, id2);
  EXPECT_EQ(a->controller, "pid");
  EXPECT_DOUBLE_EQ(a->gains.at("ki_per_s2"), 900);
  EXPECT_EQ(a->status, "done");
  EXPECT_EQ(s.history("xy_table").size(), 2u);
  EXPECT_FALSE(s.active("thermal_gantry"));
  // Ended by its deadline with gains that meet every constraint: stored, and says so.
  Summary usable;
  usable.status = Status::deadline;
  usable.usable = true;
  const auto id3 = s.save("xy_table", "ccc", {{"kp_per_s", 90}}, usable, "{}", "tester");
  EXPECT_EQ(s.active("xy_table")->id, id3);
  EXPECT_EQ(s.active("xy_table")->status, "deadline");
}

// A store written before statuses took Summary's spelling: a fit "ok" and a tuning without a
// status column, both with "ok" in their JSON. Opening it reads them as done.
TEST(TuningStoreTest, AnOlderStoreReadsInSummarysSpelling) {
  test::TempDir dir;
  const std::string db = (dir.path() / "old.db").string();
  {
    store::SqliteDb old(db, R"sql(
CREATE TABLE sessions (id INTEGER PRIMARY KEY, machine TEXT NOT NULL, log_path TEXT NOT NULL, log_hash TEXT NOT NULL,
  who TEXT NOT NULL, added_utc TEXT NOT NULL);
CREATE TABLE fits (id INTEGER PRIMARY KEY, session_id INTEGER NOT NULL REFERENCES sessions(id), machine TEXT NOT NULL,
  status TEXT NOT NULL, fit_json TEXT NOT NULL, who TEXT NOT NULL, created_utc TEXT NOT NULL);
CREATE TABLE active (machine TEXT PRIMARY KEY, fit_id INTEGER NOT NULL REFERENCES fits(id));
CREATE TABLE tunings (id INTEGER PRIMARY KEY, machine TEXT NOT NULL, controller TEXT NOT NULL, gains_json TEXT NOT NULL,
  result_json TEXT NOT NULL, who TEXT NOT NULL, created_utc TEXT NOT NULL);
CREATE TABLE active_tuning (machine TEXT PRIMARY KEY, tuning_id INTEGER NOT NULL REFERENCES tunings(id));
INSERT INTO sessions VALUES (1, 'thermal_gantry', '/tmp/s.csv', '00', 'tester', '2026-01-01T00:00:00Z');
INSERT INTO fits VALUES (1, 1, 'thermal_gantry', 'ok', '{"status": "ok", "axes": {}}', 'tester', '2026-01-01T00:00:00Z');
INSERT INTO active VALUES ('thermal_gantry', 1);
INSERT INTO tunings VALUES (1, 'xy_table', 'p', '{"kp_per_s": 80}', '{"status": "ok"}', 'tester', '2026-01-01T00:00:00Z');
INSERT INTO active_tuning VALUES ('xy_table', 1);
)sql");
  }
  const auto t = TuningStore(db).active("xy_table");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->status, "done");
  EXPECT_EQ(nlohmann::json::parse(t->result_json)["status"], "done");
  EXPECT_DOUBLE_EQ(t->gains.at("kp_per_s"), 80);
  const auto f = calibration::CalibrationStore(db).active("thermal_gantry");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->status, "done");
  EXPECT_EQ(nlohmann::json::parse(f->fit_json)["status"], "done");
}

}  // namespace
}  // namespace machplan::tuning
