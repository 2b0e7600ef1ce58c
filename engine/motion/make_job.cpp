#include "engine/motion/make_job.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/plasma_words.h"
#include "engine/programs/program.h"

namespace machplan::motion {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

void require(bool ok, const char* field, double value, const char* rule) { require_field(ok, field, value, rule); }

// Builds the job while walking the moves.
class Builder {
 public:
  Builder(const Program& program, const JobOptions& options)
      : program_(program), options_(options), words_(program, options, job_) {
    job_.source = program.source;
    job_.start_mm = program.start.head<2>();
    position_ = program.start;
  }

  Job run() {
    for (std::size_t i = 0; i < program_.moves.size(); ++i) {
      const Move& m = program_.moves[i];
      words_.before_move(i);
      if (words_.take_torch_disable() && torch_on_) disable_torch(m);
      switch (m.kind) {
        case Move::Kind::rapid: motion(m, /*rapid=*/true); break;
        case Move::Kind::line:
        case Move::Kind::arc: motion(m, /*rapid=*/false); break;
        case Move::Kind::dwell: event(Step::Kind::dwell, m); break;
        case Move::Kind::torch_on: event(Step::Kind::torch_on, m); break;
        case Move::Kind::torch_off: event(Step::Kind::torch_off, m); break;
      }
    }
    words_.before_move(program_.moves.size());
    close();
    return std::move(job_);
  }

 private:
  [[noreturn]] void refuse(const Move& m, const std::string& what) const {
    throw InputError(program_.source, m.line, what);
  }

  // The torch goes off here (M62 P3, an over cut, pierce only); the program's next M5 adds
  // no second torch_off.
  void disable_torch(const Move& m) {
    event(Step::Kind::torch_off, m);
    torch_disabled_ = true;
  }

  // Modes 2 and 4 of the hole rules: after hole `m` (from `from`), cut with the torch on, the
  // torch goes off and the tool goes on along the circle for `length` mm at the hole's feed.
  void overcut(const Move& m, const Eigen::Vector2d& from, double length, double feed) {
    disable_torch(m);
    const double r = (from - m.center).norm();
    const Eigen::Vector2d e = m.end.head<2>();
    const double a = std::atan2(e.y() - m.center.y(), e.x() - m.center.x()) + (m.clockwise ? -1.0 : 1.0) * length / r;
    Move o = m;
    o.turns = 0;
    o.end.head<2>() = m.center + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    motion(o, /*rapid=*/false, feed);
  }

  void motion(const Move& m, bool rapid, double given_feed = 0.0) {
    if (!rapid && skip_cuts_) return;  // pierce only: the tool stays at the pierce point
    if (m.kind == Move::Kind::arc && m.plane != Move::Plane::xy)
      refuse(m, fmt::format("arc in the {} plane ({}): these machines move in XY only",
                            m.plane == Move::Plane::xz ? "XZ" : "YZ", m.plane == Move::Plane::xz ? "G18" : "G19"));
    const double dz = m.end.z() - position_.z();
    if (std::abs(dz) > options_.z_tolerance_mm) {
      if (m.kind == Move::Kind::arc)
        refuse(m, fmt::format("helical arc (Z moves by {:.6g} mm along the arc): Z is not "
                              "programmable on these machines",
                              dz));
      refuse(m, fmt::format("Z changes from {:.6g} to {:.6g} mm: Z is not programmable on "
                            "these machines (torch height and the XY table's tool are not driven "
                            "by the program)",
                            position_.z(), m.end.z()));
    }
    double feed = options_.rapid_feed_mm_per_s;
    if (!rapid) {
      if (!(m.feed_mm_per_min > 0.0) || !std::isfinite(m.feed_mm_per_min))
        refuse(m, fmt::format("{} move with no feed (F = {}): program an F word before it",
                              to_string(m.kind), m.feed_mm_per_min));
    }
    const Eigen::Vector2d a = position_.head<2>();
    if (!rapid) feed = given_feed > 0.0 ? given_feed : words_.feed_mm_per_s(m, a);
    position_ = m.end;

    const std::vector<Segment> pieces = move_segments(m, a, options_.zero_length_mm);
    if (pieces.empty()) return;  // zero-length move: nothing to do

    if (open_ && current_.rapid != rapid) close();
    if (!open_) {
      current_ = Stretch{};
      current_.rapid = rapid;
      current_.cutting = torch_on_;
      open_ = true;
    }
    for (const Segment& s : pieces) {
      current_.segments.push_back(s);
      current_.feed_mm_per_s.push_back(feed);
      current_.source_lines.push_back(m.line);
      current_.thc_off.push_back(!rapid && words_.thc_off() ? 1 : 0);  // rapids: no THC
    }
    if (!rapid && torch_on_ && given_feed == 0.0)
      if (const double length = words_.overcut_mm(m, a); length > 0.0) overcut(m, a, length, feed);
  }

  void event(Step::Kind kind, const Move& m) {
    if (kind == Step::Kind::torch_off && torch_disabled_) {  // already off (see disable_torch)
      torch_disabled_ = skip_cuts_ = false;
      return;
    }
    close();
    Step st;
    st.kind = kind;
    st.source_line = m.line;
    st.seconds = kind == Step::Kind::dwell ? m.seconds : 0.0;
    job_.steps.push_back(st);
    if (kind == Step::Kind::torch_on) {
      torch_disabled_ = skip_cuts_ = false;  // a new cut, even without an M5 before it
      job_.steps.back().material = words_.torch_on_material();
      torch_on_ = true;
      if (words_.pierce_only()) {  // pierce, and leave the cut out
        disable_torch(m);
        skip_cuts_ = true;
      }
    }
    if (kind == Step::Kind::torch_off) torch_on_ = false;
  }

  void close() {
    if (!open_) return;
    if (std::none_of(current_.thc_off.begin(), current_.thc_off.end(), [](std::uint8_t f) { return f != 0; }))
      current_.thc_off.clear();
    Step st;
    st.kind = Step::Kind::move;
    st.source_line = current_.source_lines.front();
    st.stretch = job_.stretches.size();
    job_.stretches.push_back(std::move(current_));
    job_.steps.push_back(st);
    open_ = false;
  }

  const Program& program_;
  const JobOptions& options_;
  Job job_;
  PlasmaWords words_;
  Eigen::Vector3d position_;
  Stretch current_;
  bool open_ = false;
  bool torch_on_ = false;
  bool torch_disabled_ = false;  // the torch went off before the program's M5
  bool skip_cuts_ = false;       // pierce only: the cut of the current M3 is left out
};

}  // namespace

std::vector<Segment> move_segments(const Move& m, const Eigen::Vector2d& a, double zero_length_mm) {
  std::vector<Segment> out;
  const Eigen::Vector2d b = m.end.head<2>();
  if (m.kind != Move::Kind::arc) {
    if ((b - a).norm() > zero_length_mm) {
      Segment s;
      s.kind = Segment::Kind::line;
      s.start = a;
      s.end = b;
      out.push_back(s);
    }
    return out;
  }
  // The arc from a to b about m.center split into Segments of |sweep| <= pi.
  const Eigen::Vector2d c = m.center;
  const double r = (a - c).norm();
  if (!(r > zero_length_mm)) return out;  // degenerate: no motion along a circle
  const double a0 = std::atan2(a.y() - c.y(), a.x() - c.x());
  const double a1 = std::atan2(b.y() - c.y(), b.x() - c.x());
  // Counter-clockwise angle from start to end in (0, 2 pi]; start = end means a full turn,
  // as in RS274NGC.
  double ccw = std::fmod(a1 - a0, kTwoPi);
  if (ccw < 0) ccw += kTwoPi;
  const bool closed = (b - a).norm() <= zero_length_mm;
  double base;
  if (m.clockwise) {
    base = closed ? kTwoPi : kTwoPi - ccw;
    if (!closed && base >= kTwoPi) base = kTwoPi;  // rounding: almost closed
  } else {
    base = closed ? kTwoPi : ccw;
    if (!closed && base <= 0.0) base = kTwoPi;
  }
  const double total = base + kTwoPi * std::max(0, m.turns);
  const int parts = std::max(1, static_cast<int>(std::ceil(total / kPi - 1e-9)));
  const double step = total / parts * (m.clockwise ? -1.0 : 1.0);
  Eigen::Vector2d from = a;
  for (int k = 0; k < parts; ++k) {
    Segment s;
    s.kind = Segment::Kind::arc;
    s.center = c;
    s.radius = r;
    s.start_angle = a0 + k * step;
    s.sweep = step;
    s.start = from;
    s.end = (k + 1 == parts) ? b
                             : Eigen::Vector2d(c + r * Eigen::Vector2d(std::cos(s.end_angle()), std::sin(s.end_angle())));
    from = s.end;
    out.push_back(s);
  }
  return out;
}

void JobOptions::validate() const {
  require(std::isfinite(rapid_feed_mm_per_s) && rapid_feed_mm_per_s > 0.0, "rapid_feed_mm_per_s",
          rapid_feed_mm_per_s, "must be finite and > 0");
  require(std::isfinite(zero_length_mm) && zero_length_mm >= 0.0, "zero_length_mm", zero_length_mm,
          "must be finite and >= 0");
  require(std::isfinite(z_tolerance_mm) && z_tolerance_mm >= 0.0, "z_tolerance_mm", z_tolerance_mm,
          "must be finite and >= 0");
}

Job make_job(const Program& program, const JobOptions& options) {
  options.validate();
  return Builder(program, options).run();
}

}  // namespace machplan::motion
