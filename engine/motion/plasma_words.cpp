#include "engine/motion/plasma_words.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/motion/make_job.h"
#include "engine/motion/materials.h"

namespace machplan::motion {
namespace {

constexpr double kMmPerInch = 25.4;
constexpr int kTemporary = -2;  // PlasmaWords::current_ when a temporary material is in force

using K = ProgramEvent::Kind;

double length_of(const ProgramEvent& e, double v) { return e.mode == 20 ? v * kMmPerInch : v; }

}  // namespace

std::vector<std::string> plasma_reported_params() { return {"holes", "h_diameter", "h_velocity", "oclength", "pierce-only"}; }

bool plasma_word(const ProgramEvent& e) {
  switch (e.kind) {
    case K::user_m_code: return e.number == 190;
    case K::wait_input: return e.number == 3 && e.mode == 3;
    case K::digital_output: return e.number == 2 || e.number == 3;
    case K::analog_output: return e.number == 3;
    case K::parameter:
    case K::magic_comment: return true;
    default: return false;
  }
}

PlasmaWords::PlasmaWords(const Program& program, const JobOptions& options, Job& job)
    : program_(program), options_(options), job_(job) {
  if (options.default_material >= 0) select(options.default_material, 0);
}

void PlasmaWords::before_move(std::size_t index) {
  while (next_event_ < program_.events.size() && program_.events[next_event_].before_move <= index)
    event(program_.events[next_event_++]);
}

const CutParameters* PlasmaWords::in_force() const {
  if (current_ == kTemporary) return &temporary_material_;
  if (current_ < 0) return nullptr;
  if (auto it = edited_.find(current_); it != edited_.end()) return &it->second;
  return options_.materials ? options_.materials->find(current_) : nullptr;
}

void PlasmaWords::select(int number, int line) {
  // -1 (QtPlasmaC's "no material change") and 0, QtPlasmaC's default material (kept in its
  // settings, not in the material file), are the material in force when the program selects
  // none, unless the file or the program defines a material 0 of its own.
  const bool own_zero = edited_.count(0) || (options_.materials && options_.materials->find(0));
  if (number == -1 || (number == 0 && !own_zero)) {
    if (options_.default_material >= 0) select(options_.default_material, line);
    else current_ = -1;
    return;
  }
  const bool known = edited_.count(number) || (options_.materials && options_.materials->find(number));
  if (!known) {
    const std::string where = line > 0 ? program_.source : std::string("default_material");
    const std::string what = options_.materials ? fmt::format("material {} is not in {}", number, options_.materials->source)
                                                : fmt::format("material {} is selected but no material file was given", number);
    if (line > 0) throw InputError(program_.source, line, fmt::format("M190 P{}: {}", number, what));
    throw InputError::field("default_material", what);
  }
  current_ = number;
}

void PlasmaWords::event(const ProgramEvent& e) {
  switch (e.kind) {
    case K::user_m_code:
      if (e.number != 190) return;
      if (e.value != std::floor(e.value) || std::abs(e.value) > 1e7)
        throw InputError(program_.source, e.line, fmt::format("M190 P{:g}: the material number must be a whole number", e.value));
      select(static_cast<int>(e.value), e.line);
      return;
    case K::digital_output:
      if (e.number == 2) thc_off_ = e.value != 0.0;
      if (e.number == 3 && e.value != 0.0) torch_disable_ = true;
      return;
    case K::analog_output:
      if (e.number == 3) velocity_pct_ = e.value <= 0.0 || e.value >= 100.0 ? 100.0 : e.value;
      return;
    case K::magic_comment: {
      const MaterialComment c =
          read_material_comment(e.text, program_.source, e.line, e.mode == 20 ? kMmPerInch : 1.0);
      if (c.option == 0) {  // joins Job::materials at its first cut
        temporary_material_ = c.material;
        temporary_ = -1;
        current_ = kTemporary;
        return;
      }
      const bool exists = edited_.count(c.material.number) || (options_.materials && options_.materials->find(c.material.number));
      if (c.option == 1 && exists) return;
      edited_[c.material.number] = c.material;
      used_.erase(c.material.number);
      return;
    }
    case K::parameter: {
      const auto bad = [&](const char* rule) {
        throw InputError(program_.source, e.line, fmt::format("#<{}> = {:g}: {}", e.text, e.value, rule));
      };
      if (e.text == "holes") {
        if (e.value != std::floor(e.value) || e.value < 0 || e.value > 4) bad("must be 0, 1, 2, 3 or 4");
        holes_ = static_cast<int>(e.value);
      } else if (e.text == "h_diameter") {
        if (!(e.value > 0.0 && length_of(e, e.value) <= 10'000.0)) bad("must be > 0 and at most 10 m");
        hole_diameter_mm_ = length_of(e, e.value);
      } else if (e.text == "h_velocity") {
        if (!(e.value > 0.0 && e.value <= 100.0)) bad("must be a percentage in (0, 100]");
        hole_velocity_pct_ = e.value;
      } else if (e.text == "oclength") {
        if (!(e.value >= 0.0 && length_of(e, e.value) <= 1000.0)) bad("must be in [0, 1000] mm");
        overcut_length_mm_ = length_of(e, e.value);
      } else if (e.text == "pierce-only") {
        pierce_only_ = e.value != 0.0;
      }
      return;
    }
    default: return;
  }
}

int PlasmaWords::torch_on_material() {
  if (current_ == kTemporary) {
    if (temporary_ < 0) {
      job_.materials.push_back(temporary_material_);
      temporary_ = static_cast<int>(job_.materials.size() - 1);
    }
    return temporary_;
  }
  const CutParameters* c = in_force();
  if (!c) return -1;
  if (auto it = used_.find(current_); it != used_.end()) return it->second;
  job_.materials.push_back(*c);
  const int index = static_cast<int>(job_.materials.size() - 1);
  used_[current_] = index;
  return index;
}

bool PlasmaWords::take_torch_disable() {
  const bool was = torch_disable_;
  torch_disable_ = false;
  return was;
}

double PlasmaWords::slowed_diameter(const Move& m, const Eigen::Vector2d& from, bool holes_only) const {
  if (m.kind != Move::Kind::arc || holes_ == 0 || m.plane != Move::Plane::xy) return 0.0;
  const double d = 2.0 * (from - m.center).norm();
  if (!(d > 0.0) || d > hole_diameter_mm_) return 0.0;
  const bool hole = (m.end.head<2>() - from).norm() <= 1e-6 || m.turns > 0;
  return hole || (!holes_only && holes_ >= 3) ? d : 0.0;
}

double PlasmaWords::feed_mm_per_s(const Move& m, const Eigen::Vector2d& from) const {
  double f = m.feed_mm_per_min / 60.0;
  const double marker = options_.material_feed_marker_mm_per_min;
  if (marker > 0.0 && (m.feed_mm_per_min == marker || m.feed_mm_per_min == marker * kMmPerInch)) {
    const CutParameters* c = in_force();
    f = c ? c->cut_feed_mm_per_s : options_.machine_cut_feed_mm_per_s;
    if (!(f > 0.0))
      throw InputError(program_.source, m.line,
                       "F#<_hal[plasmac.cut-feed-rate]> asks for the material's cut feed, but no material is in force "
                       "and the machine gives no value for it");
  }
  const double pct = slowed_diameter(m, from, false) > 0.0 ? hole_velocity_pct_ : velocity_pct_;
  return f * pct / 100.0;
}

double PlasmaWords::overcut_mm(const Move& m, const Eigen::Vector2d& from) const {
  if (holes_ != 2 && holes_ != 4) return 0.0;
  const double d = slowed_diameter(m, from, true);
  return d > 0.0 ? std::min(overcut_length_mm_, std::numbers::pi * d) : 0.0;
}

}  // namespace machplan::motion
