// What the executor must know about a machine, in engine terms. models/cutting builds it from
// a machine YAML (MachineConfig::setup()); the executor never reads files itself.
#pragma once

#include <array>
#include <string>

#include "engine/control/servo.h"
#include "engine/executor/thc.h"
#include "engine/hardware/backend.h"

namespace machplan::control {
struct ControllerPlant;
}

namespace machplan::executor {

// How the torch finds the sheet before a pierce (initial height sensing), as QtPlasmaC probes:
// down at the height axis' speed to `probe_height_mm` over the expected surface, then at
// `probe_speed_mm_per_s` until a sensor closes; the surface is where it closed (ohmic: the
// shield touched the plate; float switch: the torch has floated up by `float_travel_mm` since).
// Heights are in the machine's height frame (engine/hardware/backend.h: 0 is the sheet's
// nominal surface). Neither sensor: no probing, the heights are taken from the nominal surface.
struct ProbeSetup {
  bool float_switch = false;          // a float switch is fitted
  bool ohmic = false;                 // ohmic sensing is fitted, tried first (the float switch backs it up)
  double probe_height_mm = 5.0;       // over the expected surface: where the slow probe starts
  double probe_speed_mm_per_s = 10.0;
  double float_travel_mm = 1.5;       // the float's rise before its switch closes
  double ohmic_offset_mm = 0.0;       // added to the surface an ohmic contact finds (QtPlasmaC's ohmic-probe-offset)
  double max_depth_mm = 5.0;          // below the expected and the nominal surface: no contact by there is a probe miss
  // A pierce within this distance (mm, in x and y) of the last probed point takes that probe's
  // surface without probing again (QtPlasmaC's skip IHS); 0: every pierce probes.
  double skip_distance_mm = 0.0;
  int debounce_periods = 3;           // a sensor counts once it reads closed this many periods in a row
  // An offset probe (QtPlasmaC's offset-probe-x/-y/-delay): a probe mounted beside the torch,
  // at this x, y offset from the torch's centre, deployed by Outputs::offset_probe and read on
  // the float-switch input (its own travel is float_travel_mm). Before each pierce that probes,
  // the planner moves the torch so the probe stands over the pierce point, the probe is
  // deployed (offset_delay_s), probes, is stowed, and the torch moves back to pierce
  // (engine/motion/offset_probe.h). 0, 0: no offset probe, the torch probes where it stands.
  double offset_x_mm = 0.0, offset_y_mm = 0.0;
  double offset_delay_s = 0.5;        // the probe's deployment (and its stowing) takes this long
  bool fitted() const { return float_switch || ohmic; }
  bool offset() const { return fitted() && (offset_x_mm != 0.0 || offset_y_mm != 0.0); }
  void validate() const;  // throws InputError naming field, value and rule
};

struct TorchSetup {
  // The machine's process: a plasma or oxy-fuel torch, or a spindle (a milling table: M3/M4
  // start it, M5 stops it; it keeps turning through a feed hold).
  enum class Kind { none, plasma, oxy_fuel, spindle };
  Kind kind = Kind::none;
  double arc_ok_timeout_s = 2.0;       // plasma: fire -> arc OK must come within this
  double pierce_delay_s = 0.5;         // material default when no G4 follows the torch-on
  double preheat_s = 0.0;              // oxy-fuel: heating before the cutting oxygen
  double spin_up_s = 0.0;              // spindle: from start to cutting speed
  double spin_down_s = 0.0;            // spindle: from stop to standstill
  double arc_loss_debounce_s = 0.02;   // arc OK may drop this long while cutting before it is a fault
  bool height_axis = false;            // a torch height axis is fitted
  double pierce_height_mm = 3.8;
  double cut_height_mm = 1.5;
  double retract_height_mm = 15.0;
  double height_tolerance_mm = 0.05;
  double height_timeout_s = 3.0;       // the height axis must reach its target within this
  double height_speed_mm_per_s = 50.0; // the height axis' top speed (the probe's time limits)
  ProbeSetup probe;                    // initial height sensing (height axis only)
  // Plasma: a lost arc holds the job for the operator's cut recovery instead of ending it.
  bool recover_on_arc_loss = false;
  // Paused motion (a held cut, torch off: the machine moves along the program's path, back or
  // on): its top speed along the path, mm/s (QtPlasmaC's paused-motion speed at 100 %).
  double paused_motion_speed_mm_per_s = 10.0;
  double volts_per_mm = 10.0;          // the arc's voltage per mm of torch-to-plate distance
  ThcSettings thc;                     // torch height control (height axis and plasma)
  void validate() const;  // throws InputError naming field, value and rule
};

struct MachineSetup {
  std::string name;
  double servo_period_s = 0.0;  // the machine file's; 0: not stated (the backend's is used)
  std::array<hardware::AxisSignals, hardware::kAxes> signals{};
  std::array<control::ServoGains, hardware::kAxes> servo{};
  std::array<double, hardware::kAxes> max_speed_mm_per_s{};  // physical top speed per axis
  // Encoder scale measured by a calibration (mm per count), used to decode the counters in
  // place of signals[i].mm_per_count (the scale the backend declares); 0: not calibrated.
  std::array<double, hardware::kAxes> calibrated_mm_per_count{};
  double max_velocity_mm_per_s = 80.0;        // the planner's speed limit per axis (overrides above 100 %)
  double max_acceleration_mm_per_s2 = 500.0;  // used for the controlled stop and jogging
  double max_jerk_mm_per_s3 = 20000.0;        // jogging
  double contour_error_limit_mm = 0.5;        // supervisor: saturated drive off the contour
  double rapid_mm_per_s = 80.0;
  TorchSetup torch;
  void validate() const;  // throws InputError naming field, value and rule
};

// What a controller may know of this setup (engine/control/controller_factory.h): servo gains,
// output limits, latencies, encoder quantum and period. The drive's time constant and gain are
// not part of the setup (they belong to the machine model): they are left unknown (0) and
// nominal (1); models/cutting/controller_plant.h fills them from the machine file.
control::ControllerPlant plant_from_setup(const MachineSetup& setup);

}  // namespace machplan::executor
