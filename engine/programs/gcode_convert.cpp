// A block into motion and events (LinuxCNC's interp_execute.cc and interp_convert.cc): the
// block's codes by modal group, the checks of its words, then each group in LinuxCNC's order
// of execution; arcs as interp_arc.cc makes them.
#include "engine/programs/internal/gcode_interp.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

namespace machplan::gcode_interp {
namespace {

// LinuxCNC's tolerances (interp_internal.hh), in inches; mm values are derived below.
constexpr double kRadiusToleranceInch = 0.00005;
constexpr double kSpiralAbsToleranceInch = 2 * 0.001 * 1.41421356237309504880;
constexpr double kSpiralAbsToleranceMm = 2 * 0.01 * 1.41421356237309504880;
constexpr double kSpiralRelativeTolerance = 0.001;
constexpr double kTiny = 1e-12;

// Codes that LinuxCNC knows and we refuse, with the name of the feature. G codes are keyed by
// ten times their number (G38.2 -> 382).
const std::map<int, const char*>& refused_g_codes() {
  static const std::map<int, const char*> codes = {
      {50, "cubic spline"}, {51, "quadratic spline"}, {52, "NURBS"}, {70, "lathe diameter mode"},
      {80, "lathe radius mode"}, {171, "UV plane"}, {181, "WU plane"}, {191, "VW plane"},
      {330, "spindle-synchronised motion"}, {331, "rigid tapping"}, {382, "probing"},
      {383, "probing"}, {384, "probing"}, {385, "probing"}, {410, "cutter radius compensation"},
      {411, "dynamic cutter radius compensation"}, {420, "cutter radius compensation"},
      {421, "dynamic cutter radius compensation"}, {431, "dynamic tool length offset"},
      {432, "additional tool length offset"},
      {700, "lathe finishing cycle"}, {710, "lathe roughing cycle"}, {711, "lathe roughing cycle"},
      {720, "lathe roughing cycle"}, {721, "lathe roughing cycle"}, {740, "left-hand tapping cycle"},
      {760, "threading cycle"}, {840, "tapping cycle"}, {860, "boring cycle with spindle stop"},
      {870, "back boring cycle"}, {880, "boring cycle with manual retract"},
      {930, "inverse time feed"}, {950, "feed per revolution"}, {960, "constant surface speed"}};
  return codes;
}

const char* refused_m_code(int m) {
  switch (m) {
    case 19: return "spindle orientation";
    case 60: return "pallet change";
    case 70: case 71: case 72: case 73: return "saving and restoring modal state";
    case 98: case 99: return "subroutines (M98/M99, Fanuc style)";
    default: break;
  }
  return nullptr;
}

int m_group(int m) {
  switch (m) {
    case 0: case 1: case 2: case 30: return 4;
    case 62: case 63: case 64: case 65: case 66: case 67: case 68: return 5;
    case 6: case 61: return 6;
    case 3: case 4: case 5: return 7;
    case 7: case 8: case 9: return 8;
    case 48: case 49: case 50: case 51: case 52: case 53: return 9;
    default: break;
  }
  if (m >= 100 && m <= 199) return 10;
  return -1;
}

}  // namespace

std::string g_name(int g10) {
  return g10 % 10 == 0 ? fmt::format("G{}", g10 / 10) : fmt::format("G{}.{}", g10 / 10, g10 % 10);
}

int g_group(int g10) {
  switch (g10) {
    case 40: case 100: case 280: case 281: case 300: case 301: case 520: case 530: case 920: case 921: case 922:
    case 923:
      return 0;                                           // non-modal
    case 0: case 10: case 20: case 30: case 730: case 800: case 810: case 820: case 830: case 850:
    case 890: return 1;                                   // motion
    case 170: case 180: case 190: return 2;               // plane
    case 900: case 910: return 3;                         // distance mode
    case 901: case 911: return 4;                         // arc distance mode
    case 940: return 5;                                   // feed mode
    case 200: case 210: return 6;                         // units
    case 400: return 7;                                   // cutter compensation off
    case 430: case 490: return 8;                         // tool length offset
    case 980: case 990: return 10;                        // canned cycle return mode
    case 540: case 550: case 560: case 570: case 580: case 590: case 591: case 592: case 593: return 12;
    case 610: case 611: case 640: return 13;              // path control
    case 970: return 14;                                  // spindle RPM mode
    default: return -1;
  }
}

// One block, in LinuxCNC's order of execution. execute() reads the block's codes by modal
// group (modal_groups), checks that every word has a code to use it (check_words), then runs
// the groups in LinuxCNC's order, one function each.
bool Reader::execute(const Block& b) {
  Codes c = modal_groups(b);
  check_words(b, c);
  feed_speed_tool(b, c);
  inputs_outputs(b, c);
  tool_and_spindle(b, c);
  other_m_codes(b, c);
  modes(b, c);
  offsets(b, c);
  motion(b, c);
  return program_stop(c);
}

// Modal group checks: the G and M codes of the block by group.
Codes Reader::modal_groups(const Block& b) {
  Codes c;
  c.g.fill(-1);
  c.m.fill(-1);
  for (int g : b.g10) {
    int group = g_group(g);
    if (group < 0) {
      const auto& refused = refused_g_codes();
      const auto it = refused.find(g);
      if (it != refused.end()) fail(fmt::format("{} ({}) is not supported", g_name(g), it->second));
      fail(fmt::format("unknown G code {}", g_name(g)));
    }
    int& seen = c.g[static_cast<std::size_t>(group)];
    // G80 beside another motion code gives way to it, as in LinuxCNC.
    if (group == 1 && (g == 800 || seen == 800)) {
      if (seen < 0 || seen == 800) seen = g;
      continue;
    }
    if (seen >= 0)
      fail(fmt::format("two G codes from the same modal group on one line: {} and {}", g_name(seen), g_name(g)));
    seen = g;
  }
  for (int m : b.m) {
    const int group = m_group(m);
    if (group < 0) {
      if (const char* name = refused_m_code(m)) fail(fmt::format("M{} ({}) is not supported", m, name));
      fail(fmt::format("unknown M code M{}", m));
    }
    if (c.m[static_cast<std::size_t>(group)] >= 0)
      fail(fmt::format("two M codes from the same modal group on one line: M{} and M{}",
                       c.m[static_cast<std::size_t>(group)], m));
    c.m[static_cast<std::size_t>(group)] = m;
  }
  return c;
}

// Words without a code that uses them; the motion the line performs.
void Reader::check_words(const Block& b, Codes& c) {
  c.has_axis = b.w('x') || b.w('y') || b.w('z');
  const int g0 = c.g[0];
  c.g0_uses_axes = g0 == 100 || g0 == 280 || g0 == 300 || g0 == 520 || g0 == 920;
  const int g_motion = c.g[1];
  if (g_motion == 800 && c.has_axis && !c.g0_uses_axes) fail("axis words (X, Y, Z) with G80");
  if (c.g0_uses_axes && g_motion >= 0 && g_motion != 800)
    fail(fmt::format("cannot use two G codes that both use axis values: {} and {}", g_name(g0), g_name(g_motion)));
  if (g_motion >= 0 && g_motion != 800) c.motion = g_motion;
  else if (g_motion < 0 && c.has_axis && !c.g0_uses_axes) {
    if (motion_g10_ == 800) fail("axis words (X, Y, Z) without a motion code G0..G3 to use them (motion mode is G80)");
    c.motion = motion_g10_;
  }
  c.is_arc = c.motion == 20 || c.motion == 30;
  c.cycle = c.motion >= 0 && is_cycle(c.motion);
  c.plane = c.g[2] == 180 ? Move::Plane::xz : c.g[2] == 190 ? Move::Plane::yz : c.g[2] == 170 ? Move::Plane::xy : plane_;
  const int m5 = c.m[5], m9 = c.m[9], m10 = c.m[10];
  if (c.is_arc) {
    const char missing = c.plane == Move::Plane::xy ? 'k' : c.plane == Move::Plane::xz ? 'j' : 'i';
    const char* pname = c.plane == Move::Plane::xy ? "XY" : c.plane == Move::Plane::xz ? "XZ" : "YZ";
    if (b.w(missing))
      fail(fmt::format("{} word given for an arc in the {} plane", static_cast<char>(std::toupper(missing)), pname));
  } else {
    if (b.w('i')) fail("I word with no G2 or G3 to use it");
    if (b.w('j')) fail("J word with no G2 or G3 to use it");
    if (b.w('k')) fail("K word with no G2 or G3 to use it");
  }
  if (b.w('r') && !c.is_arc && !c.cycle && g0 != 100) fail("R word with no G2, G3, G10 or canned cycle to use it");
  const bool p_used = c.is_arc || g0 == 40 || g0 == 100 || c.g[13] == 640 || c.motion == 820 || c.motion == 890 ||
                      (m5 >= 62 && m5 <= 66) || m9 >= 0 || m10 >= 0;
  if (b.w('p') && !p_used)
    fail("P word with no code that uses it (G2/G3, G4, G10, G64, G82, G89, M50-M53, M62-M66, M100-M199)");
  if (b.w('q') && !(c.g[13] == 640 || c.motion == 730 || c.motion == 830 || m5 == 66 || m5 == 67 || m5 == 68 ||
                    c.m[6] == 61 || m10 >= 0))
    fail("Q word with no code that uses it (G64, G73, G83, M61, M66-M68, M100-M199)");
  if (b.w('l') && !(g0 == 100 || c.cycle || m5 == 66)) fail("L word with no G10, canned cycle or M66 to use it");
  if (b.w('e') && !(m5 == 66 || m5 == 67 || m5 == 68))
    fail("E word with no M66, M67 or M68 to use it (and 'E' is a word letter, not an exponent: write 1000, not 1e3)");
  if (b.w('h') && c.g[8] != 430) fail("H word with no G43 to use it");
  if (b.w('d')) fail("D words (cutter compensation) are not supported");
  if (c.is_arc) check_arc_words(b, c);
  if (b.spindle) {
    const int n = *b.spindle;
    const bool all = n == -1 && c.m[7] == 5;
    if (!all && (n < 0 || n >= options_.spindle_count))
      fail(fmt::format("invalid spindle ($) number ${}: this machine has {} spindle{} ($0{})", n,
                       options_.spindle_count, options_.spindle_count == 1 ? "" : "s",
                       options_.spindle_count == 1 ? "" : fmt::format("..${}", options_.spindle_count - 1)));
  }
}

// The centre or radius words and the P word (turns) of an arc.
void Reader::check_arc_words(const Block& b, const Codes& c) {
  const char first = c.plane == Move::Plane::xy ? 'i' : c.plane == Move::Plane::xz ? 'k' : 'j';
  const char second = c.plane == Move::Plane::xy ? 'j' : c.plane == Move::Plane::xz ? 'i' : 'k';
  if (b.w('r') && (b.w(first) || b.w(second))) fail("mixed radius (R) and centre (I, J, K) format for an arc");
  if (!b.w('r') && !b.w(first) && !b.w(second)) fail("R, I, J and K words all missing for an arc");
  if (!b.w('p')) return;
  const double p = *b.w('p');
  if (std::abs(p - std::round(p)) > 1e-4) fail(fmt::format("P word on G2/G3 is not an integer: P{:g}", p));
  if (std::round(p) < 1) fail(fmt::format("P word on G2/G3 must be 1 or greater (number of turns), got P{:g}", p));
  if (std::round(p) > options_.max_arc_turns)
    fail(fmt::format("P{:g} asks for more than {} turns on one arc", p, options_.max_arc_turns));
}

int Reader::integer_word(const Block& b, char c, const char* what) const {
  const double v = *b.w(c);
  if (std::abs(v - std::round(v)) > 1e-4 || v < 0)
    fail(fmt::format("{} word {}{:g} must be a whole number >= 0 ({})", static_cast<char>(std::toupper(c)),
                     static_cast<char>(std::toupper(c)), v, what));
  return static_cast<int>(std::round(std::min(v, 1e9)));
}

// G94 (which resets the feed), F, S, T.
void Reader::feed_speed_tool(const Block& b, const Codes& c) {
  if (c.g[5] == 940) feed_mm_per_min_ = 0.0;  // G94 resets the feed, as LinuxCNC does
  if (b.w('f')) {
    if (*b.w('f') < 0) fail("negative F word (feed rate)");
    feed_mm_per_min_ = *b.w('f') * scale();
  }
  if (b.w('s')) {
    if (*b.w('s') < 0) fail("negative S word (spindle speed)");
    spindle_speed_ = *b.w('s');
  }
  if (b.w('t')) {
    tool_selected_ = integer_word(b, 't', "tool number");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_select;
    e.number = tool_selected_;
    event(e);
  }
}

// M62..M68: outputs and inputs.
void Reader::inputs_outputs(const Block& b, const Codes& c) {
  const int m5 = c.m[5];
  if (m5 >= 62 && m5 <= 65) {
    if (!b.w('p')) fail(fmt::format("M{} needs a P word (output number)", m5));
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::digital_output;
    e.number = integer_word(b, 'p', "output number");
    e.value = (m5 == 62 || m5 == 64) ? 1.0 : 0.0;
    e.synchronized = m5 == 62 || m5 == 63;
    event(e);
  } else if (m5 == 66) {
    if (!b.w('p') && !b.w('e')) fail("M66 needs a P (digital) or E (analog) input number");
    if (b.w('p') && b.w('e')) fail("M66 takes a P or an E word, not both");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::wait_input;
    e.number = b.w('p') ? integer_word(b, 'p', "input number") : integer_word(b, 'e', "input number");
    e.mode = b.w('l') ? integer_word(b, 'l', "wait mode 0..4") : 0;
    if (e.mode > 4) fail(fmt::format("M66 wait mode L{} must be 0..4", e.mode));
    e.value = b.w('q').value_or(0.0);
    if (e.value < 0) fail("M66 timeout Q must be >= 0 seconds");
    event(e);
  } else if (m5 == 67 || m5 == 68) {
    if (!b.w('e') || !b.w('q')) fail(fmt::format("M{} needs an E word (output number) and a Q word (value)", m5));
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::analog_output;
    e.number = integer_word(b, 'e', "output number");
    e.value = *b.w('q');
    e.synchronized = m5 == 67;
    event(e);
  }
}

// M6 / M61 (tool change), then M3 / M4 / M5 (torch or spindle).
void Reader::tool_and_spindle(const Block& b, const Codes& c) {
  if (c.m[6] == 6) {
    // LinuxCNC stops the spindle for the change.
    Move m;
    m.kind = Move::Kind::torch_off;
    push(m);
    tool_in_spindle_ = tool_selected_;
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_change;
    e.number = tool_in_spindle_;
    event(e);
  } else if (c.m[6] == 61) {
    if (!b.w('q')) fail("M61 needs a Q word (tool number)");
    tool_in_spindle_ = tool_selected_ = integer_word(b, 'q', "tool number");
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_change;
    e.number = tool_in_spindle_;
    event(e);
  }
  if (c.m[7] == 3 || c.m[7] == 4) {
    Move m;
    m.kind = Move::Kind::torch_on;
    m.spindle_speed = spindle_speed_;
    m.spindle = b.spindle.value_or(0);
    push(m);
  } else if (c.m[7] == 5) {
    Move m;
    m.kind = Move::Kind::torch_off;
    m.spindle = b.spindle.value_or(0);
    push(m);
  }
}

// M7-M9 (coolant), M48-M53 (overrides), M100-M199 (user M codes), then G4 (dwell).
void Reader::other_m_codes(const Block& b, const Codes& c) {
  if (c.m[8] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::coolant;
    e.number = c.m[8];
    event(e);
  }
  if (c.m[9] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::feed_override;
    e.number = c.m[9];
    e.value = b.w('p').value_or(1.0);
    event(e);
  }
  if (c.m[10] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::user_m_code;
    e.number = c.m[10];
    e.value = b.w('p').value_or(0.0);
    e.value2 = b.w('q').value_or(0.0);
    event(e);
  }
  if (c.g[0] == 40) {
    if (!b.w('p') || *b.w('p') < 0) fail("dwell time missing with G4 (P seconds, 0 or more)");
    Move m;
    m.kind = Move::Kind::dwell;
    m.seconds = *b.w('p');
    push(m);
  }
}

// Plane, units, tool length offset, coordinate system, path control, distance modes and the
// canned cycles' retract mode.
void Reader::modes(const Block& b, const Codes& c) {
  if (c.g[2] >= 0) plane_ = c.plane;
  if (c.g[6] == 200) inches_ = true;
  if (c.g[6] == 210) inches_ = false;
  if (c.g[8] >= 0) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::tool_length_offset;
    e.number = c.g[8] == 490 ? -1 : b.w('h') ? integer_word(b, 'h', "tool number") : tool_in_spindle_;
    event(e);
  }
  if (c.g[12] >= 0) {
    const int g = c.g[12];
    const int system = g <= 590 ? (g - 540) / 10 + 1 : 6 + (g - 590);
    change_offsets([&] {
      params_[kCoordSystemParam] = system;
      load_g5x();
    });
  }
  if (c.g[13] >= 0) {
    const int g = c.g[13];
    path_mode_ = g == 610 ? Move::PathMode::exact_path : g == 611 ? Move::PathMode::exact_stop : Move::PathMode::blend;
    if (g == 640) {
      if (b.w('p') && *b.w('p') < 0) fail("G64 P (path tolerance) must be >= 0");
      if (b.w('q') && *b.w('q') < 0) fail("G64 Q (naive CAM tolerance) must be >= 0");
      path_tolerance_mm_ = b.w('p').value_or(0.0) * scale();
    } else {
      path_tolerance_mm_ = 0.0;
    }
  }
  if (c.g[3] == 900) incremental_ = false;
  if (c.g[3] == 910) incremental_ = true;
  if (c.g[4] == 901) ij_absolute_ = true;
  if (c.g[4] == 911) ij_absolute_ = false;
  if (c.g[10] >= 0) retract_r_plane_ = c.g[10] == 990;
}

// G10 L2 / L20: a coordinate system's offsets.
void Reader::set_coordinate_system(const Block& b) {
  if (!b.w('l')) fail("G10 needs an L word (L2 or L20 set a coordinate system)");
  const int l = integer_word(b, 'l', "G10 L");
  if (l == 1 || l == 10 || l == 11) fail(fmt::format("G10 L{} (setting tool table data) is not supported", l));
  if (l != 2 && l != 20) fail(fmt::format("G10 L{} is not a G10 code LinuxCNC knows (L1, L2, L10, L11, L20)", l));
  if (!b.w('p')) fail(fmt::format("G10 L{} needs a P word (coordinate system 0..9)", l));
  int p = integer_word(b, 'p', "coordinate system");
  if (p > 9) fail(fmt::format("G10 L{} P{}: the coordinate system must be 0..9", l, p));
  if (b.w('r') && *b.w('r') != 0.0) fail("G10 L2 R (rotation of a coordinate system) is not supported");
  const int current = static_cast<int>(params_[kCoordSystemParam]);
  if (p == 0) p = current;
  for (int a = 0; a < 3; ++a) {
    const auto& v = b.w(kAxes[a]);
    if (!v) continue;
    double off = *v * scale();
    if (l == 20) off = machine_position()[a] - (g92_on_ ? g92_mm_[a] : 0.0) - off;
    params_[static_cast<std::size_t>(g5x_param(p, a))] = off;
  }
  if (p == current) change_offsets([&] { load_g5x(); });
}

// The non-modal codes that set offsets or go through stored positions: G10, G28 / G30,
// G28.1 / G30.1, G92, G52, G92.1 / G92.2 / G92.3.
void Reader::offsets(const Block& b, const Codes& c) {
  const int g0 = c.g[0];
  if (g0 == 100) {
    set_coordinate_system(b);
  } else if (g0 == 280 || g0 == 300) {
    // Through the point the axis words give (if any) to the stored position (#5161.. for G28,
    // #5181.. for G30, machine coordinates), moving only the named axes, or all without any.
    const int base = g0 == 280 ? kFirstG28Param : kFirstG30Param;
    Eigen::Vector3d via = pos_mm_;
    for (int a = 0; a < 3; ++a)
      if (const auto& v = b.w(kAxes[a])) via[a] = incremental_ ? pos_mm_[a] + *v * scale() : *v * scale();
    straight(Move::Kind::rapid, via);
    Eigen::Vector3d home = via;
    for (int a = 0; a < 3; ++a)
      if (!c.has_axis || b.w(kAxes[a])) home[a] = params_[static_cast<std::size_t>(base + a)] - offset()[a];
    straight(Move::Kind::rapid, home);
  } else if (g0 == 281 || g0 == 301) {
    const int base = g0 == 281 ? kFirstG28Param : kFirstG30Param;
    const Eigen::Vector3d machine = machine_position();
    for (int a = 0; a < 3; ++a) params_[static_cast<std::size_t>(base + a)] = machine[a];
  } else if (g0 == 920) {
    if (!c.has_axis) fail("G92 needs at least one axis word");
    change_offsets([&] {
      const Eigen::Vector3d machine = machine_position();
      for (int a = 0; a < 3; ++a) {
        if (const auto& v = b.w(kAxes[a])) g92_mm_[a] = machine[a] - g5x_mm_[a] - *v * scale();
        else if (!g92_on_) g92_mm_[a] = 0.0;
        params_[static_cast<std::size_t>(kFirstG92Param + a)] = g92_mm_[a];
      }
      g92_on_ = true;
      params_[5210] = 1;
    });
  } else if (g0 == 520) {
    // G52: the local offset, which LinuxCNC keeps in the G92 offset, set to the values given.
    change_offsets([&] {
      if (!g92_on_) g92_mm_.setZero();
      for (int a = 0; a < 3; ++a) {
        if (const auto& v = b.w(kAxes[a])) g92_mm_[a] = *v * scale();
        params_[static_cast<std::size_t>(kFirstG92Param + a)] = g92_mm_[a];
      }
      g92_on_ = true;
      params_[5210] = 1;
    });
  } else if (g0 == 921 || g0 == 922 || g0 == 923) {
    g92_off_or_restore(g0);
  }
}

// G92.1 (offsets off and cleared), G92.2 (off, kept), G92.3 (restored from the parameters).
void Reader::g92_off_or_restore(int g0) {
  change_offsets([&] {
    if (g0 == 923) {
      for (int a = 0; a < 3; ++a) g92_mm_[a] = params_[static_cast<std::size_t>(kFirstG92Param + a)];
      g92_on_ = true;
      params_[5210] = 1;
      return;
    }
    g92_on_ = false;
    params_[5210] = 0;
    if (g0 == 921) {
      g92_mm_.setZero();
      for (int a = 0; a < 9; ++a) params_[static_cast<std::size_t>(kFirstG92Param + a)] = 0.0;
    }
  });
}

// G0 / G1 / G2 / G3 / the canned cycles, with G53 for the line.
void Reader::motion(const Block& b, const Codes& c) {
  const int previous_motion = motion_g10_;
  if (c.g[1] >= 0) motion_g10_ = c.g[1];
  if ((c.motion >= 0 && !is_cycle(c.motion)) || c.g[1] == 800) cycle_series_ = false;
  if (c.motion < 0) return;
  const int g0 = c.g[0];
  if (g0 == 530) {
    if (c.motion != 0 && c.motion != 10) fail("G53 is allowed only with G0 or G1");
    if (incremental_) fail("G53 cannot be used in incremental distance mode (G91)");
  }
  Eigen::Vector3d end = pos_mm_;
  if (!c.cycle) {
    for (int a = 0; a < 3; ++a) {
      const auto& v = b.w(kAxes[a]);
      if (!v) continue;
      if (g0 == 530) end[a] = *v * scale() - offset()[a];
      else end[a] = incremental_ ? pos_mm_[a] + *v * scale() : *v * scale();
    }
  }
  if (c.motion == 0) {
    straight(Move::Kind::rapid, end);
  } else if (c.motion == 10) {
    straight(Move::Kind::line, end);
  } else if (c.is_arc) {
    if (feed_mm_per_min_ <= 0) fail(fmt::format("cannot make an arc (G{}) with zero feed rate", c.motion / 10));
    arc(b, c.motion == 20, end);
    pos_mm_ = end;
  } else {
    cycle(b, c.motion, previous_motion);
  }
}

// M0 / M1 are kept; M2 / M30 end the program (returns false).
bool Reader::program_stop(const Codes& c) {
  const int m4 = c.m[4];
  if (m4 == 0 || m4 == 1) {
    ProgramEvent e;
    e.kind = ProgramEvent::Kind::program_stop;
    e.number = m4;
    event(e);
  }
  return !(m4 == 2 || m4 == 30);
}

void Reader::arc(const Block& b, bool clockwise, const Eigen::Vector3d& end_mm) {
  // LinuxCNC does this arithmetic in program units and in the plane's own axes; so do we.
  const double s = scale();
  const double radius_tolerance = inches_ ? kRadiusToleranceInch : kRadiusToleranceInch * kMmPerInch;
  const double spiral_abs_tolerance = inches_ ? kSpiralAbsToleranceInch : kSpiralAbsToleranceMm;
  const Eigen::Vector2d start = plane_pair(pos_mm_) / s, finish = plane_pair(end_mm) / s;
  const double x0 = start.x(), y0 = start.y();
  const double x1 = finish.x(), y1 = finish.y();
  const char first = plane_ == Move::Plane::xy ? 'i' : plane_ == Move::Plane::xz ? 'k' : 'j';
  const char second = plane_ == Move::Plane::xy ? 'j' : plane_ == Move::Plane::xz ? 'i' : 'k';
  double cx = 0, cy = 0;
  if (b.w('r')) {
    const double r = *b.w('r');
    if (x0 == x1 && y0 == y1) fail("current point same as end point of arc (R format cannot make a full circle)");
    const double abs_r = std::abs(r);
    if (abs_r == 0) fail("zero-radius arc: R0");
    const double mid_x = (x0 + x1) / 2.0, mid_y = (y0 + y1) / 2.0;
    double half = std::hypot(mid_x - x1, mid_y - y1);
    if (!(half - abs_r <= radius_tolerance))
      fail(fmt::format("arc radius R{:g} too small to reach end point (half the chord is {:.4f})", r, half));
    if (half / abs_r > 1 - kTiny) half = abs_r;
    const double chord_angle = std::atan2(y1 - y0, x1 - x0);
    const double theta = ((clockwise && r > 0) || (!clockwise && r < 0)) ? chord_angle - M_PI_2 : chord_angle + M_PI_2;
    const double offset = abs_r * std::cos(std::asin(half / abs_r));
    cx = mid_x + offset * std::cos(theta);
    cy = mid_y + offset * std::sin(theta);
  } else {
    const double i = b.w(first).value_or(0.0), j = b.w(second).value_or(0.0);
    // Offsets are in program units; with G90.1 they are absolute centre coordinates (of the
    // work coordinate system; no G91 offset applies to them).
    cx = ij_absolute_ ? i : x0 + i;
    cy = ij_absolute_ ? j : y0 + j;
    const double r1 = std::hypot(cx - x0, cy - y0);
    const double r2 = std::hypot(cx - x1, cy - y1);
    const auto where = [&] {
      return fmt::format("start=({:.4f},{:.4f}) center=({:.4f},{:.4f}) end=({:.4f},{:.4f}) r1={:.4f} r2={:.4f}", x0, y0,
                         cx, cy, x1, y1, r1, r2);
    };
    if (r1 < radius_tolerance || r2 < radius_tolerance) fail("zero-radius arc: " + where());
    const double abs_err = std::abs(r1 - r2);
    const double rel_err = abs_err / std::max(r1, r2);
    if (abs_err > spiral_abs_tolerance * 100.0 ||
        (rel_err > kSpiralRelativeTolerance && abs_err > spiral_abs_tolerance))
      fail("radius to end of arc differs from radius to start: " + where());
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) fail("arc centre cannot be computed (numbers too large or too small)");
  Move m;
  m.kind = Move::Kind::arc;
  m.plane = plane_;
  m.end = end_mm;
  m.center = Eigen::Vector2d(cx * s, cy * s);
  m.clockwise = clockwise;
  m.turns = b.w('p') ? static_cast<int>(std::lround(*b.w('p'))) - 1 : 0;
  m.feed_mm_per_min = feed_mm_per_min_;
  push(m);
}

}  // namespace machplan::gcode_interp
