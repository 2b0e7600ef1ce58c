// QtPlasmaC materials and program words: the material file reader (engine/motion/materials.h)
// and what make_job does with material changes, material comments, THC and torch switches,
// velocity, hole rules and pierce only (engine/motion/plasma_words.h). Our own inputs.
#include <cmath>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/motion/materials.h"
#include "engine/motion/plasma_words.h"
#include "engine/motion/process_time.h"
#include "engine/programs/gcode.h"

namespace machplan::motion {
namespace {

using ::testing::HasSubstr;

const char* kFile = R"(# two materials
[MATERIAL_NUMBER_7]
NAME               = Steel 2 mm
KERF_WIDTH         = 1.1
THC                = 0
PIERCE_HEIGHT      = 3.2
PIERCE_DELAY       = 0.25
PUDDLE_JUMP_HEIGHT = 50
PUDDLE_JUMP_DELAY  = 0.1
CUT_HEIGHT         = 1.2
CUT_SPEED          = 2700
CUT_AMPS           = 40
CUT_VOLTS          = 105
PAUSE_AT_END       = 0.15
GAS_PRESSURE       = 5
CUT_MODE           = 1

[material_number_2]
pierce_height = 4
pierce_delay = 1
cut_height = 2
cut_speed = 1200
kerf_width =
)";

std::string error_of(const std::string& text, const MaterialReadOptions& o = {}) {
  try {
    read_materials(text, "mats.cfg", o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(MaterialFile, ReadsEveryKeyInMillimetresAndSeconds) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  ASSERT_EQ(t.materials.size(), 2u);
  const CutParameters* a = t.find(7);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->name, "Steel 2 mm");
  EXPECT_DOUBLE_EQ(a->kerf_mm, 1.1);
  EXPECT_FALSE(a->thc);
  EXPECT_DOUBLE_EQ(a->pierce_height_mm, 3.2);
  EXPECT_DOUBLE_EQ(a->pierce_delay_s, 0.25);
  EXPECT_DOUBLE_EQ(a->puddle_jump_height_pct, 50);
  EXPECT_DOUBLE_EQ(a->puddle_jump_delay_s, 0.1);
  EXPECT_DOUBLE_EQ(a->cut_height_mm, 1.2);
  EXPECT_DOUBLE_EQ(a->cut_feed_mm_per_s, 2700.0 / 60.0);
  EXPECT_DOUBLE_EQ(a->cut_amps, 40);
  EXPECT_DOUBLE_EQ(a->cut_volts, 105);
  EXPECT_DOUBLE_EQ(a->pause_at_end_s, 0.15);
  EXPECT_EQ(t.lines[0], 2);
  // Keys in any case; optional keys absent or empty are 0, THC absent stays on.
  const CutParameters* b = t.find(2);
  ASSERT_NE(b, nullptr);
  EXPECT_DOUBLE_EQ(b->kerf_mm, 0.0);
  EXPECT_TRUE(b->thc);
  EXPECT_DOUBLE_EQ(b->cut_feed_mm_per_s, 20.0);
  EXPECT_EQ(t.find(3), nullptr);
  EXPECT_TRUE(t.warnings.empty());
}

TEST(MaterialFile, InchFileScalesLengthsAndFeed) {
  MaterialReadOptions o;
  o.mm_per_unit = 25.4;
  const MaterialTable t = read_materials("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=0.15\nPIERCE_DELAY=0.5\nCUT_HEIGHT=0.06\n"
                                         "CUT_SPEED=100\nKERF_WIDTH=0.05\n",
                                         "in.cfg", o);
  EXPECT_NEAR(t.materials[0].pierce_height_mm, 3.81, 1e-12);
  EXPECT_NEAR(t.materials[0].cut_feed_mm_per_s, 2540.0 / 60.0, 1e-12);
  EXPECT_NEAR(t.materials[0].kerf_mm, 1.27, 1e-12);
  EXPECT_DOUBLE_EQ(t.materials[0].pierce_delay_s, 0.5);  // seconds are not scaled
}

TEST(MaterialFile, UnknownKeysWarnOnce) {
  const MaterialTable t = read_materials("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=3\nPIERCE_DELAY=0\nCUT_HEIGHT=1\n"
                                         "CUT_SPEED=100\nFLAVOUR=1\n[MATERIAL_NUMBER_2]\nPIERCE_HEIGHT=3\nPIERCE_DELAY=0\n"
                                         "CUT_HEIGHT=1\nCUT_SPEED=100\nflavour=2\n",
                                         "m.cfg");
  ASSERT_EQ(t.warnings.size(), 1u);
  EXPECT_THAT(t.warnings[0], HasSubstr("m.cfg:6: key 'FLAVOUR'"));
}

TEST(MaterialFile, BadFilesNameFileAndLine) {
  const std::string ok = "PIERCE_HEIGHT=3\nPIERCE_DELAY=0.5\nCUT_HEIGHT=1\nCUT_SPEED=2000\n";
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=3\nPIERCE_DELAY=0.5\nCUT_HEIGHT=1\n"),
              HasSubstr("mats.cfg:1: material 1 has no CUT_SPEED"));
  EXPECT_THAT(error_of("PIERCE_HEIGHT=3\n"), HasSubstr("mats.cfg:1: key 'PIERCE_HEIGHT' before the first"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\n" + ok + "[MATERIAL_NUMBER_1]\n" + ok), HasSubstr("mats.cfg:6: material 1 is defined twice"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_x]\n" + ok), HasSubstr("mats.cfg:1: material number 'x'"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1000000]\n" + ok), HasSubstr("mats.cfg:1:"));
  EXPECT_THAT(error_of("[TOOL_1]\n" + ok), HasSubstr("mats.cfg:1: '[TOOL_1]' is not a section"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\n" + ok + "CUT_SPEED=1\n"), HasSubstr("mats.cfg:6: CUT_SPEED given twice"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=three\n"), HasSubstr("mats.cfg:2: PIERCE_HEIGHT must be a number"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=-1\n"), HasSubstr("mats.cfg:2: PIERCE_HEIGHT = -1 is out of range"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nPIERCE_HEIGHT=nan\n"), HasSubstr("mats.cfg:2: PIERCE_HEIGHT must be a number"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nCUT_SPEED=0\n"), HasSubstr("mats.cfg:2: CUT_SPEED = 0 must be > 0"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nCUT_SPEED=\n"), HasSubstr("mats.cfg:2: CUT_SPEED has no value"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\nTHC=2\n"), HasSubstr("mats.cfg:2: THC must be 0 (off) or 1 (on)"));
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\njust words\n"), HasSubstr("mats.cfg:2: 'just words' is neither"));
  MaterialReadOptions few;
  few.max_materials = 1;
  EXPECT_THAT(error_of("[MATERIAL_NUMBER_1]\n" + ok + "[MATERIAL_NUMBER_2]\n" + ok, few),
              HasSubstr("mats.cfg:6: more than 1 materials with max_materials"));
}

// A ramp pierce for thick plate: its keys (lengths and speeds in the file's units), and the
// settings that do not fit together refused with the material's line.
TEST(MaterialFile, RampPierceKeysAndTheirRules) {
  const std::string ok = "PIERCE_HEIGHT=6\nPIERCE_DELAY=1.5\nCUT_HEIGHT=2\nCUT_SPEED=1200\n";
  const std::string ramp = "PIERCE_TYPE=2\nPIERCE_MOTION_DELAY=40\nPIERCE_END_HEIGHT=3\nCUT_HEIGHT_DELAY=0.1\n"
                           "GOUGE_SPEED=300\nGOUGE_SPEED_DISTANCE=4\nCREEP_SPEED=600\nCREEP_SPEED_DISTANCE=5\n";
  const MaterialTable t = read_materials("[MATERIAL_NUMBER_5]\n" + ok + ramp, "m.cfg");
  const CutParameters* m = t.find(5);
  ASSERT_NE(m, nullptr);
  EXPECT_TRUE(m->ramp_pierce);
  EXPECT_DOUBLE_EQ(m->pierce_motion_delay_pct, 40);
  EXPECT_DOUBLE_EQ(m->pierce_end_height_mm, 3);
  EXPECT_DOUBLE_EQ(m->cut_height_delay_s, 0.1);
  EXPECT_DOUBLE_EQ(m->gouge_speed_mm_per_s, 5);
  EXPECT_DOUBLE_EQ(m->gouge_distance_mm, 4);
  EXPECT_DOUBLE_EQ(m->creep_speed_mm_per_s, 10);
  EXPECT_DOUBLE_EQ(m->creep_distance_mm, 5);
  MaterialReadOptions inch;
  inch.mm_per_unit = 25.4;
  const std::string in_inch = "[MATERIAL_NUMBER_5]\nPIERCE_HEIGHT=0.2\nPIERCE_DELAY=1\nCUT_HEIGHT=0.1\nCUT_SPEED=60\n"
                              "PIERCE_TYPE=2\nGOUGE_SPEED=10\nGOUGE_SPEED_DISTANCE=0.25\n";
  const MaterialTable ti = read_materials(in_inch, "m.cfg", inch);
  const CutParameters* mi = ti.find(5);
  ASSERT_NE(mi, nullptr);
  EXPECT_NEAR(mi->gouge_distance_mm, 6.35, 1e-9);
  EXPECT_NEAR(mi->gouge_speed_mm_per_s, 254.0 / 60.0, 1e-9);
  EXPECT_FALSE(read_materials("[MATERIAL_NUMBER_5]\n" + ok + "PIERCE_TYPE=0\n", "m.cfg").find(5)->ramp_pierce);
  const std::string head = "[MATERIAL_NUMBER_5]\n" + ok;
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=1\n"), HasSubstr("mats.cfg:6: PIERCE_TYPE = 1 (a wiggle pierce) is not supported"));
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=3\n"), HasSubstr("mats.cfg:6: PIERCE_TYPE must be 0 (standing) or 2 (ramp)"));
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=2\nGOUGE_SPEED_DISTANCE=4\n"),
              HasSubstr("mats.cfg:1: material 5: GOUGE_SPEED_DISTANCE needs GOUGE_SPEED > 0"));
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=2\nCREEP_SPEED=2000\nCREEP_SPEED_DISTANCE=4\n"),
              HasSubstr("mats.cfg:1: material 5: CREEP_SPEED is above CUT_SPEED"));
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=2\nPUDDLE_JUMP_HEIGHT=150\n"),
              HasSubstr("mats.cfg:1: material 5: a ramp pierce and a puddle jump: choose one"));
  EXPECT_THAT(error_of(head + "GOUGE_SPEED=300\nGOUGE_SPEED_DISTANCE=4\n"),
              HasSubstr("mats.cfg:1: material 5: ramp pierce settings without PIERCE_TYPE = 2"));
  EXPECT_THAT(error_of(head + "PIERCE_TYPE=2\nPIERCE_MOTION_DELAY=120\n"), HasSubstr("mats.cfg:7: PIERCE_MOTION_DELAY = 120 is out of range"));
  // In a material comment, by their short keys.
  const MaterialComment c =
      read_material_comment("o=0, ph=6, pd=1.5, ch=2, fr=1200, pt=2, md=40, eh=3, hd=0.1, gs=300, gd=4, cs=600, cd=5", "p.ngc", 3, 1.0);
  EXPECT_TRUE(c.material.ramp_pierce);
  EXPECT_DOUBLE_EQ(c.material.creep_speed_mm_per_s, 10);
  try {
    read_material_comment("o=0, ph=6, pd=1.5, ch=2, fr=1200, pt=2, gd=4", "p.ngc", 3, 1.0);
    ADD_FAILURE() << "a gouge distance without its speed was accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("p.ngc:3: material comment: gd needs gs > 0"));
  }
}

TEST(MaterialComment, ReadsTemporaryAndNumberedMaterials) {
  const MaterialComment t = read_material_comment("o=0, na=Plate 6, ph=3.1, pd=0.4, ch=1.5, fr=2100, kw=1.6, th=0, cv=120, pe=0.2, "
                                                  "jh=40, jd=0.3, mt=6, gp=5, cm=1",
                                                  "p.ngc", 4);
  EXPECT_EQ(t.option, 0);
  EXPECT_EQ(t.material.number, 0);
  EXPECT_EQ(t.material.name, "Plate 6");
  EXPECT_DOUBLE_EQ(t.material.cut_feed_mm_per_s, 35.0);
  EXPECT_DOUBLE_EQ(t.material.kerf_mm, 1.6);
  EXPECT_FALSE(t.material.thc);
  EXPECT_DOUBLE_EQ(t.material.puddle_jump_height_pct, 40);
  const MaterialComment n = read_material_comment("o=2,nu=9,ph=0.1,pd=0,ch=0.05,fr=80", "p.ngc", 4, 25.4);
  EXPECT_EQ(n.option, 2);
  EXPECT_EQ(n.material.number, 9);
  EXPECT_NEAR(n.material.cut_feed_mm_per_s, 80 * 25.4 / 60, 1e-12);
  const auto bad = [](const std::string& text) {
    try {
      read_material_comment(text, "p.ngc", 4);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(bad("o=0, ph=3, pd=0.1, ch=1"), HasSubstr("p.ngc:4: material comment has no fr"));
  EXPECT_THAT(bad("o=1, ph=3, pd=0.1, ch=1, fr=100"), HasSubstr("p.ngc:4: material comment: o=1 and o=2 need nu="));
  EXPECT_THAT(bad("o=5, ph=3"), HasSubstr("o must be 0, 1 or 2"));
  EXPECT_THAT(bad("o=0, zz=3"), HasSubstr("unknown key 'zz'"));
  EXPECT_THAT(bad("o=0, ph"), HasSubstr("'ph' is not key=value"));
}

// Reads `gcode` as the run does (hole-rule parameters and material comments reported, the
// cut feed parameter as the marker) and makes its job.
constexpr double kMarker = 987654.321;
Job plasma_job(const std::string& gcode, const MaterialTable* table = nullptr, int default_material = -1,
               double machine_feed_mm_per_s = 0.0) {
  GcodeOptions g;
  g.report_magic_comments = true;
  g.reported_params = plasma_reported_params();
  g.params["_hal[plasmac.cut-feed-rate]"] = kMarker;
  g.spindle_count = 3;
  JobOptions jo;
  jo.materials = table;
  jo.default_material = default_material;
  jo.material_feed_marker_mm_per_min = kMarker;
  jo.machine_cut_feed_mm_per_s = machine_feed_mm_per_s;
  return make_job(read_gcode(gcode, "plasma.ngc", g), jo);
}

std::vector<const Step*> steps_of(const Job& j, Step::Kind k) {
  std::vector<const Step*> out;
  for (const Step& s : j.steps)
    if (s.kind == k) out.push_back(&s);
  return out;
}

TEST(PlasmaWords, MaterialChangesSelectEachCutsMaterialAndFeed) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  const Job j = plasma_job("G21\nM190 P7\nM66 P3 L3 Q1\nF#<_hal[plasmac.cut-feed-rate]>\nG0 X10 Y10\nM3 $0 S1\nG1 X50\nM5 $0\n"
                           "M190 P2\nM66 P3 L3 Q1\nF#<_hal[plasmac.cut-feed-rate]>\nG0 Y30\nM3 $0 S1\nG1 X10\nM5 $0\n"
                           "M190 P-1\nG0 Y50\nM3 $0 S1\nG1 X50 F600\nM5 $0\nM2\n",
                           &t);
  const auto on = steps_of(j, Step::Kind::torch_on);
  ASSERT_EQ(on.size(), 3u);
  ASSERT_EQ(j.materials.size(), 2u);
  EXPECT_EQ(j.materials[static_cast<std::size_t>(on[0]->material)].number, 7);
  EXPECT_EQ(j.materials[static_cast<std::size_t>(on[1]->material)].number, 2);
  EXPECT_EQ(on[2]->material, -1);  // P-1 with no default: the machine's settings
  std::vector<double> cut_feeds;
  for (const Stretch& s : j.stretches)
    if (s.cutting) cut_feeds.push_back(s.feed_mm_per_s.front());
  ASSERT_EQ(cut_feeds.size(), 3u);
  EXPECT_DOUBLE_EQ(cut_feeds[0], 45.0);   // CUT_SPEED 2700 mm/min
  EXPECT_DOUBLE_EQ(cut_feeds[1], 20.0);   // 1200 mm/min
  EXPECT_DOUBLE_EQ(cut_feeds[2], 10.0);   // F600 written: kept
}

TEST(PlasmaWords, DefaultMaterialAndMachineFeed) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  const Job j = plasma_job("F#<_hal[plasmac.cut-feed-rate]>\nG0 X10\nM3 $0 S1\nG1 X50\nM5 $0\nM2\n", &t, 2);
  ASSERT_EQ(j.materials.size(), 1u);
  EXPECT_EQ(j.materials[0].number, 2);
  EXPECT_EQ(steps_of(j, Step::Kind::torch_on)[0]->material, 0);
  // No material in force: the machine's value; none at all: refused naming the line.
  const Job m = plasma_job("F#<_hal[plasmac.cut-feed-rate]>\nG0 X10\nM3 $0 S1\nG1 X50\nM5 $0\nM2\n", nullptr, -1, 50.0);
  EXPECT_DOUBLE_EQ(m.stretches[1].feed_mm_per_s[0], 50.0);
  EXPECT_TRUE(m.materials.empty());
  try {
    plasma_job("F#<_hal[plasmac.cut-feed-rate]>\nG0 X10\nM3 $0 S1\nG1 X50\nM5 $0\nM2\n");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("plasma.ngc:4: F#<_hal[plasmac.cut-feed-rate]>"));
  }
}

TEST(PlasmaWords, UnknownMaterialIsRefusedNamingTheLine) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  try {
    plasma_job("G0 X1\nM190 P5\nM2\n", &t);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("plasma.ngc:2: M190 P5: material 5 is not in mats.cfg"));
  }
  EXPECT_THROW(plasma_job("G0 X1\nM190 P1\nM2\n"), InputError);  // no file at all
}

TEST(PlasmaWords, TemporaryMaterialsAndInchComments) {
  const Job j = plasma_job("G21\n(o=0, na=A, ph=3, pd=0.1, ch=1, fr=1800, kw=0.9)\nF#<_hal[plasmac.cut-feed-rate]>\nG0 X10\n"
                           "M3 $0 S1\nG1 X50\nM5 $0\n(o=0, ph=3, pd=0.2, ch=1, fr=2400)\nG0 Y20\nM3 $0 S1\nG1 X10\nM5 $0\n"
                           "G20\n(o=0, ph=0.1, pd=0.2, ch=0.04, fr=100)\nF#<_hal[plasmac.cut-feed-rate]>\nG0 Y2\nM3 $0 S1\n"
                           "G1 X1\nM5 $0\nM2\n");
  ASSERT_EQ(j.materials.size(), 3u);
  EXPECT_EQ(j.materials[0].name, "A");
  EXPECT_DOUBLE_EQ(j.materials[0].kerf_mm, 0.9);
  const auto on = steps_of(j, Step::Kind::torch_on);
  EXPECT_EQ(on[0]->material, 0);
  EXPECT_EQ(on[1]->material, 1);
  EXPECT_EQ(on[2]->material, 2);
  std::vector<double> feeds;
  for (const Stretch& s : j.stretches)
    if (s.cutting) feeds.push_back(s.feed_mm_per_s.front());
  EXPECT_DOUBLE_EQ(feeds[0], 30.0);
  EXPECT_DOUBLE_EQ(feeds[1], 40.0);
  EXPECT_NEAR(feeds[2], 100 * 25.4 / 60, 1e-9);  // inch comment, F read under G20
  EXPECT_NEAR(j.materials[2].pierce_height_mm, 2.54, 1e-12);
}

TEST(PlasmaWords, OnlyTheMaterialsCutsUseJoinTheJob) {
  const Job j = plasma_job("(o=0, na=unused, ph=3, pd=0.1, ch=1, fr=1800)\n(o=0, na=used, ph=3, pd=0.1, ch=1, fr=2400)\n"
                           "G0 X10\nM3 $0 S1\nG1 X20 F100\nM62 P3\nG1 X25\nM3 $0 S1\nG1 X30\nM5 $0\nM2\n");
  ASSERT_EQ(j.materials.size(), 1u);
  EXPECT_EQ(j.materials[0].name, "used");
  // The torch disabled by M62 P3 and lit again by an M3 without an M5 between: that M3's cut
  // ends with its own M5.
  EXPECT_EQ(steps_of(j, Step::Kind::torch_on).size(), 2u);
  EXPECT_EQ(steps_of(j, Step::Kind::torch_off).size(), 2u);
  EXPECT_EQ(j.steps.back().kind, Step::Kind::torch_off);
}

TEST(PlasmaWords, NumberedCommentsAddOrReplaceForThisProgram) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  const Job j = plasma_job("(o=1, nu=7, ph=9, pd=9, ch=9, fr=100)\n(o=2, nu=2, ph=3, pd=0.1, ch=1, fr=3000)\n"
                           "(o=1, nu=11, ph=3, pd=0.1, ch=1, fr=600)\nF#<_hal[plasmac.cut-feed-rate]>\n"
                           "M190 P7\nG0 X10\nM3 $0 S1\nG1 X20\nM5 $0\nM190 P2\nM3 $0 S1\nG1 X30\nM5 $0\n"
                           "M190 P11\nM3 $0 S1\nG1 X40\nM5 $0\nM2\n",
                           &t);
  std::vector<double> feeds;
  for (const Stretch& s : j.stretches)
    if (s.cutting) feeds.push_back(s.feed_mm_per_s.front() * 60.0);
  ASSERT_EQ(feeds.size(), 3u);
  EXPECT_NEAR(feeds[0], 2700, 1e-9);  // o=1 leaves an existing material alone
  EXPECT_NEAR(feeds[1], 3000, 1e-9);  // o=2 replaces it
  EXPECT_NEAR(feeds[2], 600, 1e-9);   // o=1 adds a new one
}

TEST(PlasmaWords, ThcSwitchesMarkSegmentsAndVelocityScalesFeeds) {
  const Job j = plasma_job("G0 X0 Y0\nM3 $0 S1\nG1 X10 F1200\nM62 P2\nG1 X20\nG1 X30\nM63 P2\nG1 X40\nM67 E3 Q50\nG1 X50\n"
                           "M67 E3 Q0\nG1 X60\nM5 $0\nG0 Y10\nM3 $0 S1\nG1 X0\nM5 $0\nM2\n");
  const Stretch* cut = nullptr;
  for (const Stretch& s : j.stretches)
    if (s.cutting && !cut) cut = &s;
  ASSERT_NE(cut, nullptr);
  ASSERT_EQ(cut->thc_off.size(), cut->segments.size());
  EXPECT_EQ(std::vector<int>(cut->thc_off.begin(), cut->thc_off.end()), (std::vector<int>{0, 1, 1, 0, 0, 0}));
  EXPECT_EQ(cut->feed_mm_per_s, (std::vector<double>{20, 20, 20, 20, 10, 20}));
  EXPECT_TRUE(j.stretches.back().thc_off.empty());  // THC never held off there
}

TEST(PlasmaWords, TorchDisableEndsTheCutWhereItStands) {
  const Job j = plasma_job("G0 X1 Y0\nM3 $0 S1\nG1 X10 F1200\nM62 P3\nG1 X14\nM63 P3\nM5 $0\nG0 X0\nM2\n");
  EXPECT_EQ(steps_of(j, Step::Kind::torch_off).size(), 1u);
  ASSERT_GE(j.stretches.size(), 3u);
  EXPECT_TRUE(j.stretches[1].cutting);
  EXPECT_FALSE(j.stretches[2].cutting);
  EXPECT_FALSE(j.stretches[2].rapid);
  EXPECT_DOUBLE_EQ(j.stretches[2].segments.back().end.x(), 14.0);
}

double cut_length(const Job& j, bool cutting) {
  double l = 0;
  for (const Stretch& s : j.stretches)
    if (s.cutting == cutting && !s.rapid)
      for (const Segment& g : s.segments) l += length(g);
  return l;
}

TEST(PlasmaWords, HoleRulesSlowSmallHolesAndArcsAndOvercut) {
  const std::string body = "G0 X10 Y0\nM3 $0 S1\nG3 X10 Y0 I-5 J0 F1000\nM5 $0\nG0 X100 Y0\nM3 $0 S1\n"
                           "G3 X80 Y0 I-10 J0\nM5 $0\nG0 X200 Y0\nM3 $0 S1\nG3 X200 Y0 I-20 J0\nM5 $0\nM2\n";
  const auto feeds = [](const Job& j) {
    std::vector<double> f;
    for (const Stretch& s : j.stretches)
      if (s.cutting) f.push_back(std::round(s.feed_mm_per_s.front() * 60.0 * 1e6) / 1e6);
    return f;
  };
  // Off: as programmed.
  EXPECT_EQ(feeds(plasma_job(body)), (std::vector<double>{1000, 1000, 1000}));
  // 1: the 10 mm hole at 60 %; the 20 mm half circle (an arc) and the 40 mm hole untouched.
  EXPECT_EQ(feeds(plasma_job("#<holes> = 1\n" + body)), (std::vector<double>{600, 1000, 1000}));
  // 3: arcs too; diameter and velocity set.
  EXPECT_EQ(feeds(plasma_job("#<holes> = 3\n#<h_diameter> = 50\n#<h_velocity> = 40\n" + body)),
            (std::vector<double>{400, 400, 400}));
  // 2: over cut after each small hole with the torch off, 4 mm by default, then 6.5 mm.
  const Job two = plasma_job("#<holes> = 2\n" + body);
  EXPECT_NEAR(cut_length(two, false), 4.0, 1e-9);
  EXPECT_EQ(steps_of(two, Step::Kind::torch_off).size(), 3u);  // no second torch_off at the M5
  const Job longer = plasma_job("#<holes> = 4\n#<oclength> = 6.5\n" + body);
  EXPECT_NEAR(cut_length(longer, false), 6.5, 1e-9);
  // The over cut follows the hole's circle: it ends 6.5 mm of arc past the start.
  const Stretch* over = nullptr;
  for (const Stretch& s : longer.stretches)
    if (!s.cutting && !s.rapid) over = &s;
  ASSERT_NE(over, nullptr);
  EXPECT_NEAR((over->segments.back().end - Eigen::Vector2d(5, 0)).norm(), 5.0, 1e-9);
  EXPECT_NEAR(over->feed_mm_per_s.front() * 60.0, 600.0, 1e-9);  // at the hole's feed
  // Inch lengths: h_diameter 0.5 in = 12.7 mm still takes the 10 mm hole.
  EXPECT_EQ(feeds(plasma_job("G20\n#<holes> = 1\n#<h_diameter> = 0.5\nG21\n" + body)), (std::vector<double>{600, 1000, 1000}));
  EXPECT_THROW(plasma_job("#<holes> = 7\n" + body), InputError);
}

TEST(PlasmaWords, PierceOnlyPiercesEachCutAndSkipsItsMoves) {
  const Job j = plasma_job("#<pierce-only> = 1\nG0 X10 Y0\nM3 $0 S1\nG1 X50 F1000\nG1 Y20\nM5 $0\nG0 X100 Y0\nM3 $0 S1\n"
                           "G1 X150\nM5 $0\nG0 X0 Y0\nM2\n");
  EXPECT_EQ(steps_of(j, Step::Kind::torch_on).size(), 2u);
  EXPECT_EQ(steps_of(j, Step::Kind::torch_off).size(), 2u);
  EXPECT_DOUBLE_EQ(cut_length(j, true), 0.0);
  // The rapid after the first pierce leaves from the pierce point.
  const Stretch& second_rapid = j.stretches[1];
  ASSERT_TRUE(second_rapid.rapid);
  EXPECT_DOUBLE_EQ(second_rapid.segments.front().start.x(), 10.0);
  EXPECT_DOUBLE_EQ(second_rapid.segments.front().start.y(), 0.0);
  // Each torch_on is followed directly by its torch_off.
  for (std::size_t i = 0; i + 1 < j.steps.size(); ++i)
    if (j.steps[i].kind == Step::Kind::torch_on) EXPECT_EQ(j.steps[i + 1].kind, Step::Kind::torch_off);
}

TEST(PlasmaWords, TheReaderReportsOnlyWhenAsked) {
  const Program plain = read_gcode("#<holes> = 2\n(o=0, ph=3, pd=0, ch=1, fr=100)\nG0 X1\nM2\n", "p.ngc");
  EXPECT_TRUE(plain.events.empty());
  GcodeOptions g;
  g.report_magic_comments = true;
  g.reported_params = {"holes"};
  const Program p = read_gcode("#<holes> = 2\n(o=0, ph=3, pd=0, ch=1, fr=100)\nG0 X1\nM2\n", "p.ngc", g);
  ASSERT_EQ(p.events.size(), 2u);
  EXPECT_EQ(p.events[0].kind, ProgramEvent::Kind::parameter);
  EXPECT_EQ(p.events[0].text, "holes");
  EXPECT_DOUBLE_EQ(p.events[0].value, 2.0);
  EXPECT_EQ(p.events[1].kind, ProgramEvent::Kind::magic_comment);
  EXPECT_EQ(p.events[1].text, "o=0, ph=3, pd=0, ch=1, fr=100");
  EXPECT_TRUE(plasma_word(p.events[0]));
}

TEST(PlasmaWords, ProcessTimeTakesEachCutsMaterialWhenAsked) {
  const MaterialTable t = read_materials(kFile, "mats.cfg");
  const Job j = plasma_job("M190 P7\nG0 X10\nM3 $0 S1\nG1 X50 F1000\nM5 $0\nM190 P2\nG0 Y10\nM3 $0 S1\nG1 X10\nM5 $0\nM2\n", &t);
  TorchTimes times;
  times.height = TorchTimes::Height{10.0, 4.0, 2.0, 10.0, 0.0};
  times.pierce_s = 2.0;
  // Machine settings: 10 -> 4 -> 2 mm (0.8 s), 2 s pierce, 2 -> 10 mm (0.8 s), twice.
  EXPECT_NEAR(process_time_s(j, times), 2 * (0.8 + 2.0 + 0.8), 1e-12);
  times.use_materials = true;
  // Material 7: 10 -> 3.2 (0.68 s), pierce 0.25 s + jump delay 0.1 s, 3.2 -> 1.6 (jump 50 %) -> 1.2
  // (0.2 s), pause at end 0.15 s, 1.2 -> 10 (0.88 s). Material 2: 10 -> 4 -> 2 (0.8 s), 1 s, 2 -> 10 (0.8 s).
  EXPECT_NEAR(process_time_s(j, times), (0.68 + 0.35 + 0.2 + 0.15 + 0.88) + (0.8 + 1.0 + 0.8), 1e-12);
  // A torch_off with no cut lit (an M6 before the first cut, a second M5) finds the torch up.
  times.use_materials = false;
  const Job twice = plasma_job("M6 T0\nG0 X10\nM3 $0 S1\nG1 X50 F1000\nM5 $0\nM5 $-1\nM2\n");
  EXPECT_EQ(steps_of(twice, Step::Kind::torch_off).size(), 3u);
  EXPECT_NEAR(process_time_s(twice, times), 0.8 + 2.0 + 0.8, 1e-12);
}

}  // namespace
}  // namespace machplan::motion
