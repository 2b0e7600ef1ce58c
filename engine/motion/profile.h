// A jerk-limited path-speed profile: constant-jerk phases in time order. The feed planners
// (engine/motion/feed_planner.h for the 2-axis machines, engine/motion/axis_planner.h for the
// 5-axis trunnion) both plan the speed along their path as one of these, built by the same
// look-ahead (engine/motion/internal/speed_profile.h), and read it back with profile_state().
#pragma once

#include <vector>

namespace machplan::motion {

// One phase of the path-speed profile: constant jerk for `duration_s` from the state
// (s0, v0, a0) at time t0.
struct ProfilePhase {
  double t0_s = 0.0, duration_s = 0.0;
  double s0_mm = 0.0, v0_mm_per_s = 0.0, a0_mm_per_s2 = 0.0, jerk_mm_per_s3 = 0.0;
};

// Path length, speed and acceleration at one time.
struct ProfileState {
  double s = 0.0, v = 0.0, a = 0.0;
};

// The state at time t_s of the profile `phases` (start times `phase_t0`, the phases' t0_s kept
// in a vector of their own for the binary search) that ends at `duration_s` and `length`:
// before 0 (or NaN) the start at rest, from duration_s on the end at rest. s is clamped to
// [0, length], v to >= 0. No allocation, O(log n).
ProfileState profile_state(const std::vector<ProfilePhase>& phases, const std::vector<double>& phase_t0, double duration_s,
                           double length, double t_s);

}  // namespace machplan::motion
