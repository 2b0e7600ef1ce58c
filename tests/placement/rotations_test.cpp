// Workpiece rotations: lists, ranges and `any`, read as people write them; the search over many
// rotations at once is never worse than the best of the same rotations searched one by one,
// and the rotation interval it claims is free.
#include <cmath>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "solvers/placement/search/search.h"
#include "tests/support/temp_dir.h"

namespace machplan::placement {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<double> rotations(const std::string& text) {
  PlacementOptions o;
  parse_rotations(text, o);
  o.validate();
  return o.rotations_deg;
}

std::string refusal(const std::string& text) {
  return test::error_of([&] { rotations(text); });
}

TEST(Rotations, ListsRangesAndAnyAreRead) {
  EXPECT_THAT(rotations("0"), ElementsAre(0));
  EXPECT_THAT(rotations("0,90,180,270"), ElementsAre(0, 90, 180, 270));
  EXPECT_THAT(rotations("0:90:30,180"), ElementsAre(0, 30, 60, 90, 180));
  EXPECT_EQ(rotations("0:360:15").size(), 24u);  // 360 is 0 again
  EXPECT_EQ(rotations("-90:90:0.5").size(), 361u);
  PlacementOptions o;
  parse_rotations("any", o);
  EXPECT_TRUE(o.any_rotation);
}

TEST(Rotations, BadListsAreRefusedNamingTheField) {
  EXPECT_THAT(refusal("nan"), HasSubstr("rotations_deg"));
  EXPECT_THAT(refusal("0,90,360"), HasSubstr("rotation 360 deg repeats 0 deg"));
  EXPECT_THAT(refusal("0:10"), HasSubstr("FROM:TO:STEP"));
  EXPECT_THAT(refusal("10:0:5"), HasSubstr("FROM <= TO and a positive STEP"));
  EXPECT_THAT(refusal("0:360:0"), HasSubstr("positive STEP"));
  EXPECT_THAT(refusal("0:360:0.05"), HasSubstr("at most 3600"));
  EXPECT_THAT(refusal("400"), HasSubstr("within -360 .. 360"));
}

bool better(const PlacementResult& a, const PlacementResult& b) {
  // The search's order: lowest pad, nearest the centre, smallest turn.
  const auto key = [](const PlacementResult& r) {
    return std::make_tuple(r.placement.pad_mm, std::hypot(r.placement.x_mm, r.placement.y_mm),
                           std::abs(std::remainder(r.placement.rotation_deg, 360.0)));
  };
  return key(a) <= key(b);
}

TEST(Rotations, AnyIsNeverWorseThanEachRotationOnItsOwnAndItsClaimIsFree) {
  // The bundled scene on a 90 deg grid of rotations: `any` against the 4 searched one by one
  // (their lowest pads: 57, 57, 50 and 50 mm).
  test::TempDir dir;
  const std::string data = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/hexam-paper/";
  std::ifstream in(data + "scene.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* f : {"machine.yaml", "workpiece.stl", "toolpath.csv"}) text.replace(text.find(f), std::string(f).size(), data + f);
  text.replace(text.find("pad_max_mm: 200"), 15, "pad_max_mm: 200\n  rotation_step_deg: 90");
  const Scene scene = load_scene(dir.write("scene.yaml", text));
  Termination term;
  PlacementOptions any;
  any.any_rotation = true;
  const PlacementResult best = place(scene, any, term);
  ASSERT_TRUE(best.summary.done()) << best.summary.full_report();
  EXPECT_EQ(best.rotations, 4);
  EXPECT_TRUE(best.verified);
  int beaten = 0;
  for (int k = 0; k < 4; ++k) {
    PlacementOptions one;
    one.rotations_deg = {90.0 * k};
    const PlacementResult r = place(scene, one, term);
    if (!r.summary.done()) continue;
    EXPECT_TRUE(better(best, r)) << "rotation " << 90 * k << ": pad " << r.placement.pad_mm << " against " << best.placement.pad_mm;
    beaten += better(best, r) && !better(r, best);
  }
  EXPECT_GT(beaten, 0);  // the rotation matters in this scene
  // The answer is free by a dense re-check, and the claimed interval is certified free at its
  // ends (a dense check there too when the interval has width).
  CheckOptions dense;
  dense.dense = true;
  EXPECT_TRUE(check(scene, best.placement, dense, term).report.free());
  for (const double d : {-best.rotation_tolerance_deg, best.rotation_tolerance_deg}) {
    if (d == 0.0) continue;
    Placement p = best.placement;
    p.rotation_deg += d;
    EXPECT_TRUE(check(scene, p, CheckOptions{}, term).report.free()) << "turned by " << d;
  }
}

}  // namespace
}  // namespace machplan::placement
