// The drilling cycles (LinuxCNC's interp_cycles.cc).
#include "engine/programs/internal/gcode_interp.h"

#include <algorithm>
#include <cmath>

namespace machplan::gcode_interp {

// Drilling cycles G73, G81, G82, G83, G85, G89 in the XY plane, expanded as LinuxCNC does
// (interp_convert.cc, convert_cycle_xy): up to R first when the series began below it; the
// first hole reached at the current height and then down to R, later ones at the clearance
// height; the cycle's feeds; back up to R (G99) or to the height where the series began
// (G98). In G91, R is relative to that height, Z to R, and L repeats the X/Y increments.
void Reader::cycle(const Block& b, int g10, int previous_motion) {
  const bool first_in_series = previous_motion != g10;
  if (plane_ != Move::Plane::xy)
    fail(fmt::format("{} (canned cycle) outside the XY plane is not supported", g_name(g10)));
  // As LinuxCNC, the arithmetic is in program units (pecks are counted in them).
  const double s = scale();
  const double current_z = pos_mm_.z() / s;
  if (first_in_series && !b.w('r'))
    fail(fmt::format("R clearance plane unspecified in the canned cycle {}", g_name(g10)));
  if (first_in_series && !b.w('z')) fail(fmt::format("Z value unspecified in the canned cycle {}", g_name(g10)));
  // R and Z are kept as written (relative in G91) for the cycles that follow.
  if (b.w('r')) cycle_r_ = *b.w('r');
  if (b.w('z')) cycle_z_ = *b.w('z');
  // The height when the series of cycles began (LinuxCNC's cycle_il); a motion that is not a
  // cycle ends the series.
  if (!cycle_series_) {
    cycle_initial_z_ = current_z;
    cycle_series_ = true;
  }
  double old_cc = cycle_initial_z_;
  const double r = incremental_ ? cycle_r_ + old_cc : cycle_r_;
  const double bottom = incremental_ ? r + cycle_z_ : cycle_z_;
  if (r < bottom) fail(fmt::format("R value ({:g}) less than Z value ({:g}) in the canned cycle", r, bottom));
  int repeats = 1;
  if (b.w('l')) {
    const double l = *b.w('l');
    if (std::abs(l - std::round(l)) > 1e-4 || l < 0) fail(fmt::format("L word L{:g} must be a whole number >= 0", l));
    repeats = static_cast<int>(std::min(std::round(l), 1e6));
  }
  if (g10 == 730 || g10 == 830) {
    if (b.w('q')) cycle_q_ = *b.w('q');
    else if (first_in_series) fail(fmt::format("Q word missing with {}", g_name(g10)));
    if (!(cycle_q_ > 0)) fail(fmt::format("Q (peck depth) must be > 0 with {}", g_name(g10)));
    if ((r - bottom) / cycle_q_ > 1e6) fail(fmt::format("{} would make more than a million pecks", g_name(g10)));
  }
  if (g10 == 820 || g10 == 890) {
    if (b.w('p')) cycle_p_s_ = *b.w('p');
    else if (first_in_series) fail(fmt::format("dwell time P word missing with {}", g_name(g10)));
    if (cycle_p_s_ < 0) fail("P (dwell) must be >= 0 in a canned cycle");
  }
  double current_cc = current_z;
  if (old_cc < r) {
    straight(Move::Kind::rapid, Eigen::Vector3d(pos_mm_.x(), pos_mm_.y(), r * s));
    old_cc = current_cc = r;
  }
  const double clear = retract_r_plane_ ? r : old_cc;
  const double rapid_delta = inches_ ? 0.010 : 0.254;
  double x = pos_mm_.x(), y = pos_mm_.y(), dx = 0, dy = 0;
  if (incremental_) {
    dx = b.w('x').value_or(0.0) * s;
    dy = b.w('y').value_or(0.0) * s;
  } else {
    if (b.w('x')) x = *b.w('x') * s;
    if (b.w('y')) y = *b.w('y') * s;
  }
  const auto at = [&](double z) { return Eigen::Vector3d(x, y, z * s); };
  const auto dwell = [&](double seconds) {
    Move m;
    m.kind = Move::Kind::dwell;
    m.seconds = seconds;
    push(m);
  };
  for (int k = 0; k < repeats; ++k) {
    x += dx;
    y += dy;
    // The first hole is reached at the current height, the others at the clearance height.
    if (k == 0 && current_cc > r) {
      straight(Move::Kind::rapid, at(current_cc));
      straight(Move::Kind::rapid, at(r));
    } else {
      straight(Move::Kind::rapid, at(clear));
      if (clear > r) straight(Move::Kind::rapid, at(r));
    }
    switch (g10) {
      case 810: case 820:
        straight(Move::Kind::line, at(bottom));
        if (g10 == 820) dwell(cycle_p_s_);
        straight(Move::Kind::rapid, at(clear));
        break;
      case 730: case 830:
        for (double depth = r - cycle_q_; depth > bottom; depth -= cycle_q_) {
          straight(Move::Kind::line, at(depth));
          if (g10 == 830) straight(Move::Kind::rapid, at(r));
          straight(Move::Kind::rapid, at(depth + rapid_delta));
        }
        straight(Move::Kind::line, at(bottom));
        straight(Move::Kind::rapid, at(clear));
        break;
      case 850:
        straight(Move::Kind::line, at(bottom));
        straight(Move::Kind::line, at(r));
        straight(Move::Kind::rapid, at(clear));
        break;
      case 890:
        straight(Move::Kind::line, at(bottom));
        dwell(cycle_p_s_);
        straight(Move::Kind::line, at(clear));
        break;
      default: fail(fmt::format("{} (canned cycle) is not supported", g_name(g10)));
    }
  }
}

}  // namespace machplan::gcode_interp
