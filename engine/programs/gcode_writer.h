// Writing a Program back as G-code that LinuxCNC's rs274 (and read_gcode) reads to the same
// moves: what `machplan order` writes after reordering a program's cuts.
//
// The text is RS274NGC in millimetres and machine coordinates (the program's work offsets
// were applied when it was read, so none is written): G21 G90 G91.1 G94 first, then one line
// per move and per kept event, each with a comment naming the source line it came from
// ("(from line 12)" when it differs from the previous one). Moves:
//   rapid      G0 X Y [Z]            (Z when it changes)
//   line       G1 X Y [Z] [F]        (F when it changes, mm/min)
//   arc        G2 / G3 X Y [Z] I J   (or K I, J K in the XZ, YZ planes, with G17 / G18 / G19
//                                    when the plane changes; incremental centre; P n for
//                                    n - 1 extra turns)
//   dwell      G4 P seconds
//   torch_on   [$n] M3 S speed       torch_off  [$n] M5
// and the path mode (G64 [P], G61, G61.1) when it changes. Events, before the move they
// preceded: T, M61 Q (for a tool change: the M6 of the source stopped the spindle, which the
// torch_off before it already says), G43 H / G49, M7 / M8 / M9, M48-M53 [P], M62-M65 P,
// M66 P L Q, M67 / M68 E Q, M100-M199 P Q, M0 / M1; a GRBL controller command becomes a
// comment (rs274 reads no '$' line). The program ends with M2.
//
// A feed of kMaterialCutFeed is written F#<_hal[plasmac.cut-feed-rate]>, QtPlasmaC's
// material feed.
//
// The grbl dialect writes what GRBL 1.1 reads to the same moves: G21 G90 G94 first (GRBL's
// arc centres are always incremental), no path modes (GRBL has only G61), and a controller
// command as its '$' line. What GRBL has no word for (tool changes, tool length offsets,
// M48-M53, M62-M68, user M codes, named parameters, arcs of several turns, $n spindles, the
// material feed) throws InputError naming the program and line.
//
// Numbers are written with 6 decimals at most (trailing zeros dropped): 1 nm in mm, far below
// the 1 um to which the conformance test compares moves.
//
// Thread safety: a pure function.
#pragma once

#include <string>

#include "engine/programs/program.h"

namespace machplan {

// `header` lines are written as comments at the top (each line in parentheses). `dialect`:
// linuxcnc or grbl (automatic is taken as linuxcnc).
std::string write_gcode(const Program& program, const std::string& header = "",
                        GcodeDialect dialect = GcodeDialect::linuxcnc);

}  // namespace machplan
