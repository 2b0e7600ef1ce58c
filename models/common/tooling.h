// The tool and its holder, which belong to the job rather than to the machine, as the parts
// that ride along the tool axis.
//
// A tool assembly is a stack of solids of revolution about the tool axis, measured from the
// tool tip up: the cutting flutes, the shank out of the holder, the holder (chuck), then the
// machine's own spindle parts above it. Each machine model appends its spindle parts to the
// stack that tool_stack() builds from the tooling.
#pragma once

#include <string>
#include <vector>

namespace machplan {

struct Tooling {
  double tool_diameter_mm = 10.0;
  // Radius of the tool's end: tool_diameter_mm / 2 (or the default, negative) is a ball end
  // mill, anything less a flat or bull-nose end mill or a drill, modelled as flat (which
  // reaches no less far than a corner radius or a drill point).
  double corner_radius_mm = -1.0;
  double stick_out_mm = 50.0;      // tool length out of the chuck
  double flute_length_mm = 20.0;   // cutting part; it touches the workpiece by design
  double chuck_diameter_mm = 60.0;
  double chuck_length_mm = 45.0;   // chuck length out of the spindle head

  bool ball_end() const { return corner_radius_mm < 0 || corner_radius_mm >= tool_diameter_mm / 2; }
};

// A cylinder (or capsule) of the moving assembly, fixed to the tool: from `from_mm` to `to_mm`
// along the tool axis measured from the tip, with a radius.
struct ToolPart {
  std::string name;
  double from_mm = 0.0;
  double to_mm = 0.0;
  double radius_mm = 0.0;
  bool capsule = false;  // rounded ends (the ball-end tool) instead of flat ones
  // cutting: touches the workpiece by design (the flutes), exempt from the workpiece checks;
  // class1: everything else that rides on the tool axis.
  enum class Class { cutting, class1 } cls = Class::class1;
};

// Flutes, shank and chuck from the tip up (the holder's top at stick_out + chuck_length).
std::vector<ToolPart> tool_stack(const Tooling& t);

}  // namespace machplan
