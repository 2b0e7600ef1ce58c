// A nesting job file (`machplan nest JOB.yaml`):
//
//   sheets:
//     - {outline: remnant.dxf, margin_mm: 10}                        # a remnant, filled first
//     - {width_mm: 2500, height_mm: 1250, count: 2, margin_mm: 10}   # x along width_mm
//   spacing_mm: 6
//   parts:
//     - {file: bracket.dxf, quantity: 12, rotations: any, mirror: false, priority: 1}
//     - {file: gusset.dxf, quantity: 6, rotations: [0, 90, 180, 270], split: false}
//
// Sheets are filled in the order given (count: that many alike, default 1; margin_mm default
// 10). spacing_mm defaults to 6 here (`machplan nest` makes it the kerf plus the clearance when
// the job's program gives a kerf). A part's file is a DXF drawing, its path relative to the job
// file; quantity defaults to 1; rotations `any` (any angle, the default: the fill tries every 45
// degrees and the four that square the part's box, the strip search any angle), `none`, or a
// list of degrees; mirror: mirrored copies are tried too; priority: lower numbers are nested
// first (must-nest parts before fillers; default 1); split: a drawing with several outer
// contours gives one part per contour. A sheet given by an `outline` is a remnant: the drawing's
// one outer contour is the material's edge, the contours inside it are cut-outs (remnant_sheet);
// its size is the box round it. A `program:` map holds how `machplan nest` writes the sheets'
// programs, its keys the names of that command's flags without their dashes
// (`program: {kerf: 1.5, lead-in: 4, holes: 2}`); the command reads it, the request ignores it.
// Unknown keys and bad values are refused naming the file, line and key.
#pragma once

#include <cstddef>
#include <string>

#include "engine/config/yaml.h"
#include "solvers/nesting/bottom_left.h"

namespace machplan::nesting {

NestRequest read_nest_job(const std::string& path);
// The same from a file already parsed; part files are found relative to `folder`.
NestRequest read_nest_job(const Yaml& root, const std::string& folder);

// The remnant drawn in `path` as a sheet (certificate.h): one closed outer contour, the contours
// inside it its cut-outs, chained and healed as `machplan profile` reads them. InputError naming
// the file for a drawing that does not close, holds several outer contours or leaves no usable
// area inside `margin_mm`.
Sheet remnant_sheet(const std::string& path, double margin_mm);

// The longest list of rotations a part may give: each is a shape the fill tries for every copy
// ("any" turns a part by any angle for less).
inline constexpr std::size_t kMaxRotations = 360;

// "any", "none" or a list: the rotations to try, degrees in [-360, 360] ("any": every 45 degrees,
// the fill's; the request's any_rotation says the rest), at most kMaxRotations of them.
// InputError naming `field` otherwise.
std::vector<double> rotations_from_text(const std::string& text, const std::string& field);

}  // namespace machplan::nesting
