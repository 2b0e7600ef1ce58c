#include "engine/programs/program.h"

#include <algorithm>
#include <cmath>

namespace machplan {

const char* to_string(Move::Kind kind) {
  switch (kind) {
    case Move::Kind::rapid: return "rapid";
    case Move::Kind::line: return "line";
    case Move::Kind::arc: return "arc";
    case Move::Kind::dwell: return "dwell";
    case Move::Kind::torch_on: return "torch_on";
    case Move::Kind::torch_off: return "torch_off";
  }
  return "unknown";
}

const char* to_string(ProgramEvent::Kind kind) {
  using K = ProgramEvent::Kind;
  switch (kind) {
    case K::tool_select: return "tool_select";
    case K::tool_change: return "tool_change";
    case K::tool_length_offset: return "tool_length_offset";
    case K::coolant: return "coolant";
    case K::feed_override: return "feed_override";
    case K::digital_output: return "digital_output";
    case K::analog_output: return "analog_output";
    case K::wait_input: return "wait_input";
    case K::user_m_code: return "user_m_code";
    case K::program_stop: return "program_stop";
    case K::controller_command: return "controller_command";
    case K::parameter: return "parameter";
    case K::magic_comment: return "magic_comment";
  }
  return "unknown";
}

const char* to_string(GcodeDialect d) {
  switch (d) {
    case GcodeDialect::linuxcnc: return "linuxcnc";
    case GcodeDialect::grbl: return "grbl";
    case GcodeDialect::automatic: return "auto";
  }
  return "?";
}

const char* to_string(Move::PathMode mode) {
  switch (mode) {
    case Move::PathMode::blend: return "blend";
    case Move::PathMode::exact_path: return "exact_path";
    case Move::PathMode::exact_stop: return "exact_stop";
  }
  return "unknown";
}

namespace {

constexpr double kTwoPi = 2.0 * M_PI;

// Angle swept by an arc from `start` to `move.end`, in radians, > 0, including extra turns.
// Start equal to end (within 1e-9 mm) is a full circle, as in LinuxCNC.
double arc_sweep_rad(const Eigen::Vector3d& start, const Move& move) {
  const double a0 = std::atan2(start.y() - move.center.y(), start.x() - move.center.x());
  const double a1 = std::atan2(move.end.y() - move.center.y(), move.end.x() - move.center.x());
  double sweep = move.clockwise ? a0 - a1 : a1 - a0;
  while (sweep < 0) sweep += kTwoPi;
  while (sweep >= kTwoPi) sweep -= kTwoPi;
  if ((start.head<2>() - move.end.head<2>()).norm() < 1e-9 || sweep < 1e-12) sweep = kTwoPi;
  return sweep + kTwoPi * move.turns;
}

// Coordinates in an arc plane's axis order (first, second, normal) and back.
Eigen::Vector3d to_plane(const Eigen::Vector3d& p, Move::Plane plane) {
  switch (plane) {
    case Move::Plane::xy: return p;
    case Move::Plane::xz: return {p.z(), p.x(), p.y()};
    case Move::Plane::yz: return {p.y(), p.z(), p.x()};
  }
  return p;
}

Eigen::Vector3d from_plane(const Eigen::Vector3d& q, Move::Plane plane) {
  switch (plane) {
    case Move::Plane::xy: return q;
    case Move::Plane::xz: return {q.y(), q.z(), q.x()};
    case Move::Plane::yz: return {q.z(), q.x(), q.y()};
  }
  return q;
}

}  // namespace

ProgramSummary summarize(const Program& program, double rapid_mm_per_min) {
  ProgramSummary s;
  Eigen::Vector3d pos = program.start;
  s.min = s.max = pos;
  auto grow = [&](const Eigen::Vector3d& p) {
    s.min = s.min.cwiseMin(p);
    s.max = s.max.cwiseMax(p);
  };
  for (const Move& m : program.moves) {
    switch (m.kind) {
      case Move::Kind::rapid: {
        ++s.rapid_count;
        const double length = (m.end - pos).norm();
        s.rapid_length_mm += length;
        if (rapid_mm_per_min > 0) s.estimated_seconds += length / rapid_mm_per_min * 60.0;
        grow(m.end);
        pos = m.end;
        break;
      }
      case Move::Kind::line: {
        ++s.line_count;
        const double length = (m.end - pos).norm();
        s.feed_length_mm += length;
        if (m.feed_mm_per_min > 0) s.estimated_seconds += length / m.feed_mm_per_min * 60.0;
        grow(m.end);
        pos = m.end;
        break;
      }
      case Move::Kind::arc: {
        ++s.arc_count;
        // Work in the arc's plane: (first, second) axes as x, y and the normal axis as z.
        Move pm = m;
        pm.end = to_plane(m.end, m.plane);
        const Eigen::Vector3d pp = to_plane(pos, m.plane);
        const auto grow_plane = [&](const Eigen::Vector3d& q) { grow(from_plane(q, m.plane)); };
        const double sweep = arc_sweep_rad(pp, pm);
        const double r0 = (pp.head<2>() - m.center).norm();
        const double r1 = (pm.end.head<2>() - m.center).norm();
        const double planar = sweep * 0.5 * (r0 + r1);
        const double length = std::hypot(planar, pm.end.z() - pp.z());
        s.feed_length_mm += length;
        if (m.feed_mm_per_min > 0) s.estimated_seconds += length / m.feed_mm_per_min * 60.0;
        // Bounding box: the end points and the quadrant points the arc passes through.
        const double a0 = std::atan2(pp.y() - m.center.y(), pp.x() - m.center.x());
        const double r = std::max(r0, r1);
        for (int q = 0; q < 4; ++q) {
          const double aq = q * M_PI_2;
          double delta = m.clockwise ? a0 - aq : aq - a0;
          while (delta < 0) delta += kTwoPi;
          while (delta >= kTwoPi) delta -= kTwoPi;
          if (delta <= sweep) {
            const double z = pp.z() + (pm.end.z() - pp.z()) * (delta / sweep);
            grow_plane(Eigen::Vector3d(m.center.x() + r * std::cos(aq), m.center.y() + r * std::sin(aq), z));
          }
        }
        grow(m.end);
        pos = m.end;
        break;
      }
      case Move::Kind::dwell:
        ++s.dwell_count;
        s.estimated_seconds += m.seconds;
        break;
      case Move::Kind::torch_on:
        ++s.torch_on_count;
        break;
      case Move::Kind::torch_off:
        break;
    }
  }
  return s;
}

}  // namespace machplan
