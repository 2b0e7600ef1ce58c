// One simulated machine axis, from the DAC code the controller writes to the counter value it
// reads back.
//
// The chain, in the order the signal travels:
//
//   DAC code c (integer, +-2^(dac_bits-1))
//     -> command latency: the code written at tick k reaches the drive at tick k + Lc
//     -> speed command  u = c / 2^(dac_bits-1) * U_fs          (U_fs: dac_full_scale, mm/s)
//     -> drive target   w = clamp(g u + n, -V_max, V_max)      (g: gain_factor, n: speed noise,
//                                                              V_max: the motor's top speed)
//     -> velocity loop + friction, integrated in `substeps` steps per tick:
//            dv/dt = (w - v - c_C sgn(v) - k_v v) / tau,   |dv/dt| <= a_drive
//        The drive's velocity loop is a proportional loop of stiffness K on a load of mass M
//        (tau = M / K); friction forces F enter divided by K, so they are written here as the
//        speed error the loop needs to hold them: c_C (coulomb_friction, mm/s) and k_v v
//        (viscous_friction_ratio). At rest the axis sticks while |w| <= c_C.
//     -> motor side position  x_m += v dt     (motor -> gearbox -> pinion/screw, in mm of travel)
//     -> backlash: the load x_l follows x_m through a dead band of width b:
//            x_l = clamp(x_l, x_m - b/2, x_m + b/2)
//     -> encoder on the load side: count = floor(x_l / q),  q = pitch / (lines * decoding)
//     -> counter: a `counter_bits` wrapping DOWN counter: every encoder edge, in either
//        direction, decrements it; a direction latch holds the direction of the latest edge
//        (the paper's 8253 plus status register). Edges of both directions within one read
//        interval cannot be told apart (see engine/control/counter_decoder.h).
//     -> reading latency: the value read at tick k was latched at tick k - Lr.
//
// Start shock (the paper, section 6): after the drive is enabled, if the first command it
// receives is non-zero the velocity jumps by `start_shock` in the command's direction; a zero
// first command arms the drive and no shock follows until it is disabled again.
//
// Every effect is switched off by its parameter: gain 1, friction 0, backlash 0, noise 0,
// shock 0, latencies 0. Quantisation is made as fine as wanted with dac_bits (up to 24) and
// encoder lines / decoding; it is never removed, since the controller reads integer counts.
//
// Determinism: all randomness comes from the caller's std::mt19937_64 through the portable
// draws in `gaussian()`; the same seed gives the same run on every standard library.
//
// Real time: step() allocates nothing and runs in O(substeps).
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <string>

namespace machplan::axis {

struct AxisPlantParams {
  // Drive and mechanics.
  double motor_max_rpm = 6000.0;          // motor top speed; the axis saturates here
  double gear_ratio = 120.0;              // motor turns per pinion / screw turn
  double mm_per_rev = 98.175;             // travel per pinion (pitch circle) or screw turn
  double dac_full_scale_rpm = 6000.0;     // motor speed the drive is told at DAC full scale
  int dac_bits = 12;                      // 8 .. 24
  double velocity_loop_time_constant_s = 0.012;  // tau of the drive's velocity loop
  double max_acceleration_mm_per_s2 = 0.0;       // drive current limit; 0 = unlimited
  double gain_factor = 1.0;               // real speed / commanded speed (the paper: 0.7)
  double coulomb_friction_mm_per_s = 0.0; // c_C, see above
  double viscous_friction_ratio = 0.0;    // k_v
  double speed_noise_mm_per_s = 0.0;      // std dev of n, drawn once per tick
  double backlash_mm = 0.0;               // b
  double start_shock_mm_per_s = 0.0;      // velocity jump on a non-zero first command
  // Encoder and counter.
  int encoder_lines_per_rev = 1500;
  double encoder_mm_per_rev = 149.285;    // the encoder's own pinion (or the screw pitch)
  int decoding = 4;                       // 1, 2 or 4 edges per line
  int counter_bits = 16;                  // 8 .. 32
  // I/O.
  int command_latency_ticks = 0;          // 0 .. kMaxLatencyTicks
  int reading_latency_ticks = 0;
  int substeps = 10;                      // integration steps per tick, 1 .. 1000

  static constexpr int kMaxLatencyTicks = 15;

  double max_speed_mm_per_s() const { return motor_max_rpm / 60.0 / gear_ratio * mm_per_rev; }
  double dac_full_scale_mm_per_s() const { return dac_full_scale_rpm / 60.0 / gear_ratio * mm_per_rev; }
  double mm_per_count() const { return encoder_mm_per_rev / (encoder_lines_per_rev * decoding); }
  int dac_max_code() const { return (1 << (dac_bits - 1)) - 1; }  // codes are -2^(b-1) .. this
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

// What the counter hardware shows at one read.
struct CounterReading {
  std::uint32_t value = 0;        // 0 .. 2^counter_bits - 1
  bool direction_negative = false;
};

// Draws shared by the simulation: a standard normal (Box-Muller on 53-bit uniforms) and a
// uniform in [0, 1). Written out because std::normal_distribution differs across libraries.
double uniform01(std::mt19937_64& rng);
double gaussian(std::mt19937_64& rng);

class AxisPlant {
 public:
  // The axis starts at rest at `position_mm` (motor and load together: mid-gap), on an
  // encoder edge, and the counter at `counter_start`. Throws like params.validate().
  explicit AxisPlant(const AxisPlantParams& params, double position_mm = 0.0, std::uint32_t counter_start = 0);

  // Advances one tick of `dt_s`: the code written now enters the command delay line; the
  // drive sees the code written command_latency_ticks ago. `enabled` false: the drive is off
  // (target speed zero) and the start-shock latch is re-armed for the next enable.
  void step(std::int32_t dac_code, bool enabled, double dt_s, std::mt19937_64& rng);

  // The counter as read at the end of the latest tick (delayed by reading_latency_ticks).
  CounterReading read() const;

  // Fault injection and truth for traces.
  void glitch_counter(std::int32_t counts);  // the counter jumps by `counts` (down-count units)
  void set_stuck(bool stuck) { stuck_ = stuck; }
  double load_position_mm() const { return load_mm_; }
  double motor_position_mm() const { return motor_mm_; }
  double velocity_mm_per_s() const { return v_; }
  bool shock_happened() const { return shock_count_ > 0; }
  int shock_count() const { return shock_count_; }
  const AxisPlantParams& params() const { return p_; }

 private:
  AxisPlantParams p_;
  double v_ = 0.0, motor_mm_ = 0.0, load_mm_ = 0.0;
  double q_mm_ = 0.0, grid_origin_mm_ = 0.0;
  std::int64_t count_pos_ = 0;
  std::uint32_t counter_ = 0, counter_mask_ = 0;
  bool dir_negative_ = false;
  bool was_enabled_ = false, first_command_pending_ = true;
  bool stuck_ = false;
  int shock_count_ = 0;
  std::array<std::int32_t, AxisPlantParams::kMaxLatencyTicks + 1> cmd_line_{};
  std::array<CounterReading, AxisPlantParams::kMaxLatencyTicks + 1> read_line_{};
  int cmd_head_ = 0, read_head_ = 0;
};

}  // namespace machplan::axis
