// Contracts of engine/programs/dxf.h: contours, chaining, nesting, units, and every problem
// and error the reader promises to report.
#include "engine/programs/dxf.h"
#include "engine/common/internal/numbers.h"


#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/geometry/curve_fit.h"
#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

// Small DXF writer: entities are lists of (code, value) lines.
struct Writer {
  std::string body;
  std::string header = "9\n$INSUNITS\n70\n4\n";  // mm; tests of missing units clear it
  std::string blocks;                               // BLOCKS section content, if any
  void pair(int code, const std::string& v) { body += fmt::format("{}\n{}\n", code, v); }
  void pair(int code, double v) { body += fmt::format("{}\n{:.12g}\n", code, v); }
  void line(const std::string& h, Vector2d a, Vector2d b) {
    pair(0, "LINE"); pair(5, h); pair(10, a.x()); pair(20, a.y()); pair(11, b.x()); pair(21, b.y());
  }
  void arc(const std::string& h, Vector2d c, double r, double a1, double a2) {
    pair(0, "ARC"); pair(5, h); pair(10, c.x()); pair(20, c.y()); pair(40, r); pair(50, a1); pair(51, a2);
  }
  void circle(const std::string& h, Vector2d c, double r) {
    pair(0, "CIRCLE"); pair(5, h); pair(10, c.x()); pair(20, c.y()); pair(40, r);
  }
  void lwpolyline(const std::string& h, const std::vector<Vector2d>& v, const std::vector<double>& b, bool closed) {
    pair(0, "LWPOLYLINE"); pair(5, h); pair(90, std::to_string(v.size())); pair(70, closed ? "1" : "0");
    for (std::size_t i = 0; i < v.size(); ++i) { pair(10, v[i].x()); pair(20, v[i].y()); pair(42, b[i]); }
  }
  std::string text() const {
    return (header.empty() ? "" : "0\nSECTION\n2\nHEADER\n" + header + "0\nENDSEC\n") +
           (blocks.empty() ? "" : "0\nSECTION\n2\nBLOCKS\n" + blocks + "0\nENDSEC\n") +
           "0\nSECTION\n2\nENTITIES\n" + body + "0\nENDSEC\n0\nEOF\n";
  }
};

ProfileReadResult read(const Writer& w, DxfOptions o = {}) { return read_dxf_profile_text(w.text(), "t.dxf", o); }

int count(const ProfileReadResult& r, const std::string& kind) {
  int n = 0;
  for (const auto& p : r.problems) n += p.kind == kind;
  return n;
}

const ProfileProblem* find(const ProfileReadResult& r, const std::string& kind) {
  for (const auto& p : r.problems)
    if (p.kind == kind) return &p;
  return nullptr;
}

TEST(Dxf, SquareWithRoundHoleNests) {
  Writer w;
  w.lwpolyline("A1", {{0, 0}, {100, 0}, {100, 60}, {0, 60}}, {0, 0, 0, 0}, true);
  w.circle("A2", {40, 30}, 12.5);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 2u);
  EXPECT_TRUE(r.problems.empty()) << r.report();
  EXPECT_NEAR(r.contours[0].area_mm2, 100 * 60, 1e-9);
  EXPECT_NEAR(std::abs(r.contours[1].area_mm2), kPi * 12.5 * 12.5, 1e-9);
  EXPECT_EQ(r.contours[0].parent, -1);
  EXPECT_EQ(r.contours[1].parent, 0);
  EXPECT_EQ(r.contours[1].depth, 1);
  EXPECT_EQ(r.contours[0].children, std::vector<int>{1});
  EXPECT_EQ(r.contours[1].handles, std::vector<std::string>{"A2"});
}

TEST(Dxf, ScrambledSlotChains) {
  // Slot 20 long, radius 5, from lines and arcs in mixed order and direction.
  Writer w;
  w.arc("S1", {20, 5}, 5, 270, 90);
  w.line("S2", {0, 0}, {20, 0});
  w.line("S3", {0, 10}, {20, 10});    // drawn against the chain
  w.arc("S4", {0, 5}, 5, 90, 270);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_TRUE(r.problems.empty()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), 20 * 10 + kPi * 25, 1e-6);
  EXPECT_NEAR(r.contours[0].perimeter_mm, 40 + 10 * kPi, 1e-6);
  EXPECT_EQ(r.contours[0].handles.size(), 4u);
}

TEST(Dxf, GapsWithinToleranceJoinOthersDoNot) {
  Writer w;
  w.line("L1", {0, 0}, {10, 0});
  w.line("L2", {10.005, 0}, {10, 10});
  w.line("L3", {10, 10}, {0, 0});
  EXPECT_EQ(read(w).contours.size(), 1u);
  DxfOptions tight;
  tight.chain_tolerance_mm = 0.001;
  // With healing (0.5 mm by default) the 0.005 mm gap is joined, and said so.
  const auto healed = read(w, tight);
  EXPECT_EQ(healed.contours.size(), 1u);
  EXPECT_EQ(count(healed, "joined"), 1);
  tight.join_tolerance_mm = 0;  // healing off
  const auto r = read(w, tight);
  EXPECT_TRUE(r.contours.empty());
  const ProfileProblem* p = find(r, "open_chain");
  ASSERT_NE(p, nullptr) << r.report();
  EXPECT_EQ(p->severity, ProfileProblem::Severity::error);
  ASSERT_TRUE(p->at.has_value());
  EXPECT_LT(std::min((*p->at - Vector2d(10, 0)).norm(), (*p->at - Vector2d(10.005, 0)).norm()), 1e-9);
  EXPECT_EQ(p->handles.size(), 3u);
  EXPECT_TRUE(r.has_errors());
}

TEST(Dxf, LwpolylineWithBulges) {
  Writer w;
  // Rectangle 10 x 10 whose right side is a half circle outward: area 100 + pi 25 / 2.
  w.lwpolyline("P1", {{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {0, 1, 0, 0}, true);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u);
  EXPECT_NEAR(r.contours[0].area_mm2, 100 + kPi * 25 / 2, 1e-9);
}

TEST(Dxf, PolylineWithVertexBulgesAndClosedFlag) {
  Writer w;
  w.pair(0, "POLYLINE"); w.pair(5, "PL"); w.pair(66, "1"); w.pair(70, "1");
  const std::vector<Vector2d> v = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  const std::vector<double> b = {0, 0, 0, -1};  // left side a half circle bulging inward
  for (std::size_t i = 0; i < v.size(); ++i) {
    w.pair(0, "VERTEX"); w.pair(10, v[i].x()); w.pair(20, v[i].y()); w.pair(42, b[i]);
  }
  w.pair(0, "SEQEND");
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_NEAR(r.contours[0].area_mm2, 100 - kPi * 25 / 2, 1e-9);
  EXPECT_EQ(r.contours[0].handles, std::vector<std::string>{"PL"});
}

TEST(Dxf, DuplicatesAndZeroLengthAreWarnings) {
  Writer w;
  w.line("D1", {0, 0}, {10, 0});
  w.line("D2", {10, 0}, {0, 0});   // the same line drawn back
  w.line("D3", {10, 0}, {0, 10});
  w.line("D4", {0, 10}, {0, 0});
  w.line("Z1", {5, 5}, {5, 5});
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  const ProfileProblem* d = find(r, "duplicate");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->severity, ProfileProblem::Severity::warning);
  EXPECT_EQ(d->handles, (std::vector<std::string>{"D1", "D2"}));
  const ProfileProblem* z = find(r, "zero_length");
  ASSERT_NE(z, nullptr);
  EXPECT_EQ(z->handles, std::vector<std::string>{"Z1"});
  EXPECT_FALSE(r.has_errors()) << r.report();
}

TEST(Dxf, BowTieSelfIntersectionIsLocated) {
  Writer w;
  w.lwpolyline("BT", {{0, 0}, {10, 10}, {10, 0}, {0, 10}}, {0, 0, 0, 0}, true);
  const auto r = read(w);
  const ProfileProblem* p = find(r, "self_intersection");
  ASSERT_NE(p, nullptr) << r.report();
  ASSERT_TRUE(p->at.has_value());
  EXPECT_NEAR((*p->at - Vector2d(5, 5)).norm(), 0, 1e-9);
  EXPECT_TRUE(r.has_errors());
}

TEST(Dxf, OverlappingContoursAreReported) {
  Writer w;
  w.circle("C1", {0, 0}, 10);
  w.circle("C2", {15, 0}, 10);
  const auto r = read(w);
  EXPECT_EQ(count(r, "overlap"), 1) << r.report();
  EXPECT_EQ(r.contours[1].parent, -1);
}

TEST(Dxf, UnsupportedEntitiesAreNamed) {
  Writer w;
  w.circle("C1", {0, 0}, 10);
  w.pair(0, "3DSOLID"); w.pair(5, "SO");
  w.pair(0, "TEXT"); w.pair(5, "TX"); w.pair(1, "note");
  w.pair(0, "MESH"); w.pair(5, "ME");
  const auto r = read(w);
  ASSERT_EQ(count(r, "unsupported_entity"), 2) << r.report();
  EXPECT_NE(r.report().find("3DSOLID SO"), std::string::npos);
  EXPECT_NE(r.report().find("MESH ME"), std::string::npos);
  const ProfileProblem* t = find(r, "annotation_ignored");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->severity, ProfileProblem::Severity::warning);
  EXPECT_TRUE(r.has_errors());
}

TEST(Dxf, InchesAreConverted) {
  Writer w;
  w.header = "9\n$INSUNITS\n70\n1\n";
  w.lwpolyline("P", {{0, 0}, {1, 0}, {1, 2}, {0, 2}}, {0, 0, 0, 0}, true);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u);
  EXPECT_NEAR(r.contours[0].area_mm2, 2 * 25.4 * 25.4, 1e-9);
  EXPECT_NEAR(r.contours[0].contour.vertices()[2].y(), 50.8, 1e-12);
}

TEST(Dxf, MirroredExtrusionFlipsArcs) {
  // ARC in the (0,0,-1) object system: OCS x is WCS -x.
  Writer w;
  w.pair(0, "CIRCLE"); w.pair(5, "M"); w.pair(10, 20.0); w.pair(20, 0.0); w.pair(40, 5.0); w.pair(230, -1.0);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u);
  const auto box = bounding_box(r.contours[0].contour);
  EXPECT_NEAR(box.center().x(), -20, 1e-9);
}

void expect_input_error(const std::string& text, int line, const std::string& words) {
  try {
    read_dxf_profile_text(text, "bad.dxf");
    FAIL() << "no error for: " << text.substr(0, 60);
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("bad.dxf:", 0), 0u) << e.what();
  }
}

TEST(Dxf, MalformedFilesGiveFileLineErrors) {
  expect_input_error("", 1, "empty file");
  expect_input_error("hello world\nthis is not dxf\n", 1, "group code");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLINE\n10\n", 7, "truncated");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLINE\n10\n1\n", 8, "truncated");  // the last line
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLINE\n10\nabc\n0\nENDSEC\n0\nEOF\n", 8, "not a number");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLINE\n10\nnan\n0\nENDSEC\n0\nEOF\n", 8, "not finite");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLINE\n10\n1e300\n0\nENDSEC\n0\nEOF\n", 8, "beyond");
  expect_input_error("0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n77\n0\nENDSEC\n0\nEOF\n", 8, "$INSUNITS");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nVERTEX\n0\nENDSEC\n0\nEOF\n", 5, "outside a POLYLINE");
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nLWPOLYLINE\n90\n5\n10\n0\n20\n0\n0\nENDSEC\n0\nEOF\n", 5, "declares 5");
  // A binary DXF with nothing after its sentinel has no 0/EOF.
  expect_input_error(std::string("AutoCAD Binary DXF\r\n\x1a") + std::string(1, '\0'), 1, "empty file");
}

// ---------------------------------------------------------------------------------------
// Binary DXF, written here from the ASCII form by the format's rules (Autodesk's DXF
// reference): group codes as 2 little-endian bytes (release 13 on) or 1 byte (older, 255
// announcing a 2-byte code), strings NUL-terminated, reals 8-byte doubles, integers 2 or 4
// bytes by the code's range.

std::string binary_dxf(const std::string& ascii, bool two_byte_codes = true) {
  std::string out("AutoCAD Binary DXF\r\n\x1a\0", 22);
  const auto put = [&out](std::uint64_t v, int bytes) {
    for (int k = 0; k < bytes; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  };
  std::vector<std::string> lines;
  for (std::size_t at = 0; at < ascii.size();) {
    const std::size_t nl = ascii.find('\n', at);
    lines.push_back(ascii.substr(at, nl - at));
    at = nl + 1;
  }
  for (std::size_t k = 0; k + 1 < lines.size(); k += 2) {
    const int code = std::stoi(lines[k]);
    const std::string& value = lines[k + 1];
    if (two_byte_codes) put(static_cast<std::uint64_t>(code), 2);
    else if (code < 255) put(static_cast<std::uint64_t>(code), 1);
    else { put(255, 1); put(static_cast<std::uint64_t>(code), 2); }
    if ((code >= 10 && code <= 59) || (code >= 210 && code <= 239)) {
      put(std::bit_cast<std::uint64_t>(std::stod(value)), 8);
    } else if ((code >= 60 && code <= 79) || (code >= 170 && code <= 179)) {
      put(static_cast<std::uint64_t>(std::stoll(value)), 2);
    } else if (code >= 90 && code <= 99) {
      put(static_cast<std::uint64_t>(std::stoll(value)), 4);
    } else {
      out += value;
      out.push_back('\0');
    }
  }
  return out;
}

// A square plate with a slot and a round hole, in inches, as pairs of every value type.
Writer binary_test_drawing() {
  Writer w;
  w.header = "9\n$INSUNITS\n70\n1\n";
  w.lwpolyline("10", {{0, 0}, {4, 0}, {4, 3}, {0, 3}}, {0, 0, 0, 0}, true);
  w.line("11", {1, 1}, {2, 1});
  w.arc("12", {2, 1.25}, 0.25, 270, 90);
  w.line("13", {2, 1.5}, {1, 1.5});
  w.arc("14", {1, 1.25}, 0.25, 90, 270);
  w.circle("15", {3, 2}, 0.5);
  return w;
}

TEST(DxfBinary, ReadsAsTheSameDrawingInAscii) {
  const Writer w = binary_test_drawing();
  const ProfileReadResult ascii = read_dxf_profile_text(w.text(), "t.dxf");
  ASSERT_EQ(ascii.contours.size(), 3u) << ascii.report();
  for (bool two_byte : {true, false}) {
    const ProfileReadResult bin = read_dxf_profile_text(binary_dxf(w.text(), two_byte), "t.dxf");
    EXPECT_EQ(bin.mm_per_unit, 25.4);
    ASSERT_EQ(bin.contours.size(), ascii.contours.size()) << bin.report();
    for (std::size_t i = 0; i < bin.contours.size(); ++i) {
      EXPECT_EQ(bin.contours[i].handles, ascii.contours[i].handles);
      EXPECT_EQ(bin.contours[i].depth, ascii.contours[i].depth);
      EXPECT_EQ(bin.contours[i].area_mm2, ascii.contours[i].area_mm2);
    }
    EXPECT_EQ(bin.report(), ascii.report());
  }
}

TEST(DxfBinary, DamagedFilesGiveErrors) {
  const std::string bin = binary_dxf(binary_test_drawing().text());
  // Cut inside a double: the pair's line in the ASCII form is named.
  const std::string cut = bin.substr(0, bin.find(std::string("\x09\0", 2) + "$INSUNITS") + 2 + 10);
  expect_input_error(cut + std::string("\x46\0\x01", 3), 7, "truncated");
  // A damaged sentinel, and a code no DXF has (80).
  std::string damaged = bin;
  damaged[20] = '\n';
  expect_input_error(damaged, 1, "sentinel");
  expect_input_error(std::string("AutoCAD Binary DXF\r\n\x1a\0", 22) + std::string("\x50\0\0\0", 4), 1,
                     "80 is not a DXF group code");
}

TEST(DxfHeader, VariablesAfterTheHeadersEndsecAreTheHeaders) {
  // The shape dxflib 2.0 (LibreCAD) writes: the header's last variables after its ENDSEC.
  const std::string text =
      "999\ndxflib 2.0\n0\nSECTION\n2\nHEADER\n9\n$ACADVER\n1\nAC1015\n0\nENDSEC\n"
      "9\n$INSUNITS\n70\n1\n9\n$DIMEXE\n40\n0.05\n9\n$PLIMMAX\n10\n8.5\n20\n11\n"
      "0\nSECTION\n2\nENTITIES\n0\nCIRCLE\n5\nC\n10\n0\n20\n0\n40\n1\n0\nENDSEC\n0\nEOF\n";
  const ProfileReadResult r = read_dxf_profile_text(text, "librecad.dxf");
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_TRUE(r.has_insunits);
  EXPECT_EQ(r.mm_per_unit, 25.4);
  EXPECT_EQ(count(r, "no_units"), 0);
  // Elsewhere between sections, a pair that is not 0/SECTION stays an error.
  expect_input_error("0\nSECTION\n2\nENTITIES\n0\nENDSEC\n9\n$INSUNITS\n70\n1\n0\nEOF\n", 7,
                     "expected 0/SECTION or 0/EOF, found group code 9");
}

// ---------------------------------------------------------------------------------------
// Curves, blocks, planes, units and the end marker.

// Largest distance from the points to a circle, and whether the contour is tangent-continuous.
double max_off_circle(const Contour& c, Vector2d center, double r) {
  double worst = 0;
  for (const auto& s : c.segments()) {
    for (double t : {0.0, 0.25, 0.5, 0.75, 1.0}) worst = std::max(worst, std::abs((point_at(s, t) - center).norm() - r));
  }
  return worst;
}
double max_corner_rad(const Contour& c) {
  double worst = 0;
  const auto segs = c.segments();
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const Vector2d a = end_tangent(segs[i]), b = start_tangent(segs[(i + 1) % segs.size()]);
    worst = std::max(worst, std::atan2(std::abs(cross(a, b)), a.dot(b)));
  }
  return worst;
}

void spline_header(Writer& w, const std::string& h, int degree, int flags, int knots, int ctrl, int fit) {
  w.pair(0, "SPLINE"); w.pair(5, h); w.pair(210, 0.0); w.pair(220, 0.0); w.pair(230, 1.0);
  w.pair(70, std::to_string(flags)); w.pair(71, std::to_string(degree)); w.pair(72, std::to_string(knots));
  w.pair(73, std::to_string(ctrl)); w.pair(74, std::to_string(fit));
}

TEST(DxfCurves, RationalNurbsCircleBecomesBiarcsOnTheCircle) {
  // The nine-point rational quadratic circle of radius 10 about (3, 4).
  Writer w;
  const double s2 = std::sqrt(0.5);
  const std::vector<double> knots = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
  const std::vector<Vector2d> ctrl = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}, {1, 0}};
  const std::vector<double> weights = {1, s2, 1, s2, 1, s2, 1, s2, 1};
  spline_header(w, "NC", 2, 1 | 4 | 8, 12, 9, 0);
  for (double k : knots) w.pair(40, k);
  for (double x : weights) w.pair(41, x);
  for (const auto& c : ctrl) { w.pair(10, 3 + 10 * c.x()); w.pair(20, 4 + 10 * c.y()); w.pair(30, 0.0); }
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  const Contour& c = r.contours[0].contour;
  EXPECT_LE(max_off_circle(c, {3, 4}, 10), 0.5 * DxfOptions{}.chain_tolerance_mm);
  EXPECT_LT(max_corner_rad(c), 1e-6);  // biarcs: no corner anywhere
  for (double b : c.bulges()) EXPECT_NE(b, 0.0);
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), kPi * 100, 2 * kPi * 10 * 0.005);
}

TEST(DxfCurves, CubicSplineWithInnerKnotsStaysWithinTolerance) {
  // A clamped cubic S-curve closed by a line; compared with de Boor's points computed here.
  Writer w;
  const std::vector<double> knots = {0, 0, 0, 0, 1, 2, 3, 3, 3, 3};
  const std::vector<Vector2d> ctrl = {{0, 0}, {10, 20}, {20, -20}, {30, 20}, {40, -20}, {50, 0}};
  spline_header(w, "SC", 3, 8, 10, 6, 0);
  for (double k : knots) w.pair(40, k);
  for (const auto& c : ctrl) { w.pair(10, c.x()); w.pair(20, c.y()); w.pair(30, 0.0); }
  w.line("L", {50, 0}, {0, 0});
  DxfOptions o;
  o.chain_tolerance_mm = 0.02;
  const auto r = read(w, o);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  Nurbs n{3, ctrl, {}, knots};
  const Contour& c = r.contours[0].contour;
  double worst = 0;
  for (int i = 0; i <= 3000; ++i) {
    const double t = 3.0 * i / 3000;
    worst = std::max(worst, distance(c, n.point(t, n.span_of(t))));
  }
  EXPECT_LE(worst, 0.5 * o.chain_tolerance_mm * 1.05);
  EXPECT_GT(worst, 0.0);
}

TEST(DxfCurves, FitPointSplinePassesThroughItsPoints) {
  Writer w;
  const std::vector<Vector2d> fit = {{0, 0}, {10, 5}, {20, 0}, {30, 5}, {40, 0}};
  spline_header(w, "FP", 3, 8, 0, 0, 5);
  w.pair(12, 1.0); w.pair(22, 0.0); w.pair(32, 0.0);  // start tangent +x
  for (const auto& f : fit) { w.pair(11, f.x()); w.pair(21, f.y()); w.pair(31, 0.0); }
  w.line("B", {40, 0}, {40, -10});
  w.line("C", {40, -10}, {0, -10});
  w.line("D", {0, -10}, {0, 0});
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  for (const auto& f : fit) EXPECT_LT(distance(r.contours[0].contour, f), 1e-9) << f.transpose();
  // The start tangent is +x: the first span out of (0, 0) leaves horizontally.
  const Contour& c = r.contours[0].contour;
  for (std::size_t i = 0; i < c.size(); ++i)
    if ((c.vertices()[i] - Vector2d(0, 0)).norm() < 1e-9) {
      const Segment s = c.span(i);
      const Vector2d t = start_tangent(s);
      if ((s.end - s.start).x() > 0) { EXPECT_NEAR(std::abs(t.y()), 0.0, 1e-6); }
      else EXPECT_NEAR(std::abs(end_tangent(c.span((i + c.size() - 1) % c.size())).y()), 0.0, 1e-6);
    }
}

TEST(DxfCurves, EllipsesFullAndPartial) {
  Writer w;
  // Full ellipse a = 20, b = 8 about (0, 0), major axis along +y.
  w.pair(0, "ELLIPSE"); w.pair(5, "E1"); w.pair(10, 0.0); w.pair(20, 0.0); w.pair(30, 0.0);
  w.pair(11, 0.0); w.pair(21, 20.0); w.pair(31, 0.0); w.pair(40, 0.4); w.pair(41, 0.0); w.pair(42, 2 * kPi);
  // Upper half of an ellipse a = 10, b = 5 about (100, 0), closed by its diameter.
  w.pair(0, "ELLIPSE"); w.pair(5, "E2"); w.pair(10, 100.0); w.pair(20, 0.0); w.pair(30, 0.0);
  w.pair(11, 10.0); w.pair(21, 0.0); w.pair(31, 0.0); w.pair(40, 0.5); w.pair(41, 0.0); w.pair(42, kPi);
  w.line("D", {90, 0}, {110, 0});
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 2u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), kPi * 20 * 8, 0.005 * r.contours[0].perimeter_mm);
  EXPECT_GT(r.contours[0].area_mm2, 0);  // counter-clockwise, as drawn
  EXPECT_NEAR(std::abs(r.contours[1].area_mm2), kPi * 10 * 5 / 2, 0.005 * r.contours[1].perimeter_mm);
  const auto box = bounding_box(r.contours[0].contour);
  EXPECT_NEAR(box.max().y(), 20, 0.005);
  EXPECT_NEAR(box.max().x(), 8, 0.005);
}

TEST(DxfCurves, AnEllipseWhoseRatioIsAboveOneKeepsItsOutline) {
  // Some writers give the longer axis as the "minor" one: major vector (10, 0) with ratio 2.5
  // is the ellipse of semi-axes 10 along x and 25 along y, the same as major (0, 25) with 0.4.
  Writer w;
  w.pair(0, "ELLIPSE"); w.pair(5, "E1"); w.pair(10, 0.0); w.pair(20, 0.0); w.pair(30, 0.0);
  w.pair(11, 10.0); w.pair(21, 0.0); w.pair(31, 0.0); w.pair(40, 2.5); w.pair(41, 0.0); w.pair(42, 2 * kPi);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_TRUE(r.problems.empty()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), kPi * 10 * 25, 0.005 * r.contours[0].perimeter_mm);
  const auto box = bounding_box(r.contours[0].contour);
  EXPECT_NEAR(box.max().x(), 10, 0.005);
  EXPECT_NEAR(box.max().y(), 25, 0.005);
  EXPECT_NEAR(box.min().y(), -25, 0.005);
}

// A 100 x 60 rectangle of four lines whose corners miss by the given gaps.
Writer gappy_rectangle(double g1, double g2) {
  Writer w;
  w.line("L1", {0, 0}, {100, 0});
  w.line("L2", {100 + g1, 0}, {100, 60});
  w.line("L3", {100, 60}, {0, 60});
  w.line("L4", {0, 60}, {0, g2});
  return w;
}

TEST(DxfHealing, SmallGapsAreJoinedAndEachJoinIsReported) {
  const auto r = read(gappy_rectangle(0.2, 0.35));
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), 6000, 60 * 0.35);
  ASSERT_EQ(count(r, "joined"), 2) << r.report();
  std::vector<double> gaps;
  for (const auto& p : r.problems) {
    if (p.kind != "joined") continue;
    EXPECT_EQ(p.severity, ProfileProblem::Severity::warning);
    ASSERT_TRUE(p.gap_mm.has_value());
    gaps.push_back(*p.gap_mm);
    ASSERT_EQ(p.handles.size(), 2u);
    ASSERT_TRUE(p.at.has_value());
    EXPECT_NE(p.message.find("join tolerance 0.5 mm"), std::string::npos) << p.message;
  }
  std::sort(gaps.begin(), gaps.end());
  EXPECT_NEAR(gaps[0], 0.2, 1e-9);
  EXPECT_NEAR(gaps[1], 0.35, 1e-9);
  // The join at (100, 0) names the lines on both sides of it.
  const ProfileProblem* j = nullptr;
  for (const auto& p : r.problems)
    if (p.kind == "joined" && std::abs(*p.gap_mm - 0.2) < 1e-9) j = &p;
  ASSERT_NE(j, nullptr);
  std::vector<std::string> h = j->handles;
  std::sort(h.begin(), h.end());
  EXPECT_EQ(h, (std::vector<std::string>{"L1", "L2"}));
  EXPECT_NEAR((*j->at - Vector2d(100, 0)).norm(), 0.0, 0.2 + 1e-9);
  EXPECT_NE(r.report().find("gaps healed up to 0.5 mm"), std::string::npos);
}

TEST(DxfHealing, GapsBeyondTheJoinToleranceStayOpenAndHealingCanBeTurnedOff) {
  const auto wide = read(gappy_rectangle(0.2, 0.8));
  EXPECT_TRUE(wide.has_errors());
  EXPECT_EQ(count(wide, "open_chain"), 1) << wide.report();
  EXPECT_EQ(count(wide, "joined"), 1) << wide.report();  // the 0.2 mm gap, still joined
  DxfOptions off;
  off.join_tolerance_mm = 0;
  const auto none = read(gappy_rectangle(0.2, 0.35), off);
  EXPECT_EQ(count(none, "joined"), 0);
  EXPECT_TRUE(none.has_errors());
  DxfOptions wider;
  wider.join_tolerance_mm = 1.0;
  EXPECT_FALSE(read(gappy_rectangle(0.2, 0.8), wider).has_errors());
  DxfOptions bad;
  bad.join_tolerance_mm = 11;
  EXPECT_THROW(bad.validate(), InputError);
}

TEST(DxfHealing, OverlappingCollinearLinesAreMerged) {
  // The bottom edge drawn as two lines that overlap by 30 mm, and the top edge drawn twice, once
  // whole and once as a piece lying within it.
  Writer w;
  w.line("B1", {0, 0}, {60, 0});
  w.line("B2", {30, 0}, {100, 0});
  w.line("R", {100, 0}, {100, 60});
  w.line("T", {100, 60}, {0, 60});
  w.line("T2", {70, 60}, {20, 60});
  w.line("L", {0, 60}, {0, 0});
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), 6000, 1e-6);
  EXPECT_NEAR(r.contours[0].perimeter_mm, 320, 1e-6);
  EXPECT_EQ(count(r, "merged_overlap"), 2) << r.report();
  for (const auto& p : r.problems) EXPECT_EQ(p.severity, ProfileProblem::Severity::warning) << p.message;
}

TEST(DxfHealing, AnArcDrawnTwiceOrWithinAnotherIsKeptOnce) {
  // A 40 x 20 slot with round ends; its right end drawn again as a smaller arc of the same
  // circle (within it, after it), and its left end drawn first as a piece and then whole.
  Writer w;
  w.line("B", {0, 0}, {40, 0});
  w.arc("R", {40, 10}, 10, 270, 90);
  w.arc("R2", {40, 10}, 10, 300, 60);
  w.line("T", {40, 20}, {0, 20});
  w.arc("L2", {0, 10}, 10, 120, 240);
  w.arc("L", {0, 10}, 10, 90, 270);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), 40 * 20 + kPi * 100, 1e-6);
  EXPECT_EQ(count(r, "merged_overlap"), 2) << r.report();
}

TEST(DxfHealing, AnOutlineDrawnTwiceIsKeptOnce) {
  // The same plate as one closed polyline and again as four lines, plus its hole once.
  Writer w;
  w.lwpolyline("P", {{0, 0}, {100, 0}, {100, 60}, {0, 60}}, {0, 0, 0, 0}, true);
  w.line("A", {0, 0}, {50, 0});
  w.line("B", {50, 0}, {100, 0});
  w.line("C", {100, 0}, {100, 60});
  w.line("D", {100, 60}, {0, 60});
  w.line("E", {0, 60}, {0, 0});
  w.circle("H", {30, 30}, 10);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 2u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_EQ(r.contours[0].handles, std::vector<std::string>{"P"});
  EXPECT_EQ(r.contours[1].parent, 0);
  ASSERT_EQ(count(r, "duplicate"), 1) << r.report();
  EXPECT_NE(find(r, "duplicate")->message.find("drawn twice"), std::string::npos) << find(r, "duplicate")->message;
}

// The arcs fitted to a drawing's curves are bounded (DxfOptions::max_fitted_spans): an ellipse
// too detailed for the tolerance is refused once it reaches the limit, naming it.
TEST(DxfCurves, FittedArcsAreBounded) {
  Writer w;
  w.pair(0, "ELLIPSE"); w.pair(5, "E1"); w.pair(10, 0.0); w.pair(20, 0.0); w.pair(30, 0.0);
  w.pair(11, 0.0); w.pair(21, 20.0); w.pair(31, 0.0); w.pair(40, 0.4); w.pair(41, 0.0); w.pair(42, 2 * kPi);
  DxfOptions o;
  const std::size_t needs = [&] {
    std::size_t arcs = 0;
    for (const auto& c : read(w, o).contours) arcs += c.contour.size();
    return arcs;
  }();
  ASSERT_GT(needs, 8u);
  o.max_fitted_spans = needs / 2;
  try {
    read(w, o);
    FAIL() << "the limit was not enforced";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fmt::format("need more than {} arcs", needs / 2)), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("give one with chain_tolerance_mm"), std::string::npos) << e.what();
  }
  o.max_fitted_spans = 0;
  EXPECT_THROW(o.validate(), InputError);
}

// A block "PLATE": 20 x 10 rectangle with a hole of radius 2 at (5, 5), base point (0, 0).
void plate_block(Writer& w) {
  Writer b;
  b.pair(0, "BLOCK"); b.pair(2, "PLATE"); b.pair(70, "0"); b.pair(10, 0.0); b.pair(20, 0.0);
  b.lwpolyline("R", {{0, 0}, {20, 0}, {20, 10}, {0, 10}}, {0, 0, 0, 0}, true);
  b.circle("H", {5, 5}, 2);
  b.pair(0, "ENDBLK");
  w.blocks += b.body;
}
void insert(Writer& w, const std::string& h, const std::string& block, Vector2d at, double sx = 1, double sy = 1,
            double rot_deg = 0, int cols = 1, int rows = 1, double dc = 0, double dr = 0) {
  w.pair(0, "INSERT"); w.pair(5, h); w.pair(2, block); w.pair(10, at.x()); w.pair(20, at.y());
  w.pair(41, sx); w.pair(42, sy); w.pair(50, rot_deg);
  if (cols * rows > 1) {
    w.pair(70, std::to_string(cols)); w.pair(71, std::to_string(rows)); w.pair(44, dc); w.pair(45, dr);
  }
}

TEST(DxfBlocks, InsertPlacesScalesRotatesAndNests) {
  Writer w;
  plate_block(w);
  insert(w, "I1", "PLATE", {100, 0}, 2, 2, 90);  // 40 x 20 turned to 20 x 40, hole at (90, 10)
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 2u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  const auto box = bounding_box(r.contours[0].contour);
  EXPECT_NEAR((box.min() - Vector2d(80, 0)).norm(), 0, 1e-9);
  EXPECT_NEAR((box.max() - Vector2d(100, 40)).norm(), 0, 1e-9);
  EXPECT_NEAR(bounding_box(r.contours[1].contour).center().x(), 90, 1e-9);
  EXPECT_NEAR(bounding_box(r.contours[1].contour).center().y(), 10, 1e-9);
  EXPECT_NEAR(std::abs(r.contours[1].area_mm2), kPi * 16, 1e-9);
  EXPECT_EQ(r.contours[1].parent, 0);
  EXPECT_EQ(r.contours[0].handles, std::vector<std::string>{"I1>R"});
}

TEST(DxfBlocks, ArraysMirrorsAndNestedBlocks) {
  Writer w;
  plate_block(w);
  // "PAIR" holds two plates, the second mirrored about x (scale x = -1) and moved right.
  Writer b;
  b.pair(0, "BLOCK"); b.pair(2, "PAIR"); b.pair(70, "0"); b.pair(10, 0.0); b.pair(20, 0.0);
  insert(b, "P1", "PLATE", {0, 0});
  insert(b, "P2", "PLATE", {50, 0}, -1, 1);
  b.pair(0, "ENDBLK");
  w.blocks += b.body;
  insert(w, "A", "PAIR", {0, 0}, 1, 1, 0, 3, 2, 100, 40);  // 3 columns x 2 rows
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 24u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  int ccw_outer = 0, cw_outer = 0;
  for (const auto& c : r.contours)
    if (c.depth == 0) (c.area_mm2 > 0 ? ccw_outer : cw_outer)++;
  EXPECT_EQ(ccw_outer, 6);
  EXPECT_EQ(cw_outer, 6);  // mirrored copies run the other way
  // The mirrored plate of the last array copy spans x 230 .. 250, y 40 .. 50.
  bool found = false;
  for (const auto& c : r.contours)
    if (c.handles.front() == "A[2,1]>P2>R") {
      const auto box = bounding_box(c.contour);
      EXPECT_NEAR((box.min() - Vector2d(230, 40)).norm(), 0, 1e-9);
      EXPECT_NEAR((box.max() - Vector2d(250, 50)).norm(), 0, 1e-9);
      found = true;
    }
  EXPECT_TRUE(found) << r.report();
}

TEST(DxfBlocks, NonUniformScaleTurnsCirclesIntoFittedEllipses) {
  Writer w;
  plate_block(w);
  insert(w, "S", "PLATE", {0, 0}, 3, 1);
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 2u) << r.report();
  EXPECT_NEAR(std::abs(r.contours[1].area_mm2), kPi * 6 * 2, 0.005 * r.contours[1].perimeter_mm);
  EXPECT_LT(max_corner_rad(r.contours[1].contour), 1e-6);
}

TEST(DxfBlocks, MissingAndRecursiveBlocks) {
  Writer w;
  w.circle("C", {0, 0}, 5);
  insert(w, "M", "NOSUCH", {0, 0});
  const auto r = read(w);
  EXPECT_EQ(count(r, "missing_block"), 1) << r.report();
  Writer loop;
  loop.blocks = "0\nBLOCK\n2\nSELF\n10\n0\n20\n0\n0\nINSERT\n5\nIN\n2\nSELF\n10\n1\n20\n0\n0\nENDBLK\n";
  insert(loop, "TOP", "SELF", {0, 0});
  try {
    read(loop);
    FAIL() << "a block inserting itself was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("contains itself"), std::string::npos) << e.what();
    EXPECT_GT(e.line(), 0);
  }
}

TEST(DxfPlanes, FlatThreeDPolylineIsReadTiltedIsNot) {
  auto poly3d = [](double z_last) {
    Writer w;
    w.pair(0, "POLYLINE"); w.pair(5, "P3"); w.pair(66, "1"); w.pair(70, "9");  // closed, 3-D
    const std::vector<Vector2d> v = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
    for (std::size_t i = 0; i < v.size(); ++i) {
      w.pair(0, "VERTEX"); w.pair(10, v[i].x()); w.pair(20, v[i].y()); w.pair(30, i == 3 ? z_last : 7.0);
      w.pair(70, "32");
    }
    w.pair(0, "SEQEND");
    return w;
  };
  const auto flat = read(poly3d(7.0));
  ASSERT_EQ(flat.contours.size(), 1u) << flat.report();
  EXPECT_NEAR(flat.contours[0].area_mm2, 100, 1e-9);
  EXPECT_FALSE(flat.has_errors());
  const auto tilted = read(poly3d(9.0));
  EXPECT_EQ(count(tilted, "not_planar"), 1) << tilted.report();
}

TEST(DxfPlanes, FlattenToleranceProjectsSlightlyTiltedEntities) {
  Writer w;
  const double tilt = 0.7 * kPi / 180;
  w.pair(0, "CIRCLE"); w.pair(5, "T"); w.pair(10, 0.0); w.pair(20, 0.0); w.pair(40, 10.0);
  w.pair(210, std::sin(tilt)); w.pair(220, 0.0); w.pair(230, std::cos(tilt));
  const auto strict = read(w);
  ASSERT_EQ(count(strict, "not_planar"), 1) << strict.report();
  EXPECT_NE(find(strict, "not_planar")->message.find("flatten"), std::string::npos);
  DxfOptions o;
  o.flatten_tolerance_deg = 1.0;
  const auto r = read(w, o);
  ASSERT_EQ(r.contours.size(), 1u) << r.report();
  EXPECT_FALSE(r.has_errors()) << r.report();
  EXPECT_EQ(count(r, "flattened"), 1);
  // The projection of a tilted circle is an ellipse of area pi r^2 cos(tilt).
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), kPi * 100 * std::cos(tilt), 0.005 * r.contours[0].perimeter_mm);
}

TEST(DxfUnits, MissingUnitsWarnAndCanBeGiven) {
  Writer w;
  w.header.clear();
  w.lwpolyline("P", {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {0, 0, 0, 0}, true);
  const auto mm = read(w);
  ASSERT_EQ(mm.contours.size(), 1u);
  EXPECT_EQ(count(mm, "no_units"), 1);
  EXPECT_FALSE(mm.has_insunits);
  // The warning names the option that gives the unit, as a field (a command line renames it).
  EXPECT_EQ(find(mm, "no_units")->option, "assumed_mm_per_unit");
  EXPECT_EQ(find(mm, "no_units")->text(),
            "the drawing does not state its units ($INSUNITS); read as mm: if it is drawn in another unit, give that "
            "unit with assumed_mm_per_unit");
  EXPECT_NEAR(mm.contours[0].area_mm2, 1, 1e-12);
  DxfOptions o;
  o.assumed_mm_per_unit = mm_per_drawing_unit("inch");
  const auto inch = read(w, o);
  EXPECT_NEAR(inch.contours[0].area_mm2, 25.4 * 25.4, 1e-9);
  EXPECT_EQ(count(inch, "no_units"), 1);
  // A drawing that states its units keeps them whatever is assumed.
  Writer stated;
  stated.lwpolyline("P", {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {0, 0, 0, 0}, true);
  EXPECT_NEAR(read(stated, o).contours[0].area_mm2, 1, 1e-12);
  EXPECT_EQ(mm_per_drawing_unit("furlong"), 0.0);
}

TEST(DxfBlocks, EntityLimitCountsInsertCopies) {
  Writer w;
  plate_block(w);
  insert(w, "A", "PLATE", {0, 0}, 1, 1, 0, 10, 10, 30, 30);  // 100 copies of 2 entities, plus the INSERT
  DxfOptions o;
  o.max_entities = 201;
  EXPECT_EQ(read(w, o).contours.size(), 200u);
  o.max_entities = 200;
  try {
    read(w, o);
    FAIL() << "the limit was not enforced";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("more than 200 entities"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("raise it with max_entities"), std::string::npos) << e.what();
  }
  o.max_entities = 0;
  EXPECT_THROW(o.validate(), InputError);
}

TEST(DxfEnd, BytesAfterEofAreIgnored) {
  Writer w;
  w.circle("C", {0, 0}, 3);
  const std::string text = w.text() + "garbage that is not a group code\n\x01\x02 more\n";
  const auto r = read_dxf_profile_text(text, "t.dxf");
  EXPECT_EQ(r.contours.size(), 1u);
  EXPECT_FALSE(r.has_errors());
}

TEST(DxfChains, OpenChainSaysHowFarItIsFromClosing) {
  Writer w;
  w.line("A", {0, 0}, {10, 0});
  w.line("B", {10, 0}, {10, 10});
  w.line("C", {10, 10}, {0, 7});  // 3 mm short of (0, 10) -> gap to (0, 0) is 7.0
  const auto r = read(w);
  const ProfileProblem* p = find(r, "open_chain");
  ASSERT_NE(p, nullptr) << r.report();
  ASSERT_TRUE(p->gap_mm.has_value());
  EXPECT_NEAR(*p->gap_mm, 7.0, 1e-9);
}

TEST(DxfChains, ManyScrambledLinesChainAndManyCirclesStaySeparate) {
  // A 2000-gon from lines in scrambled order and direction, and a 30 x 30 grid of circles
  // of which exactly one pair overlaps: the grid-based chaining and the pair sweep must give
  // what the definition says.
  Writer w;
  const int n = 2000;
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = (i * 7919) % n;
  for (int i : order) {
    const double a0 = 2 * kPi * i / n, a1 = 2 * kPi * (i + 1) / n;
    Vector2d p(1000 * std::cos(a0), 1000 * std::sin(a0)), q(1000 * std::cos(a1), 1000 * std::sin(a1));
    if (i % 3 == 0) std::swap(p, q);
    w.line(fmt::format("L{}", i), p, q);
  }
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) w.circle(fmt::format("C{}_{}", i, j), {3000 + 10.0 * i, 10.0 * j}, 4);
  w.circle("X", {3000 + 10.0 * 29 + 7, 0}, 4);  // overlaps C29_0
  const auto r = read(w);
  ASSERT_EQ(r.contours.size(), 1u + 900u + 1u) << r.problems.size();
  EXPECT_EQ(r.contours[0].handles.size(), static_cast<std::size_t>(n));
  EXPECT_NEAR(std::abs(r.contours[0].area_mm2), 0.5 * n * 1e6 * std::sin(2 * kPi / n), 1e-3);
  ASSERT_EQ(count(r, "overlap"), 1);
  const ProfileProblem* o = find(r, "overlap");
  EXPECT_EQ(o->handles, (std::vector<std::string>{"C29_0", "X"}));
}

TEST(Dxf, BundledProfiles) {
  const std::string dir = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/profiles/";
  const auto flange = read_dxf_profile(dir + "flange_plate.dxf");
  ASSERT_EQ(flange.contours.size(), 10u);
  EXPECT_FALSE(flange.has_errors()) << flange.report();
  const double corner = 20 * 20 * (4 - kPi);  // four rounded corners remove r^2 (1 - pi/4) each
  // The file holds the corner bulge tan(pi/8) to 6 decimals, which moves the area by ~5e-4.
  EXPECT_NEAR(flange.contours[0].area_mm2, 200 * 200 - corner, 2e-3);
  for (std::size_t i = 1; i < flange.contours.size(); ++i) EXPECT_EQ(flange.contours[i].parent, 0);

  const auto bracket = read_dxf_profile(dir + "bracket_slot.dxf");
  ASSERT_EQ(bracket.contours.size(), 3u) << bracket.report();
  EXPECT_TRUE(bracket.problems.empty()) << bracket.report();
  const double fillet = 100 * (1 - kPi / 4);
  EXPECT_NEAR(std::abs(bracket.contours[0].area_mm2), 120 * 30 + 50 * 50 + fillet - fillet, 1e-6);
  EXPECT_NEAR(std::abs(bracket.contours[1].area_mm2), 20 * 12 + kPi * 36, 1e-6);

  const auto curved = read_dxf_profile(dir + "curved_plate.dxf");
  ASSERT_EQ(curved.contours.size(), 6u) << curved.report();
  EXPECT_TRUE(curved.problems.empty()) << curved.report();
  EXPECT_EQ(curved.contours[0].children.size(), 5u);
  EXPECT_NEAR(std::abs(curved.contours[1].area_mm2), kPi * 30 * 15, 0.005 * curved.contours[1].perimeter_mm);
  for (std::size_t i = 2; i < 6; ++i) EXPECT_NEAR(std::abs(curved.contours[i].area_mm2), kPi * 16, 1e-9);
  EXPECT_EQ(curved.contours[5].handles, std::vector<std::string>{"106[1,1]>1101"});

  const auto sheet = read_dxf_profile(dir + "nested_sheet.dxf");
  ASSERT_EQ(sheet.contours.size(), 10u);
  EXPECT_FALSE(sheet.has_errors()) << sheet.report();
  int deepest = 0;
  for (const auto& c : sheet.contours) deepest = std::max(deepest, c.depth);
  EXPECT_EQ(deepest, 3);
}

TEST(Dxf, CliPrintsJsonAndExitCodes) {
  const std::string flange = "datasets/profiles/flange_plate.dxf";
  test::Cli cli;
  const test::CliResult json = cli.run({"profile", flange, "--json"});
  EXPECT_EQ(json.code, 0) << json.err;
  EXPECT_NE(json.out.find("\"contours\""), std::string::npos);
  EXPECT_EQ(cli.run({"profile", "/nonexistent.dxf"}).code, 2);
  EXPECT_EQ(cli.run({"profile", flange, "--tolerance", "-1"}).code, 2);
  auto exit_code = [&](const std::string& args) { return cli.run("profile " + flange + " " + args).code; };
  EXPECT_EQ(exit_code("--units inch --flatten-tolerance 0.5"), 0);
  EXPECT_EQ(exit_code("--units furlong"), 2);
  EXPECT_EQ(exit_code("--flatten-tolerance 9"), 2);
  EXPECT_EQ(exit_code("--flatten-tolerance nan"), 2);
  EXPECT_EQ(exit_code("--max-entities 3"), 2);
}

TEST(Dxf, CliNamesTheFlagThatGivesTheUnits) {
  test::Cli cli;
  Writer w;
  w.header.clear();
  w.circle("C", {0, 0}, 5);
  const std::string file = cli.write("nounits.dxf", w.text());
  const test::CliResult r = cli.run({"profile", file});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("give that unit with --units"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("assumed_mm_per_unit"), std::string::npos) << r.out;
  const test::CliResult json = cli.run({"profile", file, "--json"});
  EXPECT_NE(json.out.find("give that unit with --units"), std::string::npos) << json.out;
  // Binary DXF is read by the command too.
  const std::string bin = cli.write("plate.dxf", binary_dxf(binary_test_drawing().text()));
  const test::CliResult b = cli.run({"profile", bin});
  EXPECT_EQ(b.code, 0) << b.err;
  EXPECT_NE(b.out.find("3 contour(s)"), std::string::npos) << b.out;
}

}  // namespace
}  // namespace machplan
