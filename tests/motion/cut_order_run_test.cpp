// The cut order and the rapids over cut parts through `machplan run`'s pipeline
// (solvers/motion/run.h) on the bundled parts, measured on the simulated machine (its clock,
// not the wall's):
//   * the bracket programmed outline first: rapids within 10 % of the straight moves, planned
//     motion no slower than LinuxCNC 2.9's best on the same program and limits (35.404 s with
//     G64, measured by bench/linuxcnc/measure.py; bench/results/cut_order.txt), the order
//     warned about; optimised, its holes and slot cut before the outline;
//   * the nested sheet: optimised at least 20 % less rapid travel than as programmed, and no
//     worse than the program's order or nearest neighbour in rapid travel or motion time on
//     every bundled part;
//   * the machine file's cut_order as the default.
#include <map>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "tests/support/datasets.h"
#include "engine/common/text_file.h"
#include "solvers/motion/run.h"
#include "tests/support/temp_dir.h"

namespace machplan::motion {
namespace {

using ::testing::HasSubstr;

using test::part;

RunOutcome run(const std::string& path, std::optional<CutOrder> order, const std::string& machine = "thermal_gantry") {
  RunOptions o;
  o.session.machine = machine;
  o.order = order;
  o.session.executor.record_trace = false;
  RunOutcome r = run_program(path, o);
  EXPECT_EQ(r.result.summary.status, Status::done) << r.summary.full_report();
  return r;
}

TEST(CutOrderRun, TheOutlineFirstBracketCrossesItsPartAndBeatsLinuxcnc) {
  const RunOutcome r = run(part("bracket_outline_first.ngc"), std::nullopt);
  EXPECT_FALSE(r.cut_order.reordered);
  EXPECT_LE(r.rapids.length_mm, 1.10 * r.rapids.straight_length_mm);
  EXPECT_EQ(r.rapids.detours, 0u);
  EXPECT_EQ(r.rapids.crossings, 4u);  // into the plate three times, out of it once
  EXPECT_LE(r.planned_motion_s, 35.404);
  bool warned = false;
  for (const std::string& w : r.warnings) warned = warned || w.find("encloses the cut at line 26, cut after it") != std::string::npos;
  EXPECT_TRUE(warned) << r.summary.full_report();
  // The torch was raised before each crossing: the torch_off steps carry the travel height.
  int raised = 0;
  for (const Step& s : r.job.steps) raised += s.kind == Step::Kind::torch_off && s.height_mm == 40.0;
  EXPECT_EQ(raised, 4);

  const RunOutcome o = run(part("bracket_outline_first.ngc"), CutOrder::optimise);
  ASSERT_TRUE(o.cut_order.reordered);
  ASSERT_EQ(o.cut_order.sequence.size(), 4u);
  EXPECT_EQ(o.cut_order.cut_lines[static_cast<std::size_t>(o.cut_order.sequence.back())], 12);  // the outline last
  EXPECT_EQ(o.rapids.crossings, 0u);
  EXPECT_LE(o.planned_motion_s, r.planned_motion_s);
  EXPECT_LT(o.result.cycle_time_s, r.result.cycle_time_s);
}

TEST(CutOrderRun, OptimisedIsNoWorseOnEveryBundledPartAndFarShorterOnTheNestedSheet) {
  for (const char* name : {"triangle_45.ngc", "contour_lines_arcs.ngc", "bracket_l.ngc", "nested_sheet.ngc"}) {
    const RunOutcome program = run(part(name), CutOrder::program);
    const RunOutcome nearest = run(part(name), CutOrder::nearest);
    const RunOutcome optimised = run(part(name), CutOrder::optimise);
    for (const RunOutcome* other : {&program, &nearest}) {
      EXPECT_LE(optimised.rapids.length_mm, other->rapids.length_mm + 1e-6) << name;
      EXPECT_LE(optimised.planned_motion_s, other->planned_motion_s + 1e-6) << name;
    }
    if (std::string(name) == "nested_sheet.ngc") {
      EXPECT_LE(optimised.rapids.length_mm, 0.80 * program.rapids.length_mm);
      EXPECT_TRUE(optimised.rapids.ok()) << optimised.rapids.summary.full_report();
    }
  }
}

TEST(CutOrderRun, TheMachineFilesCutOrderIsTheDefault) {
  test::TempDir dir;
  const std::string gantry = read_text_file(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/machines/thermal_gantry.yaml");
  const std::string optimise = dir.write("gantry_optimise.yaml", gantry + "cut_order: optimise\n");
  const RunOutcome r = run(part("bracket_outline_first.ngc"), std::nullopt, optimise);
  EXPECT_TRUE(r.cut_order.reordered);
  EXPECT_EQ(r.cut_order.order, CutOrder::optimise);
  // The option wins over the file.
  EXPECT_FALSE(run(part("bracket_outline_first.ngc"), CutOrder::program, optimise).cut_order.reordered);
  // A name that is not an order: the file and line.
  const std::string bad = dir.write("gantry_bad.yaml", gantry + "cut_order: sideways\n");
  RunOptions o;
  o.session.machine = bad;
  try {
    (void)run_program(part("bracket_outline_first.ngc"), o);
    FAIL() << "an unknown cut_order was accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("gantry_bad.yaml:"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("key 'cut_order' must be program, nearest or optimise, got 'sideways'"));
  }
}

}  // namespace
}  // namespace machplan::motion
