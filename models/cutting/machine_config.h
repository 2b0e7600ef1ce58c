// Cutting machines as data: the thermal gantry and the XY table, read from YAML.
//
// A machine file (datasets/machines/NAME.yaml, documented in datasets/machines/README.md)
// holds, per axis, the physics the simulator needs (models/axis/plant.h: drive, friction,
// backlash, encoder, counter, DAC, latency) and the servo gains the executor uses; for the
// machine, the path limits, the torch and the torch height axis. The reader validates every
// number, refuses unknown keys and names FILE:LINE and the key in every complaint.
//
// Example:
//
//   auto m = cutting::load_machine(cutting::find_machine("thermal_gantry"));
//   executor::MachineSetup setup = m.setup();        // what the executor needs
//   axis::AxisPlant x(m.axes[0].plant);              // what the simulator needs
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "engine/control/servo.h"
#include "engine/executor/machine_setup.h"
#include "engine/executor/thc.h"
#include "models/axis/plant.h"

namespace machplan {
class Yaml;
}

namespace machplan::cutting {

struct AxisConfig {
  std::string name;              // "x", "y"
  double travel_mm = 0.0;
  axis::AxisPlantParams plant;
  control::ServoGains servo;
};

struct Limits {
  double velocity_mm_per_s = 0.0;
  double acceleration_mm_per_s2 = 0.0;
  double jerk_mm_per_s3 = 0.0;
  double rapid_mm_per_s = 0.0;
  // Largest contour error a cut may have (optional key, mm): the executor's supervisor stops a
  // cut whose drive saturates while the error exceeds it.
  double contour_error_mm = 0.5;
};

struct PlasmaConfig {
  double arc_start_delay_s = 0.15;
  double arc_ok_timeout_s = 2.0;
  double pierce_delay_s = 0.5;
  double arc_start_failure_probability = 0.0;  // simulation only
  // A lost arc: `stop` ends the job (a fault); `recover` holds it for the operator to move back
  // along the path and pierce again (the executor's cut recovery).
  bool recover_on_arc_loss = false;
  // The arc's voltage: arc_volts_base_v + volts_per_mm x the torch's distance to the plate
  // (about 0.1 mm per volt), with Gaussian noise; over a kerf cut earlier (or a void) the arc
  // stretches and the voltage jumps by kerf_crossing_rise_v. Simulation only, but for
  // volts_per_mm, which THC uses to turn volts into millimetres. A material's cut chart in
  // force replaces the base (models/sim/sim_backend.h).
  double arc_volts_base_v = 70.0;
  double volts_per_mm = 10.0;
  double arc_voltage_noise_v = 0.3;
  double kerf_crossing_rise_v = 30.0;
};


struct OxyFuelConfig {
  double preheat_s = 20.0;
  double pierce_delay_s = 2.0;
};

// A spindle (milling): S is its speed; the executor waits spin_up_s after M3/M4 and
// spin_down_s after M5 with the axes at rest.
struct SpindleConfig {
  double spin_up_s = 0.5;
  double spin_down_s = 0.3;
  double max_speed_rpm = 24000.0;
};

struct TorchConfig {
  executor::TorchSetup::Kind kind = executor::TorchSetup::Kind::none;
  bool has_plasma = false, has_oxy_fuel = false;
  PlasmaConfig plasma;
  OxyFuelConfig oxy_fuel;
  // Paused motion along the path while a cut is held (`paused_motion_speed_mm_per_s` in the
  // torch block): its top speed, mm/s.
  double paused_motion_speed_mm_per_s = 10.0;
};

struct TorchHeightConfig {
  bool fitted = false;
  // Initial height sensing (engine/executor/machine_setup.h): the `probe` block of the
  // torch_height block; without one the torch does not probe.
  executor::ProbeSetup probe;
  double pierce_height_mm = 3.8;
  double cut_height_mm = 1.5;
  double retract_height_mm = 15.0;
  double speed_mm_per_s = 50.0;
  double timeout_s = 3.0;
  // The torch height over the table while a rapid crosses a part already cut (its target lies
  // inside the part: a hole cut after its outline), mm: high enough that a part that has
  // tipped up in the skeleton cannot catch the torch. `travel_height_over_cut_mm` in the
  // torch_height block; 0 (absent): the retract height, nothing raised. At least the retract
  // height, and a stroke from cut height the timeout allows.
  double travel_height_over_cut_mm = 0.0;
};

struct MachineConfig {
  std::string name, description, source;
  double servo_period_s = 0.001;
  // Hole slugs whose bounding box is larger than this in x or y may tip up in the skeleton, so
  // rapids keep clear of them; smaller ones drop or lie flat and rapids cross them, mm.
  // Outer contours (parts) are always kept clear of. Default: 50 mm, about the pitch of a
  // cutting table's support slats.
  double slug_tip_size_mm = 50.0;
  // The order `machplan run` cuts a program in when --order is not given (`cut_order:` in the
  // file: program, nearest or optimise; solvers/motion/cut_order.h reads the name). Empty:
  // the program's own order.
  std::string cut_order;
  int cut_order_line = 0;  // where the file gives it
  Limits limits;
  std::array<AxisConfig, 2> axes;
  TorchConfig torch;
  std::optional<SpindleConfig> spindle;  // a milling machine: the `spindle` block instead of `torch`
  TorchHeightConfig torch_height;
  // Torch height control (engine/executor/thc.h): the `thc` block; its defaults without one.
  executor::ThcSettings thc;
  // The simulated sheet (models/sim): a warp of this amplitude and wavelength, mm (0: flat), and
  // the chance that its surface is too dirty for an ohmic contact at one probe.
  double sheet_warp_amplitude_mm = 0.0, sheet_warp_wavelength_mm = 500.0;
  double sheet_ohmic_miss_probability = 0.0;
  // Where programs' zero sits on this machine (X, Y mm), as an operator touching off the
  // sheet corner sets G54; `origin_mm: [x, y]` in the file. `machplan run --origin` overrides it.
  std::optional<std::array<double, 2>> origin_mm;
  // A laser pointer beside the torch (`laser: {offset_mm: [x, y]}`): its dot lies this far from
  // the torch, mm. Framing with it (run --frame --laser) traces the outline with the dot.
  std::optional<std::array<double, 2>> laser_offset_mm;
  // What the G-code reader takes from the machine (`gcode:` in the file): the spindles $n may
  // name (QtPlasmaC: torch, scribe, spotting), and values of parameters programs read from the
  // machine, such as QtPlasmaC's _hal[plasmac.cut-feed-rate] (the material's cut feed).
  int gcode_spindles = 1;
  std::vector<std::pair<std::string, double>> gcode_params;

  // The executor's view: signals, gains, stop deceleration, torch timing.
  executor::MachineSetup setup() const;
};

// Reads and validates a machine file. Throws InputError "FILE:LINE: key 'a.b' ...", and
// "FILE: ... is a machine for placement ..." for a placement machine (see MachineUse).
MachineConfig load_machine(const std::string& path);
MachineConfig machine_from_yaml(const Yaml& root);

// Where `--machine NAME` looks, in this order (the first NAME.yaml found wins):
//
//   1. user:      $XDG_CONFIG_HOME/machplan/machines (default ~/.config/machplan/machines),
//                 created on first use so that the user sees where their machines go;
//   2. installed: share/machplan/machines beside the running program's bin/ folder, then the
//                 share/machplan/machines of the prefix machplan was configured to install to;
//   3. source:    for a program inside this build tree, the source tree's datasets/machines.
//
// Never the current directory: a machine file there is used only when given as a path. A
// folder that does not exist is still listed (with exists = false) so that messages can say
// where a machine would have been found.
struct MachineFolder {
  std::string path;
  std::string kind;  // "user", "installed", "source"
  bool exists = false;
};
std::vector<MachineFolder> machine_folders();

// `name_or_path` is a path to a machine file (it contains '/' or '.', or names an existing
// file), or a machine name looked up as NAME.yaml in machine_folders(). Throws
// InputError::field("machine", ...) naming the value and the folders searched when nothing
// matches.
std::string find_machine(const std::string& name_or_path);

// What a machine file is for. The machine folders hold two families:
//   * cutting: machines that run programs (this reader: axes with their drives, path limits,
//     a torch or a spindle); `run`, `tune`, `guard`, `calibrate` and `serve` take them;
//   * placement: machines a workpiece is placed on (a top-level `kind:`, read by
//     models/hexam and models/trunnion; a HexaM file may leave `kind` out and is known by its
//     `struts`); a scene names them (`machine:`) for `place` and `check`.
// `unreadable`: the file is not YAML a machine can be read from (MachineEntry::problem says why).
enum class MachineUse { cutting, placement, unreadable };
const char* to_string(MachineUse use);
MachineUse machine_use(const Yaml& root);

// Every NAME.yaml in machine_folders(), in search order; `shadowed` marks a name that an
// earlier folder already provides. Each file's top level is read to tell its use.
struct MachineEntry {
  std::string name, path, kind;  // kind: the folder's ("user", "installed", "source")
  bool shadowed = false;
  MachineUse use = MachineUse::unreadable;
  std::string problem;  // why the file is unreadable
};
std::vector<MachineEntry> list_machines();

}  // namespace machplan::cutting
