#include "engine/programs/toolpath.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <vector>
#include <filesystem>
#include <system_error>
#include <utility>

#include <Eigen/Geometry>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"
#include "engine/programs/gcode.h"
#include "engine/programs/internal/arc_walk.h"

namespace machplan {
namespace {

using text_scan::iequals;
using text_scan::LineReader;
using text_scan::printable;
using text_scan::trim;

constexpr double kMinAxisNorm = 1e-9;
constexpr double kMmPerInch = 25.4;
constexpr std::size_t kMaxFields = 8;

// Up to kMaxFields comma-separated fields; `count` may exceed kMaxFields (then only the
// first kMaxFields are stored) so that the caller can report how many there were.
struct Fields {
  std::array<std::string_view, kMaxFields> at;
  std::size_t count = 0;
};

Fields split_commas(std::string_view s) {
  Fields f;
  if (trim(s).empty()) return f;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = s.find(',', start);
    const std::string_view field = trim(s.substr(start, comma == std::string_view::npos ? s.npos : comma - start));
    if (f.count < kMaxFields) f.at[f.count] = field;
    ++f.count;
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return f;
}

class Reader {
 public:
  Reader(const std::string& source, const ToolPathReadOptions& options) : options_(options) {
    path_.source = source;
  }

  // Reserves room for about one pose per line (never more than 4 M ahead of time): growing
  // the vector by doubling costs more than the parsing on large paths.
  void reserve_for(std::string_view text) {
    const auto lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1;
    path_.poses.reserve(std::min({lines, options_.max_poses, std::size_t{1} << 22}));
  }

  [[noreturn]] void fail(int line, const std::string& message) const {
    throw InputError(path_.source, line, message);
  }

  double number(std::string_view field, int line, const char* what) const {
    std::string_view s = field;
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double value = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (s.empty() || ec == std::errc::invalid_argument || end != s.data() + s.size())
      fail(line, fmt::format("{}: expected a number, found '{}'", what, printable(field)));
    if (ec == std::errc::result_out_of_range)
      fail(line, fmt::format("{}: number '{}' is out of range", what, printable(field)));
    if (!std::isfinite(value))
      fail(line, fmt::format("{}: number '{}' is not finite", what, printable(field)));
    if (std::abs(value) > kMaxToolPathNumber)
      fail(line, fmt::format("{}: number '{}' is beyond +-{:g}, which no tool path reaches (in mm: {:g} km)", what,
                             printable(field), kMaxToolPathNumber, kMaxToolPathNumber / 1e6));
    return value;
  }

  Eigen::Vector3d unit_axis(const Eigen::Vector3d& v, int line) const {
    const double n = v.norm();
    if (!(n >= kMinAxisNorm))
      fail(line, fmt::format("tool axis ({}, {}, {}) has length {:g}; it must be at least {:g}", v.x(), v.y(),
                             v.z(), n, kMinAxisNorm));
    return v / n;
  }

  void add_pose(const ToolPose& pose) {
    if (path_.poses.size() >= options_.max_poses)
      fail(pose.line, fmt::format("more than {} poses; the reader's limit (ToolPathReadOptions::max_poses) is {}",
                                  options_.max_poses, options_.max_poses));
    if (pending_cutter_) {
      // A CUTTER before this move and after the last LOAD: it describes the tool in the
      // spindle (a numbered one must keep its shape), or a new unnumbered one when the
      // unnumbered tool in the spindle already moved.
      if (tool_ < 0 || (path_.tools[tool_].number < 0 && path_.tools[tool_].poses > 0))
        tool_ = new_tool(-1, pending_cutter_->line);
      describe_tool(pending_cutter_->line);
    }
    path_.poses.push_back(pose);
    path_.poses.back().tool = tool_;
    if (tool_ >= 0) ++path_.tools[tool_].poses;
  }

  int new_tool(int number, int line) {
    ToolPath::Tool t;
    t.number = number;
    t.line = line;
    path_.tools.push_back(t);
    return static_cast<int>(path_.tools.size()) - 1;
  }

  // Gives the tool in force the CUTTER waiting (two CUTTERs of one tool number must agree).
  void describe_tool(int line) {
    ToolPath::Tool& t = path_.tools[tool_];
    if (t.cutter && t.number >= 0 && t.poses > 0) {
      const ToolPath::Cutter &a = *t.cutter, &b = *pending_cutter_;
      if (std::abs(a.diameter_mm - b.diameter_mm) > 1e-9 || std::abs(a.corner_radius_mm - b.corner_radius_mm) > 1e-9 ||
          std::abs(a.length_mm - b.length_mm) > 1e-9)
        fail(line, fmt::format("CUTTER describes tool {} unlike the CUTTER of line {} (one number, one tool)", t.number,
                               a.line));
    }
    t.cutter = pending_cutter_;
    pending_cutter_.reset();
  }

  // LOAD/TOOL, n: the moves that follow are made with tool n.
  void load_tool(int number, int line) {
    tool_ = -1;
    for (std::size_t k = 0; k < path_.tools.size(); ++k)
      if (path_.tools[k].number == number) tool_ = static_cast<int>(k);
    if (tool_ < 0) tool_ = new_tool(number, line);
    if (pending_cutter_) describe_tool(line);
  }

  ToolPath finish() {
    if (path_.poses.empty()) fail(0, "the tool path holds no pose");
    return std::move(path_);
  }

  const ToolPathReadOptions& options_;
  ToolPath path_;
  // The tool in force (index into path_.tools, -1 none yet) and a CUTTER not yet bound to one.
  int tool_ = -1;
  std::optional<ToolPath::Cutter> pending_cutter_;
};

// ---------------------------------------------------------------------------------------------
// APT / CLDATA

class AptReader : public Reader {
 public:
  using Reader::Reader;

  ToolPath read(std::string_view text) {
    reserve_for(text);
    LineReader lines(text);
    std::string joined;       // a statement spread over '$' continuation lines
    int joined_line = 0;      // its first line; 0 when no continuation is pending
    std::string_view line;
    while (lines.next(line)) {
      const int number = lines.line_number();
      if (line.size() > options_.max_line_bytes)
        fail(number, fmt::format("line is longer than {} bytes", options_.max_line_bytes));
      if (const auto comment = line.find("$$"); comment != std::string_view::npos) line = line.substr(0, comment);
      line = trim(line);
      const bool continues = !line.empty() && line.back() == '$';
      if (continues) line.remove_suffix(1);
      if (continues || joined_line > 0) {
        if (joined_line == 0) joined_line = number;
        if (joined.size() + line.size() > options_.max_statement_bytes)
          fail(joined_line, fmt::format("statement continued with '$' is longer than {} bytes",
                                        options_.max_statement_bytes));
        joined.append(line);
        if (continues) continue;
        statement(joined, joined_line);
        joined.clear();
        joined_line = 0;
      } else {
        statement(line, number);
      }
    }
    if (joined_line > 0) fail(joined_line, "statement continued with '$' but the file ends");
    if (circle_line_ > 0) fail(circle_line_, "CIRCLE without a GOTO to end it before the file ends");
    finish_warnings();
    return finish();
  }

 private:
  void statement(std::string_view s, int line) {
    s = trim(s);
    if (s.empty()) return;
    current_statement_ = s;
    std::size_t word_end = 0;
    while (word_end < s.size() && (std::isalnum(static_cast<unsigned char>(s[word_end])) || s[word_end] == '_'))
      ++word_end;
    const std::string_view word = s.substr(0, word_end);
    std::string_view rest = trim(s.substr(word_end));
    if (word.empty() || !std::isalpha(static_cast<unsigned char>(word.front())))
      fail(line, fmt::format("expected an APT statement (WORD or WORD/values), found '{}'", printable(s, 40)));
    if (after_fini_) fail(line, fmt::format("APT statement '{}' after FINI", printable(word)));

    if (iequals(word, "PARTNO")) {
      if (!rest.empty() && rest.front() == '/') rest.remove_prefix(1);
      path_.part_name = std::string(trim(rest));
      return;
    }
    const bool has_slash = !rest.empty() && rest.front() == '/';
    if (!known(word)) {
      // A coordinate system other than the identity moves the poses that follow; machplan
      // keeps them as written and says so apart from the harmless identity ones.
      if (iequals(word, "CSYS") && has_slash && !identity_csys(split_all(rest.substr(1)))) {
        if (csys_count_++ == 0) csys_first_line_ = line;
        return;
      }
      // Cutter compensation moves the tool off the points written by its radius.
      if (iequals(word, "CUTCOM") && has_slash) {
        const auto v = split_all(rest.substr(1));
        if (!v.empty() && (iequals(v[0], "LEFT") || iequals(v[0], "RIGHT")) && cutcom_count_++ == 0) cutcom_first_line_ = line;
      }
      return skip(word, line);
    }
    if (!rest.empty() && !has_slash)
      fail(line, fmt::format("APT statement '{}': expected '/' or the end of the statement, found '{}'",
                             printable(word), printable(rest, 40)));
    const Fields args = split_commas(has_slash ? rest.substr(1) : std::string_view{});
    const bool bare_rapid = iequals(word, "RAPID") && args.count == 0;  // RAPID and RAPID/
    if (has_slash && args.count == 0 && !bare_rapid)
      fail(line, fmt::format("APT statement '{}': no values after '/'", printable(word)));
    if (circle_line_ > 0 && (iequals(word, "CIRCLE") || iequals(word, "FINI") || iequals(word, "CYCLE") ||
                             iequals(word, "FROM") || iequals(word, "GODLTA") || (iequals(word, "RAPID") && !bare_rapid)))
      fail(line, fmt::format("{} after the CIRCLE of line {}, which needs a GOTO to end it", printable(word), circle_line_));

    if (iequals(word, "GOTO")) return go_to(args, line, "GOTO");
    if (iequals(word, "FROM")) {
      rapid_ = true;
      return go_to(args, line, "FROM");
    }
    if (iequals(word, "GODLTA")) return go_to(args, line, "GODLTA");
    if (iequals(word, "CIRCLE")) return circle(args, line);
    if (iequals(word, "CYCLE")) return cycle(args, line);
    if (iequals(word, "TLAXIS")) return tool_axis(args, line);
    if (iequals(word, "FEDRAT")) return feed(args, line);
    if (iequals(word, "CUTTER")) return cutter(args, line);
    if (iequals(word, "LOAD")) return load(args, line);
    if (iequals(word, "CSI_SET_FLUTE_LENGTH") || iequals(word, "CSI_SET_EXTENSION_LENGTH")) return tool_length(word, args, line);
    if (iequals(word, "RAPID")) {
      rapid_ = true;
      if (bare_rapid) return;
      return go_to(args, line, "RAPID");
    }
    if (iequals(word, "MULTAX")) {
      if (args.count == 0 || (args.count == 1 && iequals(args.at[0], "ON"))) {
        path_.multiaxis = true;
      } else if (!(args.count == 1 && iequals(args.at[0], "OFF"))) {
        fail(line, "MULTAX: expected MULTAX, MULTAX/ON or MULTAX/OFF");
      }
      return;
    }
    if (iequals(word, "UNITS") || iequals(word, "UNIT")) {
      if (args.count == 1 && (iequals(args.at[0], "MM") || iequals(args.at[0], "MILLIMETERS"))) {
        mm_per_unit_ = 1.0;
      } else if (args.count == 1 && (iequals(args.at[0], "INCHES") || iequals(args.at[0], "INCH"))) {
        mm_per_unit_ = kMmPerInch;
      } else {
        fail(line, fmt::format("{}: expected {}/MM or {}/INCHES", printable(word), printable(word), printable(word)));
      }
      return;
    }
    // FINI
    no_values(word, args, line);
    if (circle_line_ > 0) fail(line, fmt::format("FINI after the CIRCLE of line {}, which needs a GOTO to end it", circle_line_));
    after_fini_ = true;
  }

  static bool known(std::string_view word) {
    for (const char* k : {"GOTO", "FROM", "GODLTA", "CIRCLE", "CYCLE", "TLAXIS", "FEDRAT", "CUTTER", "LOAD",
                          "CSI_SET_FLUTE_LENGTH", "CSI_SET_EXTENSION_LENGTH", "RAPID", "MULTAX", "UNITS", "UNIT", "FINI"})
      if (iequals(word, k)) return true;
    return false;
  }

  static std::vector<std::string_view> split_all(std::string_view s) {
    std::vector<std::string_view> all;
    for (std::size_t start = 0;;) {
      const std::size_t comma = s.find(',', start);
      all.push_back(trim(s.substr(start, comma == std::string_view::npos ? s.npos : comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    return all;
  }

  // CSYS/r11, r12, r13, tx, r21, ..., tz: true when it is the identity (to 1e-9).
  static bool identity_csys(const std::vector<std::string_view>& v) {
    if (v.size() != 12) return false;
    for (std::size_t k = 0; k < 12; ++k) {
      double x = 0;
      std::string_view f = v[k];
      if (!f.empty() && f.front() == '+') f.remove_prefix(1);
      const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), x);
      if (ec != std::errc() || end != f.data() + f.size()) return false;
      const double want = (k == 0 || k == 5 || k == 10) ? 1.0 : 0.0;
      if (std::abs(x - want) > 1e-9) return false;
    }
    return true;
  }

  // A statement that carries nothing for the tool path, counted per kind.
  void skip(std::string_view word, int line) {
    std::string key(word);
    for (char& c : key) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    const auto it = std::find_if(path_.skipped.begin(), path_.skipped.end(),
                                 [&](const ToolPath::SkippedKind& k) { return k.statement == key; });
    if (it == path_.skipped.end()) path_.skipped.push_back({key, line, 1});
    else ++it->count;
  }

 public:
  // The warning of the statements that change what the path means (a CSYS not applied).
  void finish_warnings() {
    if (csys_count_ > 0)
      path_.warnings.push_back(fmt::format("{}:{}: APT statement 'CSYS' with a transformation other than the identity{}: "
                                           "the poses after it are kept in the coordinates written, not transformed",
                                           path_.source, csys_first_line_,
                                           csys_count_ > 1 ? fmt::format(" ({} statements)", csys_count_) : ""));
    if (cutcom_count_ > 0)
      path_.warnings.push_back(fmt::format("{}:{}: cutter compensation (CUTCOM/LEFT or RIGHT){}: the control offsets "
                                           "the tool from the points written by its radius; they are checked as written",
                                           path_.source, cutcom_first_line_,
                                           cutcom_count_ > 1 ? fmt::format(" ({} statements)", cutcom_count_) : ""));
  }

 private:
  void no_values(std::string_view word, const Fields& args, int line) const {
    if (args.count != 0) fail(line, fmt::format("{} takes no values", printable(word)));
  }

  Eigen::Vector3d point3(const Fields& args, std::size_t from, int line, const char* what) const {
    return Eigen::Vector3d(number(args.at[from], line, fmt::format("{} x", what).c_str()),
                           number(args.at[from + 1], line, fmt::format("{} y", what).c_str()),
                           number(args.at[from + 2], line, fmt::format("{} z", what).c_str()));
  }

  // GOTO, FROM, RAPID with values, GODLTA (`what`; relative to the last pose).
  void go_to(const Fields& args, int line, const char* what) {
    const bool relative = std::string_view(what) == "GODLTA";
    if (args.count != 3 && args.count != 6)
      fail(line, fmt::format("{}: expected 3 values (x, y, z) or 6 (x, y, z, i, j, k), found {}", what, args.count));
    if (relative && path_.poses.empty()) fail(line, "GODLTA before any position");
    ToolPose pose;
    pose.line = line;
    pose.tip_mm = point3(args, 0, line, what) * mm_per_unit_;
    if (relative) pose.tip_mm += path_.poses.back().tip_mm;
    if (args.count == 6) {
      pose.axis = unit_axis({number(args.at[3], line, "GOTO i"), number(args.at[4], line, "GOTO j"),
                             number(args.at[5], line, "GOTO k")},
                            line);
      path_.multiaxis = true;
    } else {
      pose.axis = axis_;
    }
    pose.feed_mm_per_min = feed_mm_per_min_;
    pose.rapid = rapid_;
    rapid_ = false;
    if (circle_line_ > 0) return arc_to(pose);
    if (cycle_) return drill(pose);
    add_pose(pose);
  }

  // CIRCLE/cx, cy, cz, i, j, k[, r, ...]: kept until the GOTO that ends it.
  void circle(const Fields& args, int line) {
    if (args.count < 6)
      fail(line, fmt::format("CIRCLE: expected at least 6 values (cx, cy, cz, i, j, k[, r]), found {}", args.count));
    if (path_.poses.empty()) fail(line, "CIRCLE before any position: the arc has no start point");
    circle_center_ = point3(args, 0, line, "CIRCLE") * mm_per_unit_;
    circle_axis_ = unit_axis({number(args.at[3], line, "CIRCLE i"), number(args.at[4], line, "CIRCLE j"),
                              number(args.at[5], line, "CIRCLE k")},
                             line);
    circle_radius_ = args.count >= 7 ? number(args.at[6], line, "CIRCLE r") * mm_per_unit_ : -1.0;
    circle_line_ = line;
  }

  void arc_to(ToolPose end) {
    const int line = circle_line_;
    circle_line_ = 0;
    const ToolPose start = path_.poses.back();  // a copy: adding poses may move the vector
    const Eigen::Vector3d a = circle_axis_;
    const Eigen::Vector3d rs = start.tip_mm - circle_center_, re = end.tip_mm - circle_center_;
    const Eigen::Vector3d vs = rs - rs.dot(a) * a, ve = re - re.dot(a) * a;
    const double r = vs.norm(), tol = options_.arc_end_tolerance_mm;
    if (!(r > tol)) fail(line, fmt::format("CIRCLE: the start point lies on the axis (radius {:g} mm)", r));
    if (circle_radius_ >= 0 && std::abs(circle_radius_ - r) > tol)
      fail(line, fmt::format("CIRCLE: radius {:g} mm but the start point is {:g} mm from the axis", circle_radius_, r));
    if (std::abs(ve.norm() - r) > tol)
      fail(end.line, fmt::format("the GOTO ending the CIRCLE of line {} is {:g} mm from the axis, the start {:g} mm: "
                                 "not on one circle",
                                 line, ve.norm(), r));
    double sweep = std::atan2(a.dot(vs.cross(ve)), vs.dot(ve));
    if (sweep < 0) sweep += 2 * kPi;
    if ((ve - vs).norm() <= tol && sweep < kPi) sweep = 2 * kPi;  // back to the start: a full turn
    ToolArc arc;
    arc.center_mm = circle_center_;
    arc.axis = a;
    arc.radius_mm = r;
    arc.sweep_rad = sweep;
    arc.line = line;
    arc.first_pose = path_.poses.size();
    const toolpath_internal::ArcWalk walk(circle_center_, a, start.tip_mm, end.tip_mm, sweep, options_);
    const std::size_t n = walk.n;
    if (n > options_.max_poses) fail(line, fmt::format("CIRCLE needs {} poses, beyond the reader's limit", n));
    const int index = static_cast<int>(path_.arcs.size());
    for (std::size_t k = 1; k < n; ++k) {
      const double f = static_cast<double>(k) / static_cast<double>(n);
      ToolPose p = end;
      p.tip_mm = walk.at(k);
      p.axis = (start.axis + f * (end.axis - start.axis)).normalized();
      p.arc = index;
      add_pose(p);
    }
    end.arc = index;
    add_pose(end);
    arc.last_pose = path_.poses.size() - 1;
    path_.arcs.push_back(arc);
  }

  // CYCLE/type, FEDTO, d, ...: each GOTO until CYCLE/OFF becomes a plunge. Cycles list more
  // options than Fields holds, so the statement is split again in full here.
  void cycle(const Fields& args, int line) {
    if (args.count == 1 && (iequals(args.at[0], "OFF") || iequals(args.at[0], "INIT") || iequals(args.at[0], "CLEAR") ||
                            iequals(args.at[0], "ON"))) {
      if (iequals(args.at[0], "OFF")) cycle_ = false;
      return;
    }
    const std::string_view s = current_statement_;
    const std::vector<std::string_view> all = split_all(s.substr(s.find('/') + 1));
    double depth = -1, rapto = 0, rtrcto = 0, feed = feed_mm_per_min_;
    // Keyword, value pairs after the type; a keyword without a value is refused.
    if (all.size() % 2 == 0) fail(line, fmt::format("CYCLE: '{}' has no value", printable(all.back())));
    for (std::size_t k = 1; k + 1 < all.size(); k += 2) {
      const std::string_view key = all[k];
      const double v = number(all[k + 1], line, "CYCLE value");
      if (iequals(key, "FEDTO")) depth = v * mm_per_unit_;
      else if (iequals(key, "RAPTO")) rapto = v * mm_per_unit_;
      else if (iequals(key, "RTRCTO")) rtrcto = v * mm_per_unit_;
      else if (iequals(key, "MMPM")) feed = v;
      else if (iequals(key, "IPM")) feed = v * kMmPerInch;
    }
    if (depth < 0) fail(line, fmt::format("CYCLE/{}: no FEDTO depth (or a negative one)", printable(all[0])));
    if (!(feed > 0)) fail(line, fmt::format("CYCLE/{}: no feed (MMPM or IPM value, or an earlier FEDRAT)", printable(all[0])));
    cycle_ = true;
    cycle_depth_ = depth;
    cycle_rapto_ = rapto;
    cycle_rtrcto_ = rtrcto;
    cycle_feed_ = feed;
  }

  // One hole of a cycle at its top point `top`.
  void drill(const ToolPose& top) {
    const Eigen::Vector3d a = top.axis;
    auto at = [&](double along, bool rapid, double feed) {
      ToolPose p = top;
      p.tip_mm = top.tip_mm + along * a;
      p.rapid = rapid;
      p.feed_mm_per_min = feed;
      add_pose(p);
    };
    if (path_.poses.empty() || (path_.poses.back().tip_mm - (top.tip_mm + cycle_rtrcto_ * a)).norm() > 1e-9)
      at(cycle_rtrcto_, true, feed_mm_per_min_);
    if (cycle_rapto_ != cycle_rtrcto_) at(cycle_rapto_, true, feed_mm_per_min_);
    at(-cycle_depth_, false, cycle_feed_);
    at(cycle_rtrcto_, true, feed_mm_per_min_);
  }

  void tool_axis(const Fields& args, int line) {
    if (args.count != 3)
      fail(line, fmt::format("TLAXIS: only the form TLAXIS/i, j, k is supported (found {} values)", args.count));
    axis_ = unit_axis({number(args.at[0], line, "TLAXIS i"), number(args.at[1], line, "TLAXIS j"),
                       number(args.at[2], line, "TLAXIS k")},
                      line);
  }

  void feed(const Fields& args, int line) {
    // FEDRAT/f, FEDRAT/MMPM, f, FEDRAT/f, MMPM (and IPM); MMPR / IPR are per revolution.
    std::string_view value, mode;
    if (args.count == 1) {
      value = args.at[0];
    } else if (args.count == 2) {
      const bool first_is_word = !args.at[0].empty() && std::isalpha(static_cast<unsigned char>(args.at[0][0]));
      mode = first_is_word ? args.at[0] : args.at[1];
      value = first_is_word ? args.at[1] : args.at[0];
    } else {
      fail(line, fmt::format("FEDRAT: expected FEDRAT/f or FEDRAT/MMPM, f, found {} values", args.count));
    }
    double scale = mm_per_unit_;
    if (!mode.empty()) {
      if (iequals(mode, "MMPM")) {
        scale = 1.0;
      } else if (iequals(mode, "IPM")) {
        scale = kMmPerInch;
      } else if (iequals(mode, "MMPR") || iequals(mode, "IPR")) {
        fail(line, fmt::format("FEDRAT: per-revolution feed '{}' is not supported", printable(mode)));
      } else {
        fail(line, fmt::format("FEDRAT: unknown feed mode '{}' (expected MMPM or IPM)", printable(mode)));
      }
    }
    const double f = number(value, line, "FEDRAT");
    if (!(f > 0.0)) fail(line, fmt::format("FEDRAT: feed {} must be positive", f));
    feed_mm_per_min_ = f * scale;
  }

  void cutter(const Fields& args, int line) {
    if (args.count < 1 || args.count > 7)
      fail(line, fmt::format("CUTTER: expected 1 to 7 values (d, r, e, f, a, b, h), found {}", args.count));
    std::array<double, 7> v{};
    for (std::size_t k = 0; k < args.count; ++k) v[k] = number(args.at[k], line, "CUTTER");
    ToolPath::Cutter c;
    c.diameter_mm = v[0] * mm_per_unit_;
    c.corner_radius_mm = v[1] * mm_per_unit_;
    c.length_mm = args.count == 7 ? v[6] * mm_per_unit_ : 0.0;
    if (!(c.diameter_mm > 0.0)) fail(line, fmt::format("CUTTER: diameter {} must be positive", v[0]));
    if (c.corner_radius_mm < 0.0 || c.corner_radius_mm > c.diameter_mm / 2 * (1 + 1e-12))
      fail(line, fmt::format("CUTTER: corner radius {} must lie between 0 and half the diameter ({})", v[1],
                             v[0] / 2));
    if (c.length_mm < 0.0) fail(line, fmt::format("CUTTER: length {} must not be negative", v[6]));
    c.line = line;
    path_.cutter = c;
    pending_cutter_ = c;
    // Right after a LOAD, before any move: it describes the tool just loaded.
    if (tool_ >= 0 && path_.tools[tool_].poses == 0) describe_tool(line);
  }

  // LOAD/TOOL, n[, ...]
  void load(const Fields& args, int line) {
    if (args.count < 2 || !iequals(args.at[0], "TOOL"))
      fail(line, "LOAD: expected LOAD/TOOL, n (a tool number)");
    const double n = number(args.at[1], line, "LOAD/TOOL");
    if (n != std::floor(n) || n < 0 || n > 1e6)
      fail(line, fmt::format("LOAD/TOOL: tool number {} must be an integer within 0 .. 1000000", printable(args.at[1])));
    load_tool(static_cast<int>(n), line);
  }

  // CAMWorks' CSI_SET_FLUTE_LENGTH/l and CSI_SET_EXTENSION_LENGTH/l: of the tool loaded last.
  void tool_length(std::string_view word, const Fields& args, int line) {
    if (args.count != 1) fail(line, fmt::format("{}: expected one length", printable(word)));
    const double l = number(args.at[0], line, std::string(word).c_str()) * mm_per_unit_;
    if (!(l > 0.0)) fail(line, fmt::format("{}: length {} must be positive", printable(word), printable(args.at[0])));
    if (tool_ < 0) tool_ = new_tool(-1, line);
    (iequals(word, "CSI_SET_FLUTE_LENGTH") ? path_.tools[tool_].flute_mm : path_.tools[tool_].extension_mm) = l;
  }

  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
  double feed_mm_per_min_ = 0.0;
  double mm_per_unit_ = 1.0;
  bool rapid_ = false;
  bool after_fini_ = false;
  // A CIRCLE waiting for its GOTO (circle_line_ > 0).
  int circle_line_ = 0;
  Eigen::Vector3d circle_center_ = Eigen::Vector3d::Zero(), circle_axis_ = Eigen::Vector3d::UnitZ();
  double circle_radius_ = -1.0;
  // A canned cycle in force.
  bool cycle_ = false;
  double cycle_depth_ = 0, cycle_rapto_ = 0, cycle_rtrcto_ = 0, cycle_feed_ = 0;
  std::string_view current_statement_;
  // CSYS statements that move the poses after them (not applied).
  int csys_first_line_ = 0;
  std::size_t csys_count_ = 0;
  // CUTCOM/LEFT and CUTCOM/RIGHT statements (compensation not applied).
  int cutcom_first_line_ = 0;
  std::size_t cutcom_count_ = 0;
};

// ---------------------------------------------------------------------------------------------
// CSV

enum Column { cx, cy, cz, ci, cj, ck, cfeed, kColumns };

bool column_of(std::string_view name, Column& c) {
  static constexpr std::array<std::pair<const char*, Column>, 8> names{
      {{"x", cx}, {"y", cy}, {"z", cz}, {"i", ci}, {"j", cj}, {"k", ck}, {"feed", cfeed}, {"f", cfeed}}};
  for (const auto& [n, col] : names)
    if (iequals(name, n)) {
      c = col;
      return true;
    }
  return false;
}

bool looks_like_header(std::string_view line) {
  const Fields f = split_commas(line);
  if (f.count == 0 || f.count > kMaxFields) return false;
  for (std::size_t k = 0; k < f.count; ++k) {
    Column c;
    if (!column_of(f.at[k], c)) return false;
  }
  return true;
}

class CsvReader : public Reader {
 public:
  using Reader::Reader;

  ToolPath read(std::string_view text) {
    reserve_for(text);
    LineReader lines(text);
    std::string_view line;
    while (lines.next(line)) {
      const int number = lines.line_number();
      if (line.size() > options_.max_line_bytes)
        fail(number, fmt::format("line is longer than {} bytes", options_.max_line_bytes));
      line = trim(line);
      if (line.empty() || line.front() == '#') continue;
      const Fields f = split_commas(line);
      if (width_ == 0) {
        if (!f.at[0].empty() && std::isalpha(static_cast<unsigned char>(f.at[0][0])) &&
            !iequals(f.at[0], "inf") && !iequals(f.at[0], "nan")) {
          header(f, number);
          continue;
        }
        headerless(f, number);
      }
      row(f, number);
    }
    return finish();
  }

 private:
  void header(const Fields& f, int line) {
    if (f.count > kColumns)
      fail(line, fmt::format("CSV header has {} columns; at most x, y, z, i, j, k, feed are known", f.count));
    bool seen[kColumns] = {};
    for (std::size_t k = 0; k < f.count; ++k) {
      Column c;
      if (!column_of(f.at[k], c))
        fail(line, fmt::format("CSV header: unknown column '{}' (known: x, y, z, i, j, k, feed)", printable(f.at[k])));
      if (seen[c]) fail(line, fmt::format("CSV header: column '{}' appears twice", printable(f.at[k])));
      seen[c] = true;
      column_at_[k] = c;
    }
    if (!seen[cx] || !seen[cy] || !seen[cz]) fail(line, "CSV header: columns x, y and z are required");
    if ((seen[ci] || seen[cj] || seen[ck]) && !(seen[ci] && seen[cj] && seen[ck]))
      fail(line, "CSV header: columns i, j and k go together (all three or none)");
    has_axis_ = seen[ci];
    has_feed_ = seen[cfeed];
    width_ = f.count;
  }

  void headerless(const Fields& f, int line) {
    if (f.count != 3 && f.count != 6 && f.count != 7)
      fail(line, fmt::format("CSV row has {} fields; without a header a row holds 3 (x, y, z), 6 (x, y, z, i, j, k) "
                             "or 7 (x, y, z, i, j, k, feed)",
                             f.count));
    for (std::size_t k = 0; k < f.count; ++k) column_at_[k] = static_cast<Column>(k);
    has_axis_ = f.count >= 6;
    has_feed_ = f.count == 7;
    width_ = f.count;
  }

  void row(const Fields& f, int line) {
    if (f.count != width_)
      fail(line, fmt::format("CSV row has {} fields, expected {}", f.count, width_));
    static constexpr const char* names[kColumns] = {"x", "y", "z", "i", "j", "k", "feed"};
    std::array<double, kColumns> v{0, 0, 0, 0, 0, 1, 0};
    for (std::size_t k = 0; k < width_; ++k) v[column_at_[k]] = number(f.at[k], line, names[column_at_[k]]);
    ToolPose pose;
    pose.line = line;
    pose.tip_mm = {v[cx], v[cy], v[cz]};
    if (has_axis_) {
      pose.axis = unit_axis({v[ci], v[cj], v[ck]}, line);
      path_.multiaxis = true;
    }
    if (has_feed_) {
      if (!(v[cfeed] > 0.0)) fail(line, fmt::format("feed {} must be positive", v[cfeed]));
      pose.feed_mm_per_min = v[cfeed];
    }
    add_pose(pose);
  }

  std::size_t width_ = 0;  // fields per row; 0 until the header or first row is seen
  std::array<Column, kMaxFields> column_at_{};
  bool has_axis_ = false, has_feed_ = false;
};

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

void ToolPathReadOptions::validate() const {
  const std::pair<const char*, std::size_t> limits[] = {{"max_poses", max_poses},
                                                        {"max_line_bytes", max_line_bytes},
                                                        {"max_statement_bytes", max_statement_bytes},
                                                        {"max_file_bytes", max_file_bytes}};
  for (const auto& [name, value] : limits)
    if (value == 0) throw InputError::field(name, "is 0; it must be positive");
  if (!std::isfinite(arc_step_rad) || !(arc_step_rad > 0) || arc_step_rad > kPi / 2)
    throw InputError::field("arc_step_rad", fmt::format("is {}, must lie in (0, pi/2]", arc_step_rad));
  if (!std::isfinite(arc_tolerance_mm) || !(arc_tolerance_mm > 0) || arc_tolerance_mm > 100)
    throw InputError::field("arc_tolerance_mm", fmt::format("is {}, must lie in (0, 100] mm", arc_tolerance_mm));
  if (!std::isfinite(arc_end_tolerance_mm) || !(arc_end_tolerance_mm > 0) || arc_end_tolerance_mm > 100)
    throw InputError::field("arc_end_tolerance_mm", fmt::format("is {}, must lie in (0, 100] mm", arc_end_tolerance_mm));
}

ToolPath read_apt(std::string_view text, const std::string& source, const ToolPathReadOptions& options) {
  options.validate();
  return AptReader(source, options).read(text);
}

ToolPath read_toolpath_csv(std::string_view text, const std::string& source, const ToolPathReadOptions& options) {
  options.validate();
  return CsvReader(source, options).read(text);
}

ToolPathFormat sniff_toolpath_format(std::string_view text, const std::string& source) {
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    line = trim(line.substr(0, std::min<std::size_t>(line.size(), 4096)));
    if (line.empty() || line.front() == '#' || line.rfind("$$", 0) == 0) continue;
    const auto c = static_cast<unsigned char>(line.front());
    if (std::isdigit(c) || c == '+' || c == '-' || c == '.' || looks_like_header(line)) return ToolPathFormat::csv;
    if (std::isalpha(c)) return ToolPathFormat::apt;
    throw InputError(source, lines.line_number(),
                     fmt::format("cannot tell whether this is an APT/CLDATA or a CSV tool path: line starts with '{}'",
                                 printable(line, 20)));
  }
  throw InputError(source, 0, "the tool path holds no pose");
}

ToolPath read_toolpath(std::string_view text, const std::string& source, const ToolPathReadOptions& options) {
  return sniff_toolpath_format(text, source) == ToolPathFormat::csv ? read_toolpath_csv(text, source, options)
                                                                    : read_apt(text, source, options);
}

ToolPath read_toolpath_file(const std::string& path, const ToolPathReadOptions& options) {
  options.validate();
  const std::string text = read_text_file(path, options.max_file_bytes);
  const std::string ext = lower_extension(path);
  if (ext == ".cl" || ext == ".apt" || ext == ".cls") return read_apt(text, path, options);
  if (ext == ".csv") return read_toolpath_csv(text, path, options);
  if (ext == ".ngc" || ext == ".nc" || ext == ".gcode" || ext == ".tap" || ext == ".g")
  {
    GcodeOptions g;
    g.dialect = GcodeDialect::automatic;  // CAM posts for GRBL as well as for LinuxCNC
    return toolpath_from_gcode(read_gcode(text, path, g), options);
  }
  return read_toolpath(text, path, options);
}

std::string ToolPath::Tool::name() const {
  return number >= 0 ? fmt::format("T{}", number) : fmt::format("the tool of line {}", line);
}

std::string skipped_summary(const ToolPath& path) {
  if (path.skipped.empty()) return {};
  std::size_t total = 0;
  std::string kinds;
  for (const ToolPath::SkippedKind& k : path.skipped) {
    total += k.count;
    kinds += fmt::format("{}{}{} ({}line {})", kinds.empty() ? "" : ", ", printable(k.statement),
                         k.count > 1 ? fmt::format(" x{}", k.count) : "", k.count > 1 ? "first at " : "", k.first_line);
  }
  return fmt::format("{}: skipped {} statement{} no tool-path geometry: {}", path.source, total,
                     total > 1 ? "s that carry" : " that carries", kinds);
}

ToolPathSummary summarize(const ToolPath& path) {
  ToolPathSummary s;
  s.poses = path.poses.size();
  if (path.poses.empty()) return s;
  s.min_mm = s.max_mm = path.poses.front().tip_mm;
  s.min_tilt_rad = std::numeric_limits<double>::infinity();
  s.max_tilt_rad = -s.min_tilt_rad;
  for (std::size_t k = 0; k < path.poses.size(); ++k) {
    const ToolPose& p = path.poses[k];
    s.min_mm = s.min_mm.cwiseMin(p.tip_mm);
    s.max_mm = s.max_mm.cwiseMax(p.tip_mm);
    const double tilt = std::atan2(p.axis.head<2>().norm(), p.axis.z());
    s.min_tilt_rad = std::min(s.min_tilt_rad, tilt);
    s.max_tilt_rad = std::max(s.max_tilt_rad, tilt);
    if (p.rapid) ++s.rapid_poses;
    if (k == 0) continue;
    const double step = (p.tip_mm - path.poses[k - 1].tip_mm).norm();
    (p.rapid ? s.rapid_length_mm : s.feed_length_mm) += step;
    if (step > s.max_step_mm) {
      s.max_step_mm = step;
      s.max_step_line = p.line;
    }
  }
  return s;
}

}  // namespace machplan
