// The HexaM-type hexapod as a placement model (machine_model.h): the struts' inverse
// kinematics per pose, and what interferes with what.
//
// Constraints, in order:
//   slider stroke        self                  each slider's distance to its stroke ends (mm)
//   joint cones          self                  angle left in each slider and plate joint cone (rad)
//   strut clearance      self                  strut capsules against each other (mm)
//   struts / workpiece   workpiece_class2      struts against the workpiece and its pad (mm)
//   per peripheral:      machine_peripheral    the tool assembly (tool, chuck, head, plate,
//                                              hinges), then the struts, against it (mm)
//   tool / support       tool_support          the tool and holder against the pad and table
// and, per placement, the workpiece with its pad against each peripheral.
//
// Motion bounds (models/hexam/hexam.h): when the tip moves d and the axis turns theta, the
// rigid assembly moves at most d + theta f R_rigid (f the plate-rotation factor), the plate
// joints at most d + theta f R_joint, the sliders kappa times that, and the struts turn at
// most (kappa + 1) joint / L_min + theta f. Near a pose whose struts stand closer to their
// rails than alpha_max, kappa is replaced by the local 1 / cos(angle + turn).
#pragma once

#include <memory>

#include "models/hexam/hexam.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

// The machine must have its tooling attached (hexam::attach_tooling).
std::shared_ptr<const MachineModel> make_hexapod_model(const hexam::Machine& machine, const Scene& scene);

}  // namespace machplan::placement
