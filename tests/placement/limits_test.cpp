// Absurd but well-formed placement input ends quickly with a message naming the limit: numbers
// beyond the scene's bounds are refused as input errors, too many peripherals are refused by
// name, and a check that would run for minutes (a large safe distance) stops at its query
// limit with exit 3 and says how to raise it.
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <thread>
#include <fstream>
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/stop.h"
#include "tests/support/datasets.h"
#include "solvers/placement/check/checker.h"
#include "solvers/placement/scene/scene.h"
#include "solvers/placement/search/search.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using test::error_of;
using test::TempDir;


// The bundled scene with 3 rows of its tool path and `replace` pairs applied to its text.
std::string write_scene(const TempDir& dir, std::vector<std::pair<std::string, std::string>> replace) {
  std::ifstream in(test::kHexamPaper + "toolpath.csv");
  std::ofstream out(dir.path() / "toolpath.csv");
  std::string line;
  for (int i = 0; i <= 3 * 351 && std::getline(in, line); ++i) out << line << '\n';
  out.close();
  std::ifstream sc(test::kHexamPaper + "scene.yaml");
  std::string text((std::istreambuf_iterator<char>(sc)), std::istreambuf_iterator<char>());
  replace.emplace_back("machine.yaml", test::kHexamPaper + "machine.yaml");
  replace.emplace_back("workpiece.stl", test::kHexamPaper + "workpiece.stl");
  for (const auto& [from, to] : replace) {
    const auto at = text.find(from);
    if (at == std::string::npos) return "<'" + from + "' not in the bundled scene>";
    text.replace(at, from.size(), to);
  }
  return dir.write("scene.yaml", text);
}

TEST(SceneLimits, HugeNumbersAreRefusedNamingTheKey) {
  struct Case {
    std::string from, to, key;
  };
  const Case cases[] = {
      {"tool_diameter_mm: 10", "tool_diameter_mm: 1e300", "tooling.tool_diameter_mm"},
      {"chuck_length_mm: 45", "chuck_length_mm: 1e9", "tooling.chuck_length_mm"},
      {"pad_max_mm: 200", "pad_max_mm: 1e308", "search.pad_max_mm"},
      {"center: [397.4, 397.4, 211]", "center: [1e9, 397.4, 211]", "center"},
      {"size: [200, 240, 422]", "size: [200, 1e12, 422]", "size"},
      {"yaw_deg: 45", "yaw_deg: 1e300", "yaw_deg"},
      {"pad_max_mm: 200", "pad_max_mm: 200\n  max_pose_queries: 0", "search.max_pose_queries"},
  };
  for (const Case& c : cases) {
    TempDir dir;
    const std::string path = write_scene(dir, {{c.from, c.to}});
    const std::string msg = error_of([&] { load_scene(path); });
    EXPECT_THAT(msg, HasSubstr(path + ":")) << c.to;
    EXPECT_THAT(msg, HasSubstr(c.key)) << c.to << "\n" << msg;
  }
}

// The optimal search's grid is bounded like the other search limits: a grid finer than
// kMinResolutionMm (searching for minutes) is refused naming the key and the bound.
TEST(SceneLimits, AGridFinerThanTheBoundIsRefused) {
  TempDir dir;
  const std::string fine = write_scene(dir, {{"pad_max_mm: 200", "pad_max_mm: 200\n  resolution_mm: 0.01"}});
  EXPECT_THAT(error_of([&] { load_scene(fine); }),
              HasSubstr(fmt::format("key 'search.resolution_mm' must be >= {}, got 0.01", kMinResolutionMm)));
  const std::string bound = write_scene(dir, {{"pad_max_mm: 200", fmt::format("pad_max_mm: 200\n  resolution_mm: {}",
                                                                              kMinResolutionMm)}});
  EXPECT_EQ(load_scene(bound).search.resolution_mm, kMinResolutionMm);
}

// `place` on a scene no placement fits says so once: the verdict is the command's, the reason
// the search's.
TEST(SceneLimits, APadLimitOfZeroSaysCannotBeMachinedOnce) {
  TempDir dir;
  const std::string scene =
      write_scene(dir, {{"pad_max_mm: 200", "pad_max_mm: 0"}, {"toolpath: toolpath.csv", "toolpath: " + test::kHexamPaper + "toolpath.csv"}});
  const test::CliResult r = test::Cli().run({"place", scene});
  EXPECT_EQ(r.code, 3) << r.err;
  const std::string verdict = "cannot be machined on this machine: ";
  const auto first = r.err.find(verdict);
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("cannot be machined", first + 1), std::string::npos) << r.err;
  EXPECT_THAT(r.err, HasSubstr(verdict + "no placement on the table with a pad up to 0 mm is free of interference"))
      << r.err;
}

TEST(SceneLimits, MorePeripheralsThanTheCheckerHandlesAreRefused) {
  std::string many = "peripherals:\n";
  for (int k = 0; k < static_cast<int>(kMaxPeripherals); ++k)  // plus the bundled magazine
    many += fmt::format("  - {{name: p{}, box: {{center: [{}, 400, 50], size: [10, 10, 10]}}}}\n", k, -300 + 40 * k);
  TempDir dir;
  const std::string path = write_scene(dir, {{"peripherals:\n", many}});
  const std::string msg = error_of([&] { load_scene(path); });
  EXPECT_THAT(msg, HasSubstr(fmt::format("{} peripherals; at most {} are supported", kMaxPeripherals + 1, kMaxPeripherals)));
}

TEST(CheckLimits, ACheckStopsAtTheQueryLimitWithExitThreeAndSaysHowToRaiseIt) {
  TempDir dir;
  const std::string scene = write_scene(dir, {{"pad_max_mm: 200", "pad_max_mm: 200\n  max_pose_queries: 50"}});
  const test::CliResult r = test::Cli().run({"check", scene, "--at", "-68,-22,57"});
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, HasSubstr("limit of 50 exact pose queries (search.max_pose_queries in the scene)"));
  EXPECT_THAT(r.err, HasSubstr("Raise the limit"));
  // The default leaves the ordinary check alone.
  const Scene ok = load_scene(write_scene(dir, {}));
  EXPECT_EQ(ok.search.max_pose_queries, SearchSettings{}.max_pose_queries);
  Checker checker(ok);
  Termination term;
  checker.report({-68, -22, 57, 0}, term);
  EXPECT_LT(checker.counts().exact_queries, ok.search.max_pose_queries);
  EXPECT_GT(checker.counts().exact_queries, 50);  // so the limit of 50 above was really reached
}

TEST(CheckStop, AStopRequestEndsACheckAndASearchWithoutAnAnswer) {
  TempDir dir;
  const Scene scene = load_scene(write_scene(dir, {}));
  StopSource source;
  Termination term(source.token());
  Checker checker(scene);
  const CheckReport before = checker.report({-68, -22, 57, 0}, term);  // not stopped: an answer
  EXPECT_GT(before.counts.exact_queries + checker.counts().exact_queries, 0);
  source.request_stop();
  EXPECT_THROW(checker.report({-60, -20, 57, 0}, term), WorkEnded);
  EXPECT_THROW(checker.dense_check({-60, -20, 57, 0}, 0.5, term), WorkEnded);
  Termination fresh(source.token());
  const PlacementResult r = place(scene, PlacementOptions{}, fresh);
  EXPECT_TRUE(r.ended_early());
  EXPECT_EQ(r.summary.status, Status::cancelled);
  EXPECT_EQ(r.summary.exit_code(), 3);
  EXPECT_THAT(r.summary.full_report(), HasSubstr("stopped on request"));
  const CheckResult c = check(scene, {-60, -20, 57, 0}, CheckOptions{}, fresh);
  EXPECT_EQ(c.summary.status, Status::cancelled);
}

TEST(CheckStop, ABudgetEndsASearchWithStatusBudget) {
  TempDir dir;
  const Scene scene = load_scene(write_scene(dir, {{"pad_max_mm: 200", "pad_max_mm: 200\n  max_pose_queries: 50"}}));
  Termination term;
  const PlacementResult r = place(scene, PlacementOptions{}, term);
  EXPECT_TRUE(r.ended_early());
  EXPECT_EQ(r.summary.status, Status::budget);
  EXPECT_THAT(r.summary.message, HasSubstr("limit of 50 exact pose queries"));
  // A budget of the caller's own ends the search the same way, and says so.
  Termination tight;
  tight.set_budget(100, "exact pose queries");
  const PlacementResult t = place(load_scene(write_scene(dir, {})), PlacementOptions{}, tight);
  EXPECT_EQ(t.summary.status, Status::budget);
  EXPECT_THAT(t.summary.message, HasSubstr("the budget of 100 exact pose queries was spent"));
}

TEST(CheckStop, SigintEndsASearchWithExitThree) {
  // Every rotation a quarter of a degree apart on the bundled scene: a search of many seconds
  // on any machine. SIGINT, sent once the command handles it, ends it through the stop request
  // with exit 3 and no placement printed.
  TempDir dir;
  std::ifstream sc(test::kHexamPaper + "scene.yaml");
  std::string text((std::istreambuf_iterator<char>(sc)), std::istreambuf_iterator<char>());
  for (const char* f : {"machine.yaml", "workpiece.stl", "toolpath.csv"}) text.replace(text.find(f), std::string(f).size(), test::kHexamPaper + f);
  text.replace(text.find("pad_max_mm: 200"), 15, "pad_max_mm: 200\n  rotation_step_deg: 0.25");
  const std::string scene = dir.write("scene.yaml", text);
  test::Cli cli;
  test::CliProcess p = cli.start({"place", scene, "--rotations", "any"});
  ASSERT_TRUE(p.wait_until_catching(SIGINT));
  ASSERT_TRUE(p.signal(SIGINT));
  const test::CliResult r = p.wait();
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, HasSubstr("stopped on request"));
  EXPECT_THAT(r.out, Not(HasSubstr("placement:")));
  EXPECT_THAT(r.out, HasSubstr("placement search ended (cancelled) before an answer"));
}

TEST(CheckStop, TheDenseCheckReportsItsProgress) {
  TempDir dir;
  const Scene scene = load_scene(write_scene(dir, {}));
  Checker checker(scene);
  Termination term;
  // A display reading the share from another thread sees it grow to 1.
  Progress progress;
  std::atomic<bool> over{false};
  std::vector<double> seen;
  std::thread watcher([&] {
    while (!over.load()) {
      seen.push_back(progress.share());
      std::this_thread::yield();
    }
  });
  checker.dense_check({-68, -22, 57, 0}, 0.5, term, &progress);
  over = true;
  watcher.join();
  EXPECT_EQ(progress.share(), 1.0);
  ASSERT_FALSE(seen.empty());
  for (double s : seen) EXPECT_TRUE(s >= 0.0 && s <= 1.0);
}

TEST(CheckLimits, ALargeSafeDistanceCostsNoMoreThanAnOrdinaryCheck) {
  // A safe distance of 1000 mm: no stretch of the path can be cleared in bulk, and class 1
  // interferes everywhere. Once an interference is known only a smaller clearance matters, so
  // the checker still looks at a small part of the path.
  TempDir dir;
  const Scene big = load_scene(write_scene(dir, {{"safe_distance_mm: 5", "safe_distance_mm: 1000"}}));
  ASSERT_EQ(big.safe_distance_mm, 1000.0);
  Checker checker(big);
  Termination term;
  EXPECT_TRUE(checker.class1(0.0, term).interferes);
  const long class1_queries = checker.counts().exact_queries;
  // Without the bound every pose was an exact query; now a small share of them.
  EXPECT_LT(class1_queries, static_cast<long>(big.tips_mm.size()) / 4) << "class 1 walked most of the path";
  EXPECT_GE(checker.class1(0.0, term).pose, 0);
  EXPECT_THAT(checker.class1(0.0, term).what, HasSubstr("/ workpiece"));
  const CheckReport r = checker.report({-68, -22, 57, 0}, term);
  EXPECT_FALSE(r.free());
  EXPECT_TRUE(r.kinds[static_cast<int>(Kind::workpiece_class1)].interferes);
  EXPECT_TRUE(r.kinds[static_cast<int>(Kind::workpiece_class2)].interferes);
  // No more work than the same check at the ordinary 5 mm (before the bound: 40 times more).
  const Scene five = load_scene(write_scene(dir, {}));  // the Checker keeps a reference
  Checker ordinary(five);
  ordinary.report({-68, -22, 57, 0}, term);
  EXPECT_LE(checker.counts().exact_queries, 2 * ordinary.counts().exact_queries + 50);
}

TEST(CheckLimits, AHugeToolTouchingEverywhereEndsQuicklyAsUnavoidable) {
  // A 2 m tool in a 3 m chuck meets the workpiece at every pose: once a clearance of 0 is
  // found nothing smaller exists (clearances are distances), so the walk stops there instead
  // of measuring every pose (4 minutes for the bundled path before).
  TempDir dir;
  const Scene scene = load_scene(
      write_scene(dir, {{"tool_diameter_mm: 10", "tool_diameter_mm: 2000"}, {"chuck_diameter_mm: 60", "chuck_diameter_mm: 3000"}}));
  ASSERT_EQ(scene.tooling.tool_diameter_mm, 2000.0);
  Checker checker(scene);
  Termination term;
  EXPECT_TRUE(checker.class1(0.0, term).interferes);
  EXPECT_EQ(checker.class1(0.0, term).clearance_mm, 0.0);
  EXPECT_LT(checker.counts().exact_queries, static_cast<long>(scene.tips_mm.size()) / 4);
  const PlacementResult r = place(scene, PlacementOptions{}, term);
  EXPECT_NE(r.summary.message.find("cannot be avoided by relocation"), std::string::npos);
  EXPECT_EQ(r.summary.status, Status::infeasible);
}

}  // namespace
}  // namespace machplan::placement
