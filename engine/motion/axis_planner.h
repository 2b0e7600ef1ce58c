// Feed planning in joint space for a machine of up to six axes, linear (mm) or rotary (rad): a
// 5-axis machine's X, Y, Z and two rotary axes, or a hexapod's six sliders. The path is a chain
// of joint-space linear moves between consecutive poses, timed as a control with per-axis limits
// would run it.
//
// The path. Move i goes in a straight line in joint space from q_{i-1} to q_i (what a control
// does between two programmed 5-axis blocks). It is parametrised by a path length l_i:
//   * the tool tip's path length relative to the workpiece over the move (`tip_mm`), when the
//     tip moves; this is the length the programmed feed is measured on;
//   * otherwise (a pure reorientation) the rotary axes' joint-space angle |dr| (rad, counted as
//     mm of path); on a machine without rotary axes, the tool axis's turn (`turn_rad`).
// Along move i every axis moves at the rate u_i = (q_i - q_{i-1}) / l_i per unit of path: at
// path speed v axis k moves at v u_ik, accelerates at a u_ik, and so on.
//
// Feed. What the programmed feed F caps depends on how the control reads it (AxisLimits::feed):
//   * tip (the default): the tip's speed relative to the workpiece, v <= F on a move where the
//     tip moves (tool centre point control, G43.4 / TRAORI: what the CAM's feed means in a
//     5-axis block; a post-processor's inverse-time feed F / l gives the same time l / F at
//     most). A pure reorientation has no feed cap (its axes' own limits bound it);
//   * axes: the combined speed of all the axes in machine coordinates, rotary degrees counted
//     as mm (G94 without tool centre point control, as Fanuc and Haas controls read a 5-axis
//     block): v |(u_x, u_y, u_z, u_a deg, u_c deg)| <= F on every feed move. A setup that
//     makes the axes travel further then takes longer at the same feed.
// Rapid moves (feed 0) have no feed cap and run at the axes' rapid speeds.
//
// Caps per move (the 2-axis planner's box, engine/motion/feed_planner.h, in five dimensions):
//   speed         v <= min(F, min_k vmax_k / |u_ik|)       (vmax: cutting or rapid speeds)
//   acceleration  a <= min_k amax_k / |u_ik|
//   jerk          j <= min_k jmax_k / |u_ik|
// so no axis exceeds its speed, acceleration or jerk inside a move.
//
// Junctions. Between moves i and i+1 the axis velocities jump from v u_i to v u_{i+1}. A control
// passes the corner with a short blend; we take GRBL's junction-deviation idea per axis: the
// blend is a parabola in joint space of path length L_b centred on the corner, over which each
// axis's velocity changes by v du_k (du = u_{i+1} - u_i) in the time L_b / v, an acceleration of
// v^2 |du_k| / L_b; the parabola leaves the corner by L_b |du_k| / 8 on axis k. So
//
//   L_b = min(l_i, l_{i+1}, min_k 8 tol_k / |du_k|)      (tol: corner_tolerance, mm or rad)
//   v_junction^2 <= min_k amax_k L_b / |du_k|
//
// keeps every axis within its acceleration over the corner and the blend within the tolerance
// of it. The plan's path does not include the blend (the time over it is counted as on the
// corner's two legs; the blend is shorter, so that errs on the slow side); sample() reports the
// corner itself, where the velocity jumps by at most what the blend spreads over L_b / v.
//
// Speed profile. Consecutive moves whose speed caps agree within 0.5 % and whose junction
// does not bind form a zone (taking the smaller caps); a junction that binds is a zone
// boundary whose speed is at most its junction cap. The zones then go through the look-ahead
// and jerk-limited S-curve profile the 2-axis planner uses (engine/motion/internal/
// speed_profile.h: GRBL's reverse and forward passes with S-curve distances, then accelerate /
// cruise / decelerate per zone at the highest peak its length allows), rest to rest.
//
// What it leaves out: servo lag and the blend's own path; jerk across a junction (the
// acceleration steps there within a zone, as on the 2-axis planner's lines).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/motion/profile.h"

namespace machplan::motion {

// At most this many axes; a machine with fewer leaves the rest at 0 (AxisLimits::names).
inline constexpr int kJointAxes = 6;
using JointVector = Eigen::Matrix<double, kJointAxes, 1>;

// A 5-axis position (X, Y, Z, then the two rotary axes), the sixth entry 0.
JointVector five_axis(double x, double y, double z, double a, double c);

// Per-axis limits.
struct AxisLimits {
  // The machine's axes, at most kJointAxes, in JointVector order, and which of them are rotary
  // (bit k: axis k, in rad) rather than linear (mm). Default: X, Y, Z and two rotary axes.
  std::vector<std::string> names = {"x", "y", "z", "rotary 1", "rotary 2"};
  unsigned rotary_axes = 0b11000;
  int axes() const { return static_cast<int>(names.size()); }
  bool rotary(int k) const { return ((rotary_axes >> k) & 1u) != 0; }

  JointVector velocity = JointVector::Zero();        // cutting moves, mm/s or rad/s
  JointVector rapid_velocity = JointVector::Zero();  // rapid moves
  JointVector acceleration = JointVector::Zero();    // mm/s^2, rad/s^2
  JointVector jerk = JointVector::Zero();            // mm/s^3, rad/s^3
  // What the programmed feed caps (see the file comment).
  enum class Feed { tip, axes } feed = Feed::tip;
  // How far a corner's blend may leave the corner: linear axes (mm), rotary axes (rad).
  double corner_tolerance_mm = 0.01;
  double corner_tolerance_rad = 0.0002;  // about 0.01 deg

  // Throws InputError naming the field, its value and the rule (every limit of the machine's
  // axes finite and > 0); InternalError when there are no axes or more than kJointAxes.
  void validate() const;
};

// One joint-space linear move, ending at `end`.
struct JointMove {
  JointVector end = JointVector::Zero();
  double tip_mm = 0.0;         // the tool tip's path length relative to the workpiece
  double turn_rad = 0.0;       // the tool axis's turn relative to the workpiece (used on a
                               // machine without rotary axes when the tip stands still)
  double feed_mm_per_s = 0.0;  // programmed feed; 0: a rapid move
};

// Axis positions, velocities and accelerations at one time.
struct JointState {
  JointVector position = JointVector::Zero();
  JointVector velocity = JointVector::Zero();
  JointVector acceleration = JointVector::Zero();
};

class JointPlan {
 public:
  double duration_s() const { return duration_s_; }
  // The state at t (clamped to [0, duration]); velocity and acceleration along the move the
  // path length at t falls in (at a corner: the later move's). No allocation, O(log n).
  JointState sample(double t_s) const;
  // The path length, speed and acceleration at t (path units: see the file comment).
  ProfileState path_state(double t_s) const { return profile_state(phases_, phase_t0_, duration_s_, length_, t_s); }
  double length() const { return length_; }

  // Per planned move (moves of zero length are dropped): where it starts on the path and in
  // joint space, its rate, its speed cap, and the corner rule's speed cap at the junction after
  // it (infinity where the rates do not change, and after the last move).
  struct Move {
    double s0 = 0.0, length = 0.0;
    JointVector start = JointVector::Zero(), rate = JointVector::Zero();  // q = start + (s - s0) rate
    double speed_cap = 0.0, junction_cap = 0.0;
  };
  const std::vector<Move>& moves() const { return moves_; }
  // Sum over moves of length / speed cap: the time with every axis at most at its speed limit
  // and no acceleration limit, a lower bound of duration_s().
  double velocity_only_s() const { return velocity_only_s_; }
  const std::vector<ProfilePhase>& profile() const { return phases_; }
  int zones() const { return zones_; }

 private:
  friend JointPlan plan_joint_moves(const JointVector&, const std::vector<JointMove>&, const AxisLimits&);
  std::vector<Move> moves_;
  std::vector<double> move_s0_;
  std::vector<ProfilePhase> phases_;
  std::vector<double> phase_t0_;
  JointVector start_ = JointVector::Zero();
  double duration_s_ = 0.0, length_ = 0.0, velocity_only_s_ = 0.0;
  int zones_ = 0;
};

// Plans the chain of moves from `start` (see the file comment), rest to rest. Throws InputError
// when the limits are invalid (AxisLimits::validate) and InternalError (the caller built it
// wrong) when a move has a non-finite position, a negative or non-finite tip length or feed.
// Thread safe, deterministic; O(n) in the number of moves.
JointPlan plan_joint_moves(const JointVector& start, const std::vector<JointMove>& moves, const AxisLimits& limits);

// The pieces of the file comment, for callers that bound the planner's time (the placement
// search): a move's path length (tip_mm, or the rotary angle when the tip stands still, or on a
// machine without rotary axes turn_rad; 0 for a move that goes nowhere); its speed,
// acceleration and jerk caps for the absolute rates |u_k| (feed 0: rapid; `tip_moves`: the feed
// caps it); the corner rule's speed cap for the absolute rate jump |du_k| with blends up to
// `max_blend` long (the shorter move's length).
// Every cap only falls when any |u_k| or |du_k| rises.
struct MoveCaps {
  double speed = 0.0, accel = 0.0, jerk = 0.0;
};
double joint_move_length(const JointVector& delta, double tip_mm, double turn_rad, const AxisLimits& limits);
MoveCaps joint_move_caps(const JointVector& rate_abs, double feed_mm_per_s, bool tip_moves, const AxisLimits& limits);
double junction_speed_cap(const JointVector& jump_abs, double max_blend, const AxisLimits& limits);

}  // namespace machplan::motion
