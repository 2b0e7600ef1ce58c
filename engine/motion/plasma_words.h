// The words of QtPlasmaC programs that make_job (engine/motion/make_job.h) acts on, followed
// through a program's events as its moves are walked:
//
//   * Materials: M190 Pn selects material n of the material file (JobOptions::materials),
//     P-1 and P0 the default (JobOptions::default_material, else the machine's settings:
//     QtPlasmaC's material 0 lives in its settings, not in the file; a material 0 the file or
//     the program defines is taken as it is); the M66
//     that waits for the change (M66 P3 L3 Q1) is its confirmation and takes no time here.
//     A material comment "(o=0, ...)" makes a temporary material and selects it; "(o=1, nu=n,
//     ...)" adds material n unless the file has it, "(o=2, nu=n, ...)" adds or replaces it,
//     for this program only (engine/motion/materials.h). Each torch_on Step carries the
//     material in force (an index into Job::materials, which holds those the cuts use).
//   * Feeds: F#<_hal[plasmac.cut-feed-rate]> is QtPlasmaC's way of saying "the material's
//     cut feed". The run reads that parameter as JobOptions::material_feed_marker_mm_per_min
//     (a value no program writes), and every move whose F is the marker gets the CUT_SPEED of
//     the material in force, or JobOptions::machine_cut_feed_mm_per_s when none is (an
//     InputError naming the line when that is 0 too). A feed written as a number is kept:
//     the material's CUT_SPEED replaces only the feeds that ask for it. (A line or arc with no F
//     at all is refused by the reader, as LinuxCNC refuses it: QtPlasmaC programs ask for the
//     material's feed through the parameter.)
//     M67 / M68 E3 Qp run the feed moves that follow at p % of their feed (p <= 0 or >= 100:
//     100 %), QtPlasmaC's velocity reduction.
//   * THC: M62 / M64 P2 hold torch height control off for the segments that follow,
//     M63 / M65 P2 let it act again (Stretch::thc_off); a material with THC = 0 holds it off
//     for its cuts (the executor reads CutParameters::thc).
//   * Torch disable: M62 / M64 P3 turn the torch off where they stand (the moves up to the
//     next M5 run with the torch off: a hand-written over cut); that M5 adds no second
//     torch_off.
//   * Hole rules, from the named parameters #<holes> (0 off, 1 holes slowed, 2 holes slowed
//     and over cut, 3 holes and arcs slowed, 4 holes and arcs slowed and holes over cut),
//     #<h_diameter> (32 mm), #<h_velocity> (60 %), #<oclength> (4 mm), lengths in the
//     program's units when set: a hole is an arc that ends where it starts (a full circle)
//     and its diameter is twice its radius as programmed. A hole (modes 1-4) or an arc (modes 3,
//     4) of diameter at most h_diameter runs at h_velocity % of its feed; in modes 2 and 4 a
//     hole cut with the torch on is followed by a torch_off and a move along the same circle
//     for oclength (at most one turn) with the torch off (the over cut), and the program's M5
//     after it adds no second torch_off.
//   * Pierce only (#<pierce-only> = 1): each M3 pierces (torch_on, then torch_off) and the
//     cutting moves up to its M5 are left out; the next move starts at the pierce point.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "engine/motion/job.h"
#include "engine/programs/program.h"

namespace machplan::motion {

struct JobOptions;

// The named parameters the G-code reader must report for the hole rules and pierce only
// (GcodeOptions::reported_params).
std::vector<std::string> plasma_reported_params();

// True when make_job acts on `e` (a material change, its wait, a THC or torch switch, a
// velocity, a hole-rule parameter, a material comment); such words are not "ignored".
bool plasma_word(const ProgramEvent& e);

// State of the plasma words while make_job walks a program (see the file comment).
class PlasmaWords {
 public:
  PlasmaWords(const Program& program, const JobOptions& options, Job& job);

  // Acts on the events that come before move `index` (program.moves.size(): all the rest).
  void before_move(std::size_t index);
  // The Job::materials index for a torch_on now (-1: the machine's settings).
  int torch_on_material();
  // The feed of line or arc `m` (starting at `from`), mm/s, the rules above applied.
  double feed_mm_per_s(const Move& m, const Eigen::Vector2d& from) const;
  bool thc_off() const { return thc_off_; }
  // M62 / M64 P3 seen since the last call.
  bool take_torch_disable();
  // The over cut after `m` (a hole just cut with the torch on), mm of path; 0 for none.
  double overcut_mm(const Move& m, const Eigen::Vector2d& from) const;
  bool pierce_only() const { return pierce_only_; }

 private:
  void event(const ProgramEvent& e);
  void select(int number, int line);
  const CutParameters* in_force() const;
  // Diameter of arc `m` from `from` when it is a hole or (arcs too) an arc the rules slow, else 0.
  double slowed_diameter(const Move& m, const Eigen::Vector2d& from, bool holes_only) const;

  const Program& program_;
  const JobOptions& options_;
  Job& job_;
  std::size_t next_event_ = 0;
  std::map<int, CutParameters> edited_;   // o=1 / o=2 materials of this program
  std::map<int, int> used_;               // material number -> Job::materials index
  int current_ = -1;                      // material number in force (-1: the machine's)
  CutParameters temporary_material_;      // the temporary material in force (current_ kTemporary)
  int temporary_ = -1;                    // its Job::materials index once a cut used it
  bool thc_off_ = false;
  bool torch_disable_ = false;
  double velocity_pct_ = 100.0;
  int holes_ = 0;
  double hole_diameter_mm_ = 32.0, hole_velocity_pct_ = 60.0, overcut_length_mm_ = 4.0;
  bool pierce_only_ = false;
};

}  // namespace machplan::motion
