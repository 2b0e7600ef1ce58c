// A table-tilting 5-axis machine (models/trunnion) as a placement model (machine_model.h).
//
// The path as the machine runs it. Every tool pose has two inverse-kinematics solutions (the
// tilt one way or the other with the table half a turn apart) except along the table's axis,
// where the table's angle is free. prepare() chooses one per pose along the path (a shortest
// path over the two solutions per pose, whose cost is the rotary axes' travel plus a large
// penalty per flip), so the table turns continuously wherever the limits allow it and a flip
// (the table turning more than a quarter turn within one step) remains only where every choice
// within the tilt axis's limits has one: those are reported as forced. Between two poses the
// control moves the rotary axes linearly and the tool tip on a line (tool centre point
// control); interpolate() follows that.
//
// Constraints, in order:
//   linear travel          self                  margin of X, Y, Z to their ends (mm)
//   rotary travel          self                  margin of the tilt axis (and a limited table) (rad)
//   tool / machine         self                  tool, holder and spindle against the trunnion's
//                                                cradle, table and end supports (mm)
//   workpiece / machine    workpiece_class2      the workpiece and its fixture against the cradle
//                                                and end supports as the table turns and tilts (mm)
//   per peripheral:        machine_peripheral    the tool assembly against it, then it against the
//                                                cradle and end supports (it rides on the table)
//   tool / support         tool_support          the tool and holder against the fixture
// and, per placement, the workpiece with its fixture against each peripheral.
//
// Motion bounds. Over a motion where the tip moves d relative to the table and the rotary axes
// turn by j in total, a point of the tool assembly (within R of the tip) moves at most
// d + (e + d + R) j relative to any body of the machine, e being the tip's distance from the
// rotary axes (it grows by d at most); the spindle nose, and so the linear axes, at most
// d + (e + d) j; a point of the workpiece, a fixture or a peripheral at distance e' from the
// axes at most e' j relative to the cradle.
#pragma once

#include <memory>

#include "models/trunnion/trunnion.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

std::shared_ptr<const MachineModel> make_trunnion_model(const trunnion::Machine& machine, const Scene& scene,
                                                       const Tooling& tooling);

}  // namespace machplan::placement
