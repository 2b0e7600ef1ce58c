// The position-loop controller of the executor: all axes at once.
//
// Once per servo period the executor hands a controller what every axis should do and what it
// does, and takes back one speed command per axis:
//
//     ControllerInput  { r_mm[i], v_ff[i], a_ff[i], y_mm[i], y_dot[i] }   i = 0 .. kAxes-1
//       r      the setpoint position at the instant the measurement was taken (the feedback
//              adapter's reading latency is already applied by the setpoint source)
//       v_ff   setpoint velocity and acceleration at the instant the command will act
//       a_ff   (command latency + one period ahead): the feed-forward terms
//       y      measured position, y_dot measured velocity (decoded, filtered by the adapter)
//       path   the path segment the tool is on, for contour controllers (a line or arc of
//              the path the setpoints follow, blended corners included; the planned source
//              gives the one nearest the measured position; null while
//              holding a point or when the source does not know the path)
//       r_preview  the setpoint 1 .. preview_ticks periods after r (same axes, same instant
//              convention), for controllers that act ahead of the path (ZPETC); preview_ticks
//              is 0 when the source cannot look ahead
//     ControllerOutput { u[i] }   speed command, mm/s at the drive's nominal scaling, already
//                                 limited to the drive's range
//
// Why one interface over all axes: axial controllers (P, PID, feed-forward) treat the axes
// one by one, but a cross-coupled contour controller needs the errors of both axes and the
// path's direction and curvature at once, so the interface takes them all.
//
// Contract for every implementation:
//   * configure() once before a run (may allocate); reset() before the first update of a run;
//   * update() is O(1) in the path length, allocates nothing, takes no lock, does no I/O and
//     never throws (the real-time rules of engine/executor/executor.h);
//   * following_error_mm(i) is the last position error r - y of axis i, and saturated(i)
//     says whether the last command of axis i was clipped to the drive's range; the
//     executor's supervisor judges both.
// tests/control/controller_contract_test.cpp runs one suite against every implementation.
#pragma once

#include <array>

#include "engine/geometry/contour.h"
#include "engine/hardware/backend.h"

namespace machplan::control {

inline constexpr int kAxes = hardware::kAxes;

struct ControllerInput {
  std::array<double, kAxes> r_mm{};
  std::array<double, kAxes> v_ff_mm_per_s{};
  std::array<double, kAxes> a_ff_mm_per_s2{};
  std::array<double, kAxes> y_mm{};
  std::array<double, kAxes> y_dot_mm_per_s{};
  const Segment* path = nullptr;  // the path piece being followed, when the source knows it
  static constexpr int kMaxPreviewTicks = 8;
  std::array<std::array<double, kAxes>, kMaxPreviewTicks> r_preview_mm{};
  int preview_ticks = 0;
};

struct ControllerOutput {
  std::array<double, kAxes> u_mm_per_s{};
};

class Controller {
 public:
  virtual ~Controller() = default;
  virtual const char* name() const = 0;
  // Clears every state (integrators, previous errors, learned gains) to its start value.
  virtual void reset() = 0;
  virtual void update(const ControllerInput& in, ControllerOutput& out) noexcept = 0;
  virtual double following_error_mm(int axis) const noexcept = 0;
  virtual bool following_error_exceeded(int axis) const noexcept = 0;
  virtual bool saturated(int axis) const noexcept = 0;
};

}  // namespace machplan::control
