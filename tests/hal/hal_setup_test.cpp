// Bad HAL setups get a clear message and exit 2, never a hang: HAL not running, no machplan
// component, its function in no thread, a servo period other than the machine file's, pins not
// linked, the axes away from the job's start, a second machplan on a machine already driven.
// Each case brings up a HAL file of its own (scripts/hal-sim up --file) and stops it again.
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "tests/support/hal_sim.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using namespace std::chrono_literals;

struct Outcome {
  int code = 0;
  std::string err;
};

std::string read_whole(const std::string& path) {
  std::ifstream f(path);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// `machplan run` of the triangle on the HAL backend, with a time limit.
Outcome run_triangle(const test::TempDir& dir) {
  const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
  test::Child c(fmt::format("'{}' run datasets/parts/triangle_45.ngc --machine thermal_gantry --backend hal", MACHPLAN_CLI),
                out, err);
  const int code = c.wait(60s);
  return {code, read_whole(err)};
}

// `scripts/hal-sim up` arguments for a HAL file of `text`, written into `dir`.
std::string hal_file(const test::TempDir& dir, const std::string& text) {
  const std::string path = (dir.path() / "machine.hal").string();
  std::ofstream(path) << text;
  return "--file '" + path + "'";
}

const char* kThread = "loadrt threads name1=servo-thread period1=1000000\n";

void expect_refused(const Outcome& o, const std::string& words) {
  EXPECT_EQ(o.code, 2) << o.err;
  EXPECT_NE(o.err.find(words), std::string::npos) << o.err;
}

TEST(HalSetup, HalNotRunning) {
  test::hal_sim("down");
  test::TempDir dir;
  expect_refused(run_triangle(dir), "HAL is not running");
}

TEST(HalSetup, NoMachplanComponent) {
  test::TempDir dir;
  test::HalSim sim(hal_file(dir, std::string(kThread) + "start\n"));
  expect_refused(run_triangle(dir), "has no machplan component");
}

TEST(HalSetup, FunctionInNoThread) {
  test::TempDir dir;
  test::HalSim sim(hal_file(dir, std::string(kThread) + "loadrt machplan\nstart\n"));
  expect_refused(run_triangle(dir), "addf machplan servo-thread");
}

TEST(HalSetup, ServoPeriodOtherThanTheMachineFiles) {
  test::TempDir dir;
  test::HalSim sim(hal_file(dir, "loadrt threads name1=servo-thread period1=2000000\nloadrt machplan\n"
                                 "addf machplan servo-thread\nstart\n"));
  expect_refused(run_triangle(dir), "runs machplan every 2 ms, the machine file's servo_period_s is 1 ms");
}

TEST(HalSetup, EstopChainNotLinked) {
  test::TempDir dir;
  test::HalSim sim(hal_file(dir, std::string(kThread) + "loadrt machplan\naddf machplan servo-thread\nstart\n"));
  expect_refused(run_triangle(dir), "machplan.estop-ok is not linked");
}

TEST(HalSetup, PositionFeedbackNotLinked) {
  test::TempDir dir;
  test::HalSim sim(hal_file(dir, std::string(kThread) +
                                     "loadrt machplan\nnet estop-ok machplan.estop-ok\nnet on machplan.enable\n"
                                     "net x-cmd machplan.axis.0.pos-cmd\naddf machplan servo-thread\nstart\n"));
  expect_refused(run_triangle(dir), "machplan.axis.0.pos-fb is not linked: net it to the drive's position feedback");
}

TEST(HalSetup, AxesAwayFromTheJobsStart) {
  test::HalSim sim;
  test::hal_sim("home 10 20");
  test::TempDir dir;
  expect_refused(run_triangle(dir), "the machine stands at X 10.000, Y 20.000 mm and the job starts at X 0.000, Y 0.000 mm");
}

TEST(HalSetup, ASecondMachplanIsRefusedWhileOneDrivesTheMachine) {
  test::HalSim sim;
  test::HalPins pins;
  test::TempDir dir, dir2;
  const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
  test::Child first(
      fmt::format("'{}' run datasets/parts/triangle_45.ngc --machine thermal_gantry --backend hal", MACHPLAN_CLI), out, err);
  const auto limit = std::chrono::steady_clock::now() + 60s;
  while (pins.number("machplan.state") != 2 && std::chrono::steady_clock::now() < limit) std::this_thread::sleep_for(5ms);
  ASSERT_EQ(pins.number("machplan.state"), 2) << read_whole(err);
  expect_refused(run_triangle(dir2), fmt::format("another machplan (pid {}) is driving this machine", first.pid()));
  first.kill_now();
}

}  // namespace
}  // namespace machplan
