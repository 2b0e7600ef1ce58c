// The executor's first controller: one AxisServo per axis (engine/control/servo.h: PID on the
// following error, velocity and acceleration feed-forward with a learned gain, backlash pulse,
// conditional integration, output saturation). The axes are independent: this is an axial
// controller, so the path in ControllerInput is not used.
//
//     u[i] = AxisServo[i].update(r[i], v_ff[i], a_ff[i], y[i])     for every axis i
//
// Real time: update() is 2 x O(1), allocates nothing and never throws.
#pragma once

#include "engine/control/controller.h"
#include "engine/control/servo.h"

namespace machplan::control {

class PidFfController final : public Controller {
 public:
  // `gains[i]` for axis i; `output_limit_mm_per_s[i]`: the speed the DAC can express.
  void configure(const std::array<ServoGains, kAxes>& gains, const std::array<double, kAxes>& output_limit_mm_per_s,
                 double period_s) {
    for (int i = 0; i < kAxes; ++i) axis_[i].configure(gains[i], output_limit_mm_per_s[i], period_s);
  }
  const char* name() const override { return "pid_ff"; }
  void reset() override {
    for (AxisServo& a : axis_) a.reset();
  }
  void update(const ControllerInput& in, ControllerOutput& out) noexcept override {
    for (int i = 0; i < kAxes; ++i)
      out.u_mm_per_s[i] = axis_[i].update(in.r_mm[i], in.v_ff_mm_per_s[i], in.a_ff_mm_per_s2[i], in.y_mm[i]);
  }
  double following_error_mm(int axis) const noexcept override { return axis_[axis].last_error_mm(); }
  bool following_error_exceeded(int axis) const noexcept override { return axis_[axis].following_error_exceeded(); }
  bool saturated(int axis) const noexcept override { return axis_[axis].saturated(); }

  const AxisServo& axis(int i) const { return axis_[i]; }

 private:
  std::array<AxisServo, kAxes> axis_{};
};

}  // namespace machplan::control
