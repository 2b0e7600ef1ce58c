// The picture of a run (`machplan run --plot`): a top view in the style of the thermal-cutting
// paper's simulation screen, programmed path against executed path.
//
// Drawn, in machine coordinates (X right, Y up, equal scales), framed on the cuts and the
// declared zones (rapids to and from a distant home are cut off at the frame's edge): the
// declared no-go zones (red),
// the parts cut (closed cuts, light grey: what the rapids avoid), the outline as programmed
// before kerf compensation (thin grey, only with a kerf), the programmed torch path (black),
// the rapids as planned (dashed blue), pierce points (open circles) and the executed path
// while the torch burned (red). The executed path is the simulated true torch position when
// the backend reports it, else the encoder position. Its distance from the programmed path is
// drawn `magnify` times larger: each executed point p is drawn at q + magnify (p - q), q being
// the nearest point of the cut's programmed path (so the error is magnified along the path
// normal and the programmed path itself is unchanged). The title carries the file, machine,
// mode, the largest contour error and the magnification; a legend and a scale bar are at the
// bottom.
//
// PNG or SVG by the file's extension. Throws InputError naming the file when it cannot be
// written or the extension is neither .png nor .svg (the field "plot"), and naming the field
// "magnify" when magnify is not finite and > 0.
#pragma once

#include <string>

#include "solvers/motion/run.h"

namespace machplan::motion {

void write_run_plot(const std::string& path, const RunOutcome& run, double magnify = 1.0);

}  // namespace machplan::motion
