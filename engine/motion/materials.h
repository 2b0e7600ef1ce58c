// Plasma materials as QtPlasmaC (LinuxCNC's plasma configuration) keeps them: the material file
// and the material comments of a program, read into CutParameters (engine/motion/job.h).
//
// The material file (`<machine>_material.cfg`) is an INI file of sections:
//
//   [MATERIAL_NUMBER_3]
//   NAME               = Mild steel 3 mm 45 A
//   KERF_WIDTH         = 1.5
//   THC                = 1
//   PIERCE_HEIGHT      = 3.8
//   PIERCE_DELAY       = 0.4
//   PUDDLE_JUMP_HEIGHT = 0
//   PUDDLE_JUMP_DELAY  = 0
//   CUT_HEIGHT         = 1.5
//   CUT_SPEED          = 2600
//   CUT_AMPS           = 45
//   CUT_VOLTS          = 118
//   PAUSE_AT_END       = 0
//   GAS_PRESSURE       = 0
//   CUT_MODE           = 1
//
//   * PIERCE_HEIGHT, PIERCE_DELAY, CUT_HEIGHT and CUT_SPEED are mandatory; a section without
//     one of them is refused naming the section's line and the key.
//   * KERF_WIDTH, PUDDLE_JUMP_HEIGHT, PUDDLE_JUMP_DELAY, CUT_AMPS, CUT_VOLTS, PAUSE_AT_END are
//     optional: absent or with no value they are 0, as in QtPlasmaC. THC absent or empty leaves
//     THC on (the machine's THC decides); THC = 0 turns it off for the material.
//   * A ramp pierce for thick plate (machplan's, after a plasmac extension's names; QtPlasmaC
//     itself pierces standing): PIERCE_TYPE = 2 (0: standing, the default; 1, a wiggle, is
//     refused), PIERCE_MOTION_DELAY (% of the pierce delay before the torch moves),
//     PIERCE_END_HEIGHT (the height at the end of the delay; 0: the cut height),
//     CUT_HEIGHT_DELAY (s there before cut height), GOUGE_SPEED and CREEP_SPEED (per minute,
//     at most CUT_SPEED) with GOUGE_SPEED_DISTANCE and CREEP_SPEED_DISTANCE: the first stretch
//     of the cut at each speed (CutParameters). Refused: a distance without its speed, a ramp
//     beside a puddle jump, ramp settings without PIERCE_TYPE = 2. Material comments take them
//     as pt, md, eh, hd, gs, gd, cs, cd.
//   * NAME is free text (at most 100 characters); GAS_PRESSURE, CUT_MODE and THICKNESS (used by
//     QtPlasmaC for PowerMax communication and display) are accepted and ignored. Any other key
//     is ignored with one warning (MaterialTable::warnings) naming its first line.
//   * Units: the file is in the machine's units: lengths (heights, kerf) and CUT_SPEED (per
//     minute) are multiplied by MaterialReadOptions::mm_per_unit (1 for a metric machine, 25.4
//     for an imperial one); CUT_SPEED becomes mm/s. Delays are seconds, PUDDLE_JUMP_HEIGHT a
//     percentage of the pierce height, CUT_AMPS amperes, CUT_VOLTS volts.
//   * Blank lines and lines starting with '#' or ';' are comments. Keys are matched in any
//     case; blanks around '=' are ignored. Material numbers need not be consecutive nor in
//     order; 0 .. 999999 (QtPlasmaC keeps 1000000 and above for temporary materials).
//
// Refused, as InputError "FILE:LINE: message": a key outside a section, a line that is neither
// a section, a key = value nor a comment, a section header that is not MATERIAL_NUMBER_n, a
// number repeated, a key repeated within a section, a value that is not a number, a number out
// of its range (heights and kerf 0 .. 100 mm, delays 0 .. 60 s, CUT_SPEED > 0 and at most
// 100 000 mm/min, THC 0 or 1, puddle jump 0 .. 200 %, amps and volts 0 .. 1000), more than
// max_materials sections.
//
// Material comments (QtPlasmaC's "magic comments") carry a material inside a program:
//
//   (o=0, na=Steel 3mm, ph=3.1, pd=0.1, ch=0.75, fr=3000, kw=0.5, th=1, cv=110, pe=0.1, jh=0, jd=0)
//
// o=0 makes a temporary material for the cuts that follow (CutParameters::number 0); o=1 and
// o=2 add or overwrite a material of the file (number nu=), for the cuts of this program only
// (the file is never written). Keys: na name, ph pierce height, pd pierce delay, ch cut height,
// fr feed (all four mandatory), kw kerf, th THC, ca amps, cv volts, pe pause at end, jh / jd
// puddle jump height / delay; mt (thickness), gp, cm accepted and ignored. Values are in the
// program's units (mm_per_unit: 25.4 under G20).
//
// Thread safety: pure functions.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "engine/motion/job.h"

namespace machplan::motion {

struct MaterialReadOptions {
  // Millimetres per unit of the file's lengths and feeds: 1 (metric machine) or 25.4 (inch).
  double mm_per_unit = 1.0;
  // Sections accepted; a larger file is refused (bounds what any input can take).
  std::size_t max_materials = 10'000;

  // Throws InputError naming the field.
  void validate() const;
};

struct MaterialTable {
  std::string source;                       // file name, for messages
  std::vector<CutParameters> materials;     // in file order
  std::vector<int> lines;                   // the line of each material's section header
  std::vector<std::string> warnings;        // keys ignored, one line each

  // The material numbered `number`, or null.
  const CutParameters* find(int number) const;
};

// Reads a material file's text. `source` names it in messages.
MaterialTable read_materials(std::string_view text, const std::string& source, const MaterialReadOptions& options = {});
// Reads the file at `path` (engine/common/text_file.h limits).
MaterialTable read_materials_file(const std::string& path, const MaterialReadOptions& options = {});

// A material comment's text (inside the parentheses, starting "o="), read as above.
struct MaterialComment {
  int option = 0;  // o=: 0 temporary, 1 add, 2 add or overwrite
  CutParameters material;  // number: nu= (0 for option 0)
};
// Throws InputError(source, line, ...) for a malformed comment or a value out of range.
MaterialComment read_material_comment(std::string_view text, const std::string& source, int line, double mm_per_unit = 1.0);

}  // namespace machplan::motion
