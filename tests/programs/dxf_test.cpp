// Contracts of engine/programs/dxf.h: contours, chaining, nesting, units, and every problem
// and error the reader promises to report.
#include "engine/programs/dxf.h"

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

using Eigen::Vector2d;
constexpr double kPi = std::numbers::pi;

// Small DXF writer: entities are lists of (code, value) lines.
struct Writer {
  std::string body;
  std::string header;
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
  w.pair(0, "SPLINE"); w.pair(5, "SP"); w.pair(70, "8");
  w.pair(0, "TEXT"); w.pair(5, "TX"); w.pair(1, "note");
  w.pair(0, "INSERT"); w.pair(5, "IN"); w.pair(2, "BOLT");
  const auto r = read(w);
  ASSERT_EQ(count(r, "unsupported_entity"), 2) << r.report();
  EXPECT_NE(r.report().find("SPLINE SP"), std::string::npos);
  EXPECT_NE(r.report().find("INSERT IN"), std::string::npos);
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
  expect_input_error(std::string("AutoCAD Binary DXF\r\n\x1a") + std::string(1, '\0'), 1, "binary");
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

  const auto sheet = read_dxf_profile(dir + "nested_sheet.dxf");
  ASSERT_EQ(sheet.contours.size(), 10u);
  EXPECT_FALSE(sheet.has_errors()) << sheet.report();
  int deepest = 0;
  for (const auto& c : sheet.contours) deepest = std::max(deepest, c.depth);
  EXPECT_EQ(deepest, 3);
}

TEST(Dxf, CliPrintsJsonAndExitCodes) {
  const std::string dir = std::string(MACHPLAN_SOURCE_DIR) + "/datasets/profiles/";
  const std::string cli = MACHPLAN_CLI;
  EXPECT_EQ(std::system((cli + " profile " + dir + "flange_plate.dxf --json > /dev/null").c_str()), 0);
  EXPECT_NE(std::system((cli + " profile /nonexistent.dxf 2> /dev/null").c_str()), 0);
  EXPECT_NE(std::system((cli + " profile " + dir + "flange_plate.dxf --tolerance -1 2> /dev/null").c_str()), 0);
}

}  // namespace
}  // namespace machplan
