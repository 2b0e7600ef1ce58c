// Controllers by name and gain vector: how the CLI (`machplan run --controller KIND --gain
// NAME=VALUE`) and the tuner (solvers/tuning) build any controller of this folder without
// knowing its type.
//
//     ControllerPlant plant = executor::plant_from_setup(setup);  // + drive tau and gain if known
//     for (const GainSpec& s : gain_specs("pid", plant)) ...  // names, units, defaults, box
//     auto c = make_controller("pid", {{"kp_per_s", 120}}, plant);
//     executor::RunParts parts; parts.controller = c.get();
//
// Kinds (controller_kinds()):
//   p       axial proportional, optional velocity / acceleration feed-forward (pid_controller.h)
//   pid     axial PID with back-calculation anti-windup, same feed-forward options (pid_controller.h)
//   pid_ff  the executor's default servo: PID, adaptive feed-forward, backlash pulse, on the
//           machine's servo section (pid_ff_controller.h, servo.h)
//   zpetc   Tomizuka's zero phase error tracking feed-forward on a P loop, from the drive model
//           (zpetc_controller.h; needs drive_time_constant_s or the gain model_time_constant_s)
//   ccc     Koren's cross-coupled contour controller on axial P loops (cross_coupled_controller.h)
//   flc     fuzzy-logic axial controller, 7 sets on E and dE, 7 x 7 rules (fuzzy_controller.h)
//
// Gains: one value per name applies to every axis. A name the caller leaves out takes its
// default, which is the machine's servo section where the kind has that gain (per axis: the
// axes keep their own values), else the spec's default. GainSpec::default_value shows axis 0's.
// Gains outside their spec's box, non-finite values and names the kind does not have are
// refused with InputError::field("gains", ...) naming the gain; an unknown kind with
// InputError::field("controller", ...) listing the kinds.
//
// Ownership: make_controller returns a configured, reset controller that owns all its state;
// it refers to nothing of the caller's. Building (configure) allocates; update() never does.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/common/names.h"
#include "engine/control/controller.h"
#include "engine/control/servo.h"

namespace machplan::control {

// One tunable gain of a controller kind.
struct GainSpec {
  std::string name;             // units in the name: "kp_per_s", "ki_per_s2", "acceleration_ff_s"
  double default_value = 0.0;   // the hand-tuned start (the machine's servo section where it has one)
  double min_value = 0.0, max_value = 0.0;  // the box the tuner may search
  bool log_scale = false;       // search in log space (gains spanning decades; min_value > 0 then)
  std::string description;      // one line for --help and reports
};

// Named gains of one controller; missing names take their defaults.
using Gains = std::map<std::string, double>;

// What a controller may know about the machine, per axis.
struct ControllerPlant {
  std::array<ServoGains, kAxes> servo{};               // the machine file's servo section
  std::array<double, kAxes> output_limit_mm_per_s{};   // the DAC's speed range (u_max)
  std::array<double, kAxes> drive_time_constant_s{};   // first-order velocity loop tau; 0: unknown
  std::array<double, kAxes> gain_factor{1.0, 1.0};     // drive gain g (speed per commanded speed)
  std::array<int, kAxes> command_latency_ticks{};      // periods from command to drive
  std::array<int, kAxes> reading_latency_ticks{};      // age of the measurement, periods
  std::array<double, kAxes> position_quantum_mm{};     // one encoder count; 0: unknown
  std::array<double, kAxes> coulomb_friction_mm_per_s{};  // drive's Coulomb friction as speed; 0: unknown
  std::array<double, kAxes> backlash_mm{};             // gap between motor and table; 0: none or unknown
  double period_s = 0.001;
  // Throws InputError naming the field.
  void validate() const;
};

// The kinds make_controller builds, in a stable order, canonically spelled.
std::vector<std::string> controller_kinds();

// A kind as a user writes it: the canonical name (the kinds above), or an old spelling
// ("pid-ff" for "pid_ff") with a note. InputError::field(field, ...) listing the kinds
// otherwise. The factory's functions accept an old spelling too (without the note).
Parsed<std::string> parse_controller_kind(std::string_view text, const char* field = "controller");

// The tunable gains of `kind` on `plant`. InputError::field("controller", ...) for an unknown kind.
std::vector<GainSpec> gain_specs(const std::string& kind, const ControllerPlant& plant);

// Builds, configures and resets a controller. InputError::field("controller") for an unknown
// kind, InputError::field("gains") for a gain the kind does not have, outside its box, or a
// combination the controller refuses.
std::unique_ptr<Controller> make_controller(const std::string& kind, const Gains& gains, const ControllerPlant& plant);

// Parses "NAME=VALUE" into `gains`; InputError::field(field) when malformed or repeated (the
// field of the caller's options that holds the gains: "controller_gains", "start", ...).
void parse_gain(const std::string& text, Gains& gains, const std::string& field = "gains");

}  // namespace machplan::control
