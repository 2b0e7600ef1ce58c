// A G-code job as a tool path for placement (toolpath.h): the moves the interpreter makes of it,
// each tool change (M6, M61) starting the moves of its tool, and a LinuxCNC tool table for what
// the program does not say of its tools.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <string>
#include <string_view>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"
#include "engine/programs/gcode.h"
#include "engine/programs/internal/arc_walk.h"
#include "engine/programs/toolpath.h"

namespace machplan {

namespace {

using text_scan::printable;

// The tip's positions along an arc move from `from`, as the APT reader places them along a
// CIRCLE (internal/arc_walk.h); the last is the move's end.
std::vector<Eigen::Vector3d> arc_points(const Move& m, const Eigen::Vector3d& from, const ToolPathReadOptions& options,
                                        const std::string& source) {
  int a = 0, b = 1, n = 2;  // the plane's axes in the centre's order, and its normal (a x b)
  if (m.plane == Move::Plane::xz) a = 2, b = 0, n = 1;
  if (m.plane == Move::Plane::yz) a = 1, b = 2, n = 0;
  const double t0 = std::atan2(from[b] - m.center.y(), from[a] - m.center.x());
  const double t1 = std::atan2(m.end[b] - m.center.y(), m.end[a] - m.center.x());
  double sweep = m.clockwise ? t0 - t1 : t1 - t0;  // >= 0 once wrapped
  while (sweep <= 1e-12) sweep += 2 * M_PI;
  sweep += 2 * M_PI * m.turns;
  Eigen::Vector3d centre = from, axis = Eigen::Vector3d::Zero();
  centre[a] = m.center.x();
  centre[b] = m.center.y();
  axis[n] = m.clockwise ? -1.0 : 1.0;
  const toolpath_internal::ArcWalk walk(centre, axis, from, m.end, sweep, options);
  if (walk.n > options.max_poses)
    throw InputError(source, m.line, fmt::format("an arc needing {} poses, beyond the reader's limit", walk.n));
  std::vector<Eigen::Vector3d> out;
  for (std::size_t k = 1; k < walk.n; ++k) out.push_back(walk.at(k));
  out.push_back(m.end);
  return out;
}
}  // namespace

ToolPath toolpath_from_gcode(const Program& program, const ToolPathReadOptions& options) {
  ToolPath path;
  path.source = program.source;
  std::size_t next_event = 0;
  int tool = -1;
  Eigen::Vector3d at = program.start;
  for (std::size_t i = 0; i < program.moves.size(); ++i) {
    for (; next_event < program.events.size() && program.events[next_event].before_move <= i; ++next_event) {
      const ProgramEvent& e = program.events[next_event];
      if (e.kind != ProgramEvent::Kind::tool_change) continue;
      tool = -1;
      for (std::size_t k = 0; k < path.tools.size(); ++k)
        if (path.tools[k].number == e.number) tool = static_cast<int>(k);
      if (tool < 0) {
        ToolPath::Tool t;
        t.number = e.number;
        t.line = e.line;
        path.tools.push_back(t);
        tool = static_cast<int>(path.tools.size()) - 1;
      }
    }
    const Move& m = program.moves[i];
    if (!is_motion(m)) continue;
    const std::vector<Eigen::Vector3d> tips = m.kind == Move::Kind::arc ? arc_points(m, at, options, program.source) : std::vector{m.end};
    for (const Eigen::Vector3d& tip : tips) {
      if (path.poses.size() >= options.max_poses)
        throw InputError(program.source, m.line, fmt::format("more than {} poses", options.max_poses));
      ToolPose pose;
      pose.tip_mm = tip;
      pose.feed_mm_per_min = m.kind == Move::Kind::rapid ? 0.0 : m.feed_mm_per_min;
      pose.rapid = m.kind == Move::Kind::rapid;
      pose.line = m.line;
      pose.tool = tool;
      path.poses.push_back(pose);
      if (tool >= 0) ++path.tools[tool].poses;
    }
    at = m.end;
  }
  if (path.poses.empty()) throw InputError(program.source, 0, "the program makes no move");
  return path;
}

std::vector<ToolTableEntry> read_tool_table_file(const std::string& path) {
  const std::string text = read_text_file(path, std::size_t{16} << 20);
  std::vector<ToolTableEntry> out;
  int line_number = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    std::string_view line(text.data() + start, end - start);
    start = end + 1;
    ++line_number;
    if (const std::size_t c = line.find(';'); c != std::string_view::npos) line = line.substr(0, c);
    ToolTableEntry e;
    e.line = line_number;
    bool has_t = false;
    for (std::size_t k = 0; k < line.size();) {
      const char ch = line[k];
      if (std::isspace(static_cast<unsigned char>(ch))) {
        ++k;
        continue;
      }
      const char letter = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
      std::size_t j = k + 1;
      while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
      const std::string word(line.substr(k + 1, j - k - 1));
      k = j;
      if (std::string_view("TPXYZABCUVWDIJQ").find(letter) == std::string_view::npos)
        throw InputError(path, line_number, fmt::format("'{}' is not a tool table word (T P X Y Z A B C U V W D I J Q)", printable(std::string(1, ch))));
      char* stop = nullptr;
      const double v = std::strtod(word.c_str(), &stop);
      if (word.empty() || *stop != '\0' || !std::isfinite(v) || std::abs(v) > 1e6)
        throw InputError(path, line_number, fmt::format("{}: '{}' is not a number within +-1e6", letter, printable(word, 20)));
      if (letter == 'T') {
        if (v != std::floor(v) || v < 0) throw InputError(path, line_number, fmt::format("T{}: a tool number is a whole number", word));
        e.number = static_cast<int>(v), has_t = true;
      }
      if (letter == 'Z') e.length_mm = v;
      if (letter == 'D') {
        if (v < 0) throw InputError(path, line_number, fmt::format("D{}: a diameter is not negative", word));
        e.diameter_mm = v;
      }
    }
    if (has_t) {
      out.push_back(e);
    } else if (line.find_first_not_of(" \t\r") != std::string_view::npos) {
      throw InputError(path, line_number, "a tool table line needs its T word");
    }
  }
  return out;
}

void apply_tool_table(ToolPath& path, const std::vector<ToolTableEntry>& table, const std::string& table_file) {
  for (ToolPath::Tool& t : path.tools) {
    for (const ToolTableEntry& e : table) {
      if (e.number != t.number) continue;
      if (!t.cutter && e.diameter_mm > 0) {
        t.cutter = ToolPath::Cutter{};
        t.cutter->diameter_mm = e.diameter_mm;
      }
      if (e.length_mm > 0) t.gauge_mm = e.length_mm;
      t.table = fmt::format("{}:{}", table_file, e.line);
    }
  }
}

}  // namespace machplan
