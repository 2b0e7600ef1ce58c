#include "engine/motion/materials.h"

#include <array>
#include <charconv>
#include <cmath>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"

namespace machplan::motion {
namespace {

using text_scan::iequals;
using text_scan::printable;
using text_scan::trim;

// What a key sets.
enum class Field { name, pierce_height, pierce_delay, cut_height, cut_speed, kerf, thc, jump_height, jump_delay, amps, volts,
                   pause, pierce_type, motion_delay, end_height, cut_height_delay, gouge_speed, gouge_distance, creep_speed,
                   creep_distance, ignored };
constexpr std::size_t kMandatory = 4;  // the first four fields after name

struct Key {
  const char* file;     // the material file's key
  const char* comment;  // the material comment's key
  Field field;
};
constexpr std::array<Key, 23> kKeys{{
    {"NAME", "na", Field::name},
    {"PIERCE_HEIGHT", "ph", Field::pierce_height},
    {"PIERCE_DELAY", "pd", Field::pierce_delay},
    {"CUT_HEIGHT", "ch", Field::cut_height},
    {"CUT_SPEED", "fr", Field::cut_speed},
    {"KERF_WIDTH", "kw", Field::kerf},
    {"THC", "th", Field::thc},
    {"PUDDLE_JUMP_HEIGHT", "jh", Field::jump_height},
    {"PUDDLE_JUMP_DELAY", "jd", Field::jump_delay},
    {"CUT_AMPS", "ca", Field::amps},
    {"CUT_VOLTS", "cv", Field::volts},
    {"PAUSE_AT_END", "pe", Field::pause},
    {"PIERCE_TYPE", "pt", Field::pierce_type},
    {"PIERCE_MOTION_DELAY", "md", Field::motion_delay},
    {"PIERCE_END_HEIGHT", "eh", Field::end_height},
    {"CUT_HEIGHT_DELAY", "hd", Field::cut_height_delay},
    {"GOUGE_SPEED", "gs", Field::gouge_speed},
    {"GOUGE_SPEED_DISTANCE", "gd", Field::gouge_distance},
    {"CREEP_SPEED", "cs", Field::creep_speed},
    {"CREEP_SPEED_DISTANCE", "cd", Field::creep_distance},
    {"GAS_PRESSURE", "gp", Field::ignored},
    {"CUT_MODE", "cm", Field::ignored},
    {"THICKNESS", "mt", Field::ignored},
}};

const Key* find_key(std::string_view k, bool comment) {
  for (const Key& key : kKeys)
    if (iequals(k, comment ? key.comment : key.file)) return &key;
  return nullptr;
}

[[noreturn]] void refuse(const std::string& source, int line, const std::string& what) { throw InputError(source, line, what); }

std::optional<double> number(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// Sets `field` of `c` from `value` (file or program units), checking its range.
void set(CutParameters& c, const Key& key, std::string_view value, double mm_per_unit, const std::string& source, int line,
         bool comment) {
  const char* name = comment ? key.comment : key.file;
  value = trim(value);
  if (key.field == Field::name) {
    if (value.size() > 100) refuse(source, line, fmt::format("{} is longer than 100 characters", name));
    c.name = std::string(value);
    return;
  }
  if (key.field == Field::ignored) return;
  double v = 0.0;
  if (!value.empty()) {
    const std::optional<double> n = number(value);
    if (!n) refuse(source, line, fmt::format("{} must be a number, got '{}'", name, printable(value)));
    v = *n;
  } else if (key.field <= Field::cut_speed) {
    refuse(source, line, fmt::format("{} has no value: it is mandatory", name));
  } else if (key.field == Field::thc) {
    return;  // no value: THC stays on
  }
  const auto in = [&](double x, double lo, double hi, const char* unit) {
    if (!(x >= lo && x <= hi))
      refuse(source, line, fmt::format("{} = {:g} is out of range: must be in [{:g}, {:g}]{}", name, v, lo, hi, unit));
    return x;
  };
  const double mm = v * mm_per_unit;
  switch (key.field) {
    case Field::pierce_height: c.pierce_height_mm = in(mm, 0.0, 100.0, " mm"); break;
    case Field::pierce_delay: c.pierce_delay_s = in(v, 0.0, 60.0, " s"); break;
    case Field::cut_height: c.cut_height_mm = in(mm, 0.0, 100.0, " mm"); break;
    case Field::cut_speed:
      if (!(mm > 0.0)) refuse(source, line, fmt::format("{} = {:g} must be > 0", name, v));
      c.cut_feed_mm_per_s = in(mm, 0.0, 100'000.0, " mm/min") / 60.0;
      break;
    case Field::kerf: c.kerf_mm = in(mm, 0.0, 100.0, " mm"); break;
    case Field::thc:
      if (v != 0.0 && v != 1.0) refuse(source, line, fmt::format("{} must be 0 (off) or 1 (on), got {:g}", name, v));
      c.thc = v == 1.0;
      break;
    case Field::jump_height: c.puddle_jump_height_pct = in(v, 0.0, 200.0, " %"); break;
    case Field::jump_delay: c.puddle_jump_delay_s = in(v, 0.0, 60.0, " s"); break;
    case Field::amps: c.cut_amps = in(v, 0.0, 1000.0, " A"); break;
    case Field::volts: c.cut_volts = in(v, 0.0, 1000.0, " V"); break;
    case Field::pause: c.pause_at_end_s = in(v, 0.0, 60.0, " s"); break;
    case Field::pierce_type:
      if (v == 1.0) refuse(source, line, fmt::format("{} = 1 (a wiggle pierce) is not supported: 0 (standing) or 2 (ramp)", name));
      if (v != 0.0 && v != 2.0) refuse(source, line, fmt::format("{} must be 0 (standing) or 2 (ramp), got {:g}", name, v));
      c.ramp_pierce = v == 2.0;
      break;
    case Field::motion_delay: c.pierce_motion_delay_pct = in(v, 0.0, 100.0, " %"); break;
    case Field::end_height: c.pierce_end_height_mm = in(mm, 0.0, 100.0, " mm"); break;
    case Field::cut_height_delay: c.cut_height_delay_s = in(v, 0.0, 60.0, " s"); break;
    case Field::gouge_speed: c.gouge_speed_mm_per_s = in(mm, 0.0, 100'000.0, " mm/min") / 60.0; break;
    case Field::gouge_distance: c.gouge_distance_mm = in(mm, 0.0, 1000.0, " mm"); break;
    case Field::creep_speed: c.creep_speed_mm_per_s = in(mm, 0.0, 100'000.0, " mm/min") / 60.0; break;
    case Field::creep_distance: c.creep_distance_mm = in(mm, 0.0, 1000.0, " mm"); break;
    case Field::name:
    case Field::ignored: break;
  }
}

// A material's parameters as the file's optional keys leave them when absent.
CutParameters blank_material(int number) {
  CutParameters c;
  c.number = number;
  c.kerf_mm = 0.0;
  c.thc = true;
  c.puddle_jump_height_pct = c.puddle_jump_delay_s = 0.0;
  c.cut_amps = c.cut_volts = c.pause_at_end_s = 0.0;
  return c;
}

void require_mandatory(const std::array<bool, kKeys.size()>& seen, const std::string& source, int line, const char* what,
                       bool comment) {
  for (std::size_t k = 1; k <= kMandatory; ++k)
    if (!seen[k])
      refuse(source, line, fmt::format("{} has no {}: it is mandatory", what, comment ? kKeys[k].comment : kKeys[k].file));
}

// A ramp pierce's settings fit together: a speed for each distance, below the cut speed; no
// puddle jump beside it; and without a ramp, none of its settings.
void check_pierce(const CutParameters& c, const std::string& source, int line, const char* what, bool comment) {
  const auto key = [&](Field f) {
    for (const Key& k : kKeys)
      if (k.field == f) return comment ? k.comment : k.file;
    return "?";
  };
  const auto speed_for = [&](double speed, double distance, Field s, Field d) {
    if (distance > 0.0 && !(speed > 0.0))
      refuse(source, line, fmt::format("{}: {} needs {} > 0", what, key(d), key(s)));
    if (distance > 0.0 && speed > c.cut_feed_mm_per_s)
      refuse(source, line, fmt::format("{}: {} is above {}: a ramp pierce starts slower than the cut", what, key(s), key(Field::cut_speed)));
  };
  if (!c.ramp_pierce) {
    if (c.gouge_distance_mm > 0.0 || c.creep_distance_mm > 0.0 || c.pierce_motion_delay_pct > 0.0 || c.pierce_end_height_mm > 0.0)
      refuse(source, line, fmt::format("{}: ramp pierce settings without {} = 2", what, key(Field::pierce_type)));
    return;
  }
  if (c.puddle_jump_height_pct > 0.0)
    refuse(source, line, fmt::format("{}: a ramp pierce and a puddle jump: choose one ({} = 0, or {} = 0)", what,
                                     key(Field::jump_height), key(Field::pierce_type)));
  speed_for(c.gouge_speed_mm_per_s, c.gouge_distance_mm, Field::gouge_speed, Field::gouge_distance);
  speed_for(c.creep_speed_mm_per_s, c.creep_distance_mm, Field::creep_speed, Field::creep_distance);
}

class FileReader {
 public:
  FileReader(const std::string& source, const MaterialReadOptions& options) : options_(options) { t_.source = source; }

  MaterialTable run(std::string_view text) {
    text_scan::LineReader lines(text);
    std::string_view raw;
    while (lines.next(raw)) {
      const int line = lines.line_number();
      const std::string_view l = trim(raw);
      if (l.empty() || l.front() == '#' || l.front() == ';') continue;
      if (l.front() == '[') section(l, line);
      else key_value(l, line);
    }
    close();
    return std::move(t_);
  }

 private:
  void section(std::string_view l, int line) {
    close();
    constexpr std::string_view kPrefix = "[MATERIAL_NUMBER_";
    if (l.back() != ']' || l.size() <= kPrefix.size() + 1 || !iequals(l.substr(0, kPrefix.size()), kPrefix))
      refuse(t_.source, line, fmt::format("'{}' is not a section [MATERIAL_NUMBER_n]", printable(l)));
    const std::string_view digits = l.substr(kPrefix.size(), l.size() - kPrefix.size() - 1);
    int n = -1;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
    if (ec != std::errc() || end != digits.data() + digits.size() || n < 0 || n > 999'999)
      refuse(t_.source, line,
             fmt::format("material number '{}' must be a whole number in 0 .. 999999", printable(digits)));
    if (t_.find(n)) refuse(t_.source, line, fmt::format("material {} is defined twice", n));
    if (t_.materials.size() >= options_.max_materials)
      throw InputError(t_.source, line, fmt::format("more than {} materials", options_.max_materials))
          .with_option("max_materials");
    t_.materials.push_back(blank_material(n));
    t_.lines.push_back(line);
    seen_.fill(false);
    open_ = true;
  }

  void key_value(std::string_view l, int line) {
    const std::size_t eq = l.find('=');
    if (eq == std::string_view::npos)
      refuse(t_.source, line, fmt::format("'{}' is neither a section, KEY = value nor a comment", printable(l)));
    const std::string_view k = trim(l.substr(0, eq));
    if (!open_) refuse(t_.source, line, fmt::format("key '{}' before the first [MATERIAL_NUMBER_n] section", printable(k)));
    const Key* key = find_key(k, false);
    if (!key) {
      std::string upper(k.substr(0, 40));
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      if (warned_.insert(upper).second)
        t_.warnings.push_back(fmt::format("{}:{}: key '{}' is not a material key: ignored", t_.source, line, printable(k)));
      return;
    }
    const std::size_t index = static_cast<std::size_t>(key - kKeys.data());
    if (seen_[index]) refuse(t_.source, line, fmt::format("{} given twice in the material", key->file));
    seen_[index] = true;
    set(t_.materials.back(), *key, l.substr(eq + 1), options_.mm_per_unit, t_.source, line, false);
  }

  void close() {
    if (!open_) return;
    open_ = false;
    const std::string what = fmt::format("material {}", t_.materials.back().number);
    require_mandatory(seen_, t_.source, t_.lines.back(), what.c_str(), false);
    check_pierce(t_.materials.back(), t_.source, t_.lines.back(), what.c_str(), false);
  }

  const MaterialReadOptions& options_;
  MaterialTable t_;
  std::array<bool, kKeys.size()> seen_{};
  std::set<std::string> warned_;
  bool open_ = false;
};

}  // namespace

void MaterialReadOptions::validate() const {
  require_field(mm_per_unit == 1.0 || mm_per_unit == 25.4, "mm_per_unit", mm_per_unit, "must be 1 (mm) or 25.4 (inch)");
  require_field(max_materials >= 1 && max_materials <= 1'000'000, "max_materials", max_materials, "must be in 1 .. 1000000");
}

const CutParameters* MaterialTable::find(int number) const {
  for (const CutParameters& c : materials)
    if (c.number == number) return &c;
  return nullptr;
}

MaterialTable read_materials(std::string_view text, const std::string& source, const MaterialReadOptions& options) {
  options.validate();
  return FileReader(source, options).run(text);
}

MaterialTable read_materials_file(const std::string& path, const MaterialReadOptions& options) {
  return read_materials(read_text_file(path), path, options);
}

MaterialComment read_material_comment(std::string_view text, const std::string& source, int line, double mm_per_unit) {
  MaterialComment out;
  out.material = blank_material(0);
  std::array<bool, kKeys.size()> seen{};
  bool have_option = false, have_number = false;
  std::string_view rest = text;
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    const std::string_view item = trim(rest.substr(0, comma));
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    if (item.empty()) continue;
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos)
      refuse(source, line, fmt::format("material comment: '{}' is not key=value", printable(item)));
    const std::string_view k = trim(item.substr(0, eq)), v = trim(item.substr(eq + 1));
    if (iequals(k, "o") || iequals(k, "nu")) {
      const std::optional<double> n = number(v);
      const bool is_o = iequals(k, "o");
      if (!n || *n != std::floor(*n) || *n < 0 || *n > (is_o ? 2 : 999'999))
        refuse(source, line,
               fmt::format("material comment: {} must be {}, got '{}'", is_o ? "o" : "nu",
                           is_o ? "0, 1 or 2" : "a material number in 0 .. 999999", printable(v)));
      (is_o ? out.option : out.material.number) = static_cast<int>(*n);
      (is_o ? have_option : have_number) = true;
      continue;
    }
    const Key* key = find_key(k, true);
    if (!key) refuse(source, line, fmt::format("material comment: unknown key '{}'", printable(k)));
    const std::size_t index = static_cast<std::size_t>(key - kKeys.data());
    if (seen[index]) refuse(source, line, fmt::format("material comment: {} given twice", key->comment));
    seen[index] = true;
    set(out.material, *key, v, mm_per_unit, source, line, true);
  }
  if (!have_option) refuse(source, line, "material comment: no o= (0, 1 or 2)");
  if (out.option != 0 && !have_number) refuse(source, line, "material comment: o=1 and o=2 need nu= (the material number)");
  if (out.option == 0) out.material.number = 0;
  require_mandatory(seen, source, line, "material comment", true);
  check_pierce(out.material, source, line, "material comment", true);
  return out;
}

}  // namespace machplan::motion
