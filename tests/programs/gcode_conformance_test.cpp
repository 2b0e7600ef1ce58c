// Conformance of machplan's G-code reader with LinuxCNC's interpreter.
//
// For every program in datasets/programs/conformance/ and every sample LinuxCNC installs under
// /usr/share/linuxcnc/ncfiles/, this reads the program with machplan's reader (in this process,
// as `machplan program FILE` does: a sanitized command-line run per program and dialect cost
// more than the rest of the test) and runs `rs274 -g FILE`, turns rs274's canonical calls into
// moves, and requires:
//   * both accept: the same sequence of moves (kind, end point and arc centre within the
//     tolerance below, feed, direction, turns, dwell seconds, spindle speed);
//   * rs274 rejects: machplan rejects too (InputError, "FILE:LINE: message": exit 2 on the
//     command line);
//   * rs274 accepts and machplan refuses: only for a feature machplan does not support, so the
//     message must say "not supported".
// Our own programs state what they expect on their first line:
//   (expect: match)           both accept and the moves match
//   (expect: refuse TEXT)     rs274 accepts; machplan refuses with a message containing TEXT
//   (expect: error TEXT)      rs274 rejects; machplan rejects with a message containing TEXT
//
// rs274 prints coordinates in the program's current length units (USE_LENGTH_UNITS) with four
// decimals, in program coordinates (machplan adds the work offsets rs274 announces); SET_FEED_RATE takes the units in effect when it is issued. ARC_FEED's rotation is
// +n for n counter-clockwise turns and -n for clockwise; machplan's Move::turns is n - 1.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"

namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "'\\''";
    else q += c;
  }
  return q + "'";
}

// Runs `command` (through the shell) with stdout and stderr captured in files under `dir`.
RunResult run(const std::string& command, const fs::path& dir) {
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string full = command + " </dev/null >" + quote(out.string()) + " 2>" + quote(err.string());
  const int status = std::system(full.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

// One move in a common form for comparison.
struct Expected {
  std::string kind;
  std::array<double, 3> end{0, 0, 0};
  std::array<double, 2> center{0, 0};
  double feed = 0, seconds = 0, speed = 0;
  bool clockwise = false;
  int turns = 0;
  std::string text;  // the canonical call, for messages
};

struct Rs274Program {
  std::vector<Expected> moves;
  std::vector<std::string> unmodelled;  // canonical calls that move or change tools, that we do not model
  bool inches_seen = false;
};

std::vector<double> numbers(const std::string& args) {
  std::vector<double> v;
  std::stringstream ss(args);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      v.push_back(std::stod(item));
    } catch (...) {
      v.push_back(NAN);
    }
  }
  return v;
}

Rs274Program parse_rs274(const std::string& out) {
  Rs274Program p;
  static const std::regex call(R"(^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$)");
  double scale = 1.0, feed = 0.0, speed = 0.0;
  // Canonical moves are in program coordinates; machplan reports machine coordinates, so the
  // work offsets rs274 announces (SET_G5X_OFFSET, SET_G92_OFFSET) are added. Arcs in the XZ
  // and YZ planes come in the plane's axis order (ARC_FEED's first and second axes).
  std::array<double, 3> g5x{0, 0, 0}, g92{0, 0, 0};
  char plane = 'z';  // normal axis: z (G17), y (G18), x (G19)
  std::stringstream ss(out);
  std::string line;
  while (std::getline(ss, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, call)) continue;
    const std::string name = m[1], args = m[2];
    const auto v = numbers(args);
    Expected e;
    e.text = line;
    if (name == "USE_LENGTH_UNITS") {
      scale = args.find("INCHES") != std::string::npos ? 25.4 : 1.0;
      if (scale != 1.0) p.inches_seen = true;
      continue;
    } else if (name == "SET_G5X_OFFSET") {
      for (int k = 0; k < 3; ++k) g5x[static_cast<std::size_t>(k)] = v.at(static_cast<std::size_t>(k + 1)) * scale;
      continue;
    } else if (name == "SET_G92_OFFSET") {
      for (int k = 0; k < 3; ++k) g92[static_cast<std::size_t>(k)] = v.at(static_cast<std::size_t>(k)) * scale;
      continue;
    } else if (name == "SELECT_PLANE") {
      plane = args.find("XZ") != std::string::npos ? 'y' : args.find("YZ") != std::string::npos ? 'x' : 'z';
      continue;
    } else if (name == "SET_FEED_RATE") {
      feed = v.at(0) * scale;
      continue;
    } else if (name == "SET_SPINDLE_SPEED") {
      speed = v.at(1);
      continue;
    } else if (name == "STRAIGHT_TRAVERSE" || name == "STRAIGHT_FEED") {
      e.kind = name == "STRAIGHT_TRAVERSE" ? "rapid" : "line";
      e.end = {v.at(0) * scale + g5x[0] + g92[0], v.at(1) * scale + g5x[1] + g92[1], v.at(2) * scale + g5x[2] + g92[2]};
      e.feed = name == "STRAIGHT_FEED" ? feed : 0.0;
    } else if (name == "ARC_FEED") {
      e.kind = "arc";
      // (first, second, normal) axes of the plane, as indices into x, y, z.
      const std::array<int, 3> axes = plane == 'z' ? std::array<int, 3>{0, 1, 2}
                                     : plane == 'y' ? std::array<int, 3>{2, 0, 1}
                                                    : std::array<int, 3>{1, 2, 0};
      const auto off = [&](int a) { return g5x[static_cast<std::size_t>(a)] + g92[static_cast<std::size_t>(a)]; };
      e.end[static_cast<std::size_t>(axes[0])] = v.at(0) * scale + off(axes[0]);
      e.end[static_cast<std::size_t>(axes[1])] = v.at(1) * scale + off(axes[1]);
      e.end[static_cast<std::size_t>(axes[2])] = v.at(5) * scale + off(axes[2]);
      e.center = {v.at(2) * scale + off(axes[0]), v.at(3) * scale + off(axes[1])};
      const int rotation = static_cast<int>(std::lround(v.at(4)));
      e.clockwise = rotation < 0;
      e.turns = std::abs(rotation) - 1;
      e.feed = feed;
    } else if (name == "DWELL") {
      e.kind = "dwell";
      e.seconds = v.at(0);
    } else if (name == "START_SPINDLE_CLOCKWISE" || name == "START_SPINDLE_COUNTERCLOCKWISE") {
      e.kind = "torch_on";
      e.speed = speed;
    } else if (name == "STOP_SPINDLE_TURNING") {
      e.kind = "torch_off";
    } else if (name == "PROGRAM_END") {
      // M2 / M30 issue one STOP_SPINDLE_TURNING of their own: the latest one.
      for (auto it = p.moves.rbegin(); it != p.moves.rend(); ++it) {
        if (it->kind == "torch_off") {
          p.moves.erase(std::next(it).base());
          break;
        }
      }
      break;
    } else if (name == "USE_TOOL_LENGTH_OFFSET" && std::regex_match(args, std::regex(R"([-0., ]*)"))) {
      continue;  // G43 / G49 with zero lengths (our tool table): no Z effect
    } else if (std::regex_match(name, std::regex("SELECT_TOOL|CHANGE_TOOL|CHANGE_TOOL_NUMBER|START_CHANGE|FLOOD_O(N|FF)|"
                                                     "MIST_O(N|FF)|(SET|CLEAR)_(MOTION|AUX)_OUTPUT_(BIT|VALUE)|WAIT"))) {
      continue;  // kept by machplan as program events, not moves
    } else {
      static const std::regex moving("PROBE|TAP|NURBS|SPLINE|TOOL|SPINDLE_RETRACT|ORIENT|MOTION|WAIT|DIGITAL|ANALOG|COOLANT|FLOOD|MIST");
      if (std::regex_search(name, moving) && name.rfind("SET_", 0) != 0) p.unmodelled.push_back(line);
      continue;
    }
    p.moves.push_back(e);
  }
  return p;
}

Expected from_move(const machplan::Move& m) {
  Expected e;
  e.kind = machplan::to_string(m.kind);
  e.end = {m.end.x(), m.end.y(), m.end.z()};
  e.center = {m.center.x(), m.center.y()};
  e.feed = m.feed_mm_per_min;
  e.clockwise = m.clockwise;
  e.turns = m.turns;
  e.seconds = m.seconds;
  e.speed = m.spindle_speed;
  e.text = fmt::format("line {}: {} to ({}, {}, {}) F {} centre ({}, {}) {} turns {} dwell {} S {}", m.line, e.kind,
                       e.end[0], e.end[1], e.end[2], e.feed, e.center[0], e.center[1], m.clockwise ? "cw" : "ccw",
                       m.turns, m.seconds, m.spindle_speed);
  return e;
}

// machplan's reading of a program in one dialect: what `machplan program FILE --dialect D`
// would print or refuse.
struct Reading {
  int exit_code = 0;  // the command line's: 0 read, 2 refused (InputError)
  std::string error;  // the refusal, "FILE:LINE: message"
  std::vector<Expected> moves;
  std::string all;  // everything the reader reports, exactly (doubles in shortest round-trip form)
};

Reading read_ours(const fs::path& file, machplan::GcodeDialect dialect) {
  machplan::GcodeOptions o;
  o.dialect = dialect;
  Reading r;
  machplan::Program program;
  try {
    program = machplan::read_gcode_file(file.string(), o);
  } catch (const machplan::InputError& e) {
    r.exit_code = 2;
    r.error = e.what();
    return r;
  }
  r.all = fmt::format("dialect {}, start ({}, {}, {}), ends with program end {}\n", machplan::to_string(program.dialect),
                      program.start.x(), program.start.y(), program.start.z(), program.ends_with_program_end);
  for (const std::string& w : program.warnings) r.all += "warning: " + w + "\n";
  for (const machplan::ProgramEvent& e : program.events)
    r.all += fmt::format("event {} line {} before move {}: {} {} {} {} {} '{}'\n", machplan::to_string(e.kind), e.line,
                         e.before_move, e.number, e.value, e.value2, e.mode, e.synchronized, e.text);
  for (const machplan::Move& m : program.moves) {
    r.moves.push_back(from_move(m));
    r.all += fmt::format("{} plane {} spindle {} path {} {}\n", r.moves.back().text, static_cast<int>(m.plane), m.spindle,
                         machplan::to_string(m.path_mode), m.path_tolerance_mm);
  }
  return r;
}

std::vector<fs::path> programs() {
  std::vector<fs::path> files;
  const fs::path ours = fs::path(MACHPLAN_SOURCE_DIR) / "datasets/programs/conformance";
  if (fs::is_directory(ours))
    for (const auto& e : fs::directory_iterator(ours))
      if (e.path().extension() == ".ngc") files.push_back(e.path());
  for (const auto& e : fs::directory_iterator(ours.parent_path()))
    if (e.path().extension() == ".ngc") files.push_back(e.path());  // demo_plate.ngc and friends
  const fs::path samples = "/usr/share/linuxcnc/ncfiles";
  if (fs::is_directory(samples))
    for (const auto& e : fs::directory_iterator(samples))
      if (e.path().extension() == ".ngc") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

class GcodeConformance : public ::testing::TestWithParam<fs::path> {};

TEST(GcodeConformanceSetup, CorpusAndReferenceArePresent) {
  const fs::path ours = fs::path(MACHPLAN_SOURCE_DIR) / "datasets/programs/conformance";
  std::size_t count = 0;
  for (const auto& e : fs::directory_iterator(ours)) count += e.path().extension() == ".ngc";
  EXPECT_GE(count, 25u) << "the conformance corpus should hold at least 25 programs";
  EXPECT_TRUE(fs::exists("/usr/bin/rs274")) << "LinuxCNC's rs274 is the reference (package linuxcnc-uspace)";
  EXPECT_TRUE(fs::is_directory("/usr/share/linuxcnc/ncfiles")) << "LinuxCNC's sample programs are missing";
}

TEST_P(GcodeConformance, MatchesRs274) {
  const fs::path file = GetParam();
  const std::string text = slurp(file);
  // Expectation line, for our own corpus.
  std::string expect = "auto", expect_text;
  {
    static const std::regex header(R"(^\(expect:\s*(match|refuse|error)\s*(.*?)\s*\))");
    std::smatch m;
    // The first line, or the second after an opening '%'.
    std::string first = text.substr(0, text.find('\n'));
    if (!first.empty() && first[0] == '%') {
      const auto next = text.find('\n');
      first = next == std::string::npos ? "" : text.substr(next + 1, text.find('\n', next + 1) - next - 1);
    }
    if (std::regex_search(first, m, header)) {
      expect = m[1];
      expect_text = m[2];
    }
  }

  const fs::path dir = fs::temp_directory_path() /
                       ("machplan_conf_" + std::to_string(::getpid()) + "_" + file.stem().string());
  fs::create_directories(dir);
  {
    // rs274 refuses samples that ask for tools not in its table: give it tools 1..20.
    std::ofstream tbl(dir / "tool.tbl");
    for (int t = 1; t <= 20; ++t) tbl << "T" << t << " P" << t << " D0.125 Z0 ;tool " << t << "\n";
  }
  // rs274 instances running at the same time crash now and then with SIGBUS (seen with
  // ctest -j2: about one run in four), so every call takes the same lock (flock, util-linux).
  const std::string lock = (fs::temp_directory_path() / "machplan_rs274.lock").string();
  const RunResult ref = run("cd " + quote(dir.string()) + " && flock " + quote(lock) +
                                " timeout 60 /usr/bin/rs274 -g -t tool.tbl " + quote(file.string()),
                            dir);
  // The reference reading is LinuxCNC's dialect; the default (auto) must read every program
  // rs274 reads exactly as it (checked below), and may read as GRBL's what rs274 refuses.
  const Reading ours = read_ours(file, machplan::GcodeDialect::linuxcnc);
  const Reading ours_auto = read_ours(file, machplan::GcodeDialect::automatic);
  fs::remove_all(dir);

  const bool ref_ok = ref.exit_code == 0;
  std::string ref_error;
  {
    std::stringstream ss(ref.err);
    std::string l;
    while (std::getline(ss, l))
      if (l != "executing" && ref_error.empty()) ref_error = l;
  }
  SCOPED_TRACE("file: " + file.string() + "\nrs274 exit " + std::to_string(ref.exit_code) +
               (ref_error.empty() ? "" : " (" + ref_error + ")") + "\nmachplan exit " +
               std::to_string(ours.exit_code) + ": " + ours.error);
  ASSERT_TRUE(ours.exit_code == 0 || ours.exit_code == 2) << "machplan must accept (0) or refuse (2)";
  if (ours.exit_code == 2) {
    EXPECT_NE(ours.error.find(file.string() + ":"), std::string::npos) << "the message must name the file";
  }

  if (expect == "match") {
    ASSERT_TRUE(ref_ok) << "this program is meant to be accepted by rs274";
    ASSERT_EQ(ours.exit_code, 0) << "this program is meant to be accepted by machplan";
  } else if (expect == "refuse") {
    ASSERT_TRUE(ref_ok) << "this program is meant to be accepted by rs274 (a feature machplan refuses)";
    ASSERT_EQ(ours.exit_code, 2);
    EXPECT_NE(ours.error.find(expect_text), std::string::npos) << "expected the message to name: " << expect_text;
    return;
  } else if (expect == "error") {
    ASSERT_FALSE(ref_ok) << "this program is meant to be rejected by rs274";
    ASSERT_EQ(ours.exit_code, 2);
    EXPECT_NE(ours.error.find(expect_text), std::string::npos) << "expected the message to contain: " << expect_text;
    return;
  }

  if (!ref_ok) {
    EXPECT_EQ(ours.exit_code, 2) << "rs274 rejects this program, so must machplan";
    return;
  }
  if (ours.exit_code == 2) {
    EXPECT_NE(ours.error.find("not supported"), std::string::npos)
        << "rs274 accepts this program; machplan may refuse it only for an unsupported feature, named";
    return;
  }

  // Both accept: compare the moves. The default dialect reads it identically.
  EXPECT_EQ(ours_auto.exit_code, ours.exit_code);
  EXPECT_EQ(ours_auto.all, ours.all) << "the automatic dialect must read a program rs274 reads as LinuxCNC does";
  const Rs274Program expected = parse_rs274(ref.out);
  EXPECT_TRUE(expected.unmodelled.empty()) << "rs274 issues calls machplan does not model, yet machplan accepted: "
                                          << expected.unmodelled.front();
  const std::vector<Expected>& got = ours.moves;
  // rs274 prints 4 decimals in program units: in inches that is 0.00127 mm of rounding.
  const double tol_mm = expected.inches_seen ? 1.6e-3 : 1e-3;
  ASSERT_EQ(got.size(), expected.moves.size()) << "number of moves";
  for (std::size_t i = 0; i < got.size(); ++i) {
    const Expected& a = got[i];
    const Expected& b = expected.moves[i];
    SCOPED_TRACE("move " + std::to_string(i) + "\n  machplan: " + a.text + "\n  rs274:    " + b.text);
    ASSERT_EQ(a.kind, b.kind);
    if (a.kind == "rapid" || a.kind == "line" || a.kind == "arc") {
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.end[k], b.end[k], tol_mm) << "end[" << k << "]";
    }
    if (a.kind == "line" || a.kind == "arc") { EXPECT_NEAR(a.feed, b.feed, 1e-4 * std::max(1.0, b.feed)) << "feed"; }
    if (a.kind == "arc") {
      for (int k = 0; k < 2; ++k) EXPECT_NEAR(a.center[k], b.center[k], tol_mm) << "center[" << k << "]";
      EXPECT_EQ(a.clockwise, b.clockwise);
      EXPECT_EQ(a.turns, b.turns);
    }
    if (a.kind == "dwell") { EXPECT_NEAR(a.seconds, b.seconds, 1e-4); }
    if (a.kind == "torch_on") { EXPECT_NEAR(a.speed, b.speed, 1e-4 * std::max(1.0, b.speed)); }
  }
}

std::string test_name(const ::testing::TestParamInfo<fs::path>& info) {
  std::string prefix = info.param.string().find("/usr/share/linuxcnc") == 0 ? "linuxcnc_" : "corpus_";
  std::string name = prefix + info.param.stem().string();
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Programs, GcodeConformance, ::testing::ValuesIn(programs()), test_name);

}  // namespace
