// STL reading (binary and ASCII, machplan's own reader) and the mesh
// report: closed cube, open box, non-manifold edge, orientation, garbage and truncated files.
#include "engine/programs/mesh.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "engine/common/error.h"
#include "tests/support/cli_run.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace fs = std::filesystem;

using test::TempDir;
using test::error_of;

Mesh cube() { return make_box_mesh({-1, -2, -3}, {4, 5, 6}); }  // 5 x 7 x 9
constexpr double kCubeVolume = 5.0 * 7.0 * 9.0;

void expect_closed_cube(const MeshReport& r) {
  EXPECT_EQ(r.vertices, 8u);
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.edges, 18u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_TRUE(r.outward);
  EXPECT_NEAR(r.volume_mm3, kCubeVolume, 1e-9);
  EXPECT_TRUE(r.bounds.min().isApprox(Eigen::Vector3d(-1, -2, -3)));
  EXPECT_TRUE(r.bounds.max().isApprox(Eigen::Vector3d(4, 5, 6)));
}

TEST(MeshReport, BoxIsClosedAndOutward) { expect_closed_cube(analyze_mesh(cube())); }

TEST(MeshReport, FlippedBoxFacesInward) {
  Mesh m = cube();
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  const MeshReport r = analyze_mesh(m);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_FALSE(r.outward);
  EXPECT_NEAR(r.volume_mm3, kCubeVolume, 1e-9);
}

TEST(MeshReport, OneFlippedTriangleBreaksOrientation) {
  Mesh m = cube();
  std::swap(m.triangles[3][1], m.triangles[3][2]);
  const MeshReport r = analyze_mesh(m);
  EXPECT_TRUE(r.closed);
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_EQ(r.volume_mm3, 0.0);
}

TEST(MeshReport, OpenBoxHasBoundary) {
  Mesh m = cube();
  m.triangles.erase(m.triangles.begin() + 2, m.triangles.begin() + 4);  // the z = max face
  const MeshReport r = analyze_mesh(m);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.boundary_edges, 4u);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_EQ(r.volume_mm3, 0.0);
}

Mesh three_fins() {
  // Three triangles on the edge (0,0,0)-(0,0,1): a non-manifold "book" of three pages.
  Mesh m;
  m.vertices = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, -1, 0}};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  return m;
}

TEST(MeshReport, ThreeTrianglesOnAnEdgeAreNonManifold) {
  const MeshReport r = analyze_mesh(three_fins());
  EXPECT_EQ(r.non_manifold_edges, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.consistently_oriented);
}

TEST(MeshReport, DegenerateTrianglesAreCounted) {
  Mesh m = cube();
  m.vertices.push_back({10, 0, 0});
  m.vertices.push_back({20, 0, 0});
  m.triangles.push_back({0, 8, 9});   // a proper (if thin) triangle: not degenerate
  m.triangles.push_back({8, 8, 9});   // repeated index
  const Eigen::Vector3d a = m.vertices[0];
  m.vertices.push_back(a + 2 * (m.vertices[8] - a));  // on the line through 0 and 8
  m.triangles.push_back({0, 8, 10});  // zero area
  const MeshReport r = analyze_mesh(m);
  EXPECT_EQ(r.degenerate_triangles, 2u);
}

TEST(MeshReport, TheVerdictNamesEachFault) {
  EXPECT_TRUE(analyze_mesh(cube()).sound());
  EXPECT_EQ(analyze_mesh(cube()).verdict(), "sound: a closed solid, consistently oriented, faces outwards");
  Mesh flipped = cube();
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  EXPECT_FALSE(analyze_mesh(flipped).sound());
  EXPECT_THAT(analyze_mesh(flipped).verdict(), StartsWith("not a sound solid: faces point inwards"));
  Mesh one = cube();
  std::swap(one.triangles[3][1], one.triangles[3][2]);
  EXPECT_THAT(analyze_mesh(one).verdict(), StartsWith("not a sound solid: not consistently oriented"));
  Mesh open = cube();
  open.triangles.erase(open.triangles.begin() + 2, open.triangles.begin() + 4);
  EXPECT_EQ(analyze_mesh(open).verdict(), "not a sound solid: open: 4 boundary edges");
  EXPECT_THAT(analyze_mesh(three_fins()).verdict(),
              StartsWith("not a sound solid: open: 6 boundary edges; 1 non-manifold edges"));
}

TEST(Weld, ToleranceMergesNearbyCorners) {
  const Mesh m = cube();
  std::vector<Eigen::Vector3d> corners;
  int k = 0;
  for (const auto& t : m.triangles)
    for (int c = 0; c < 3; ++c) corners.push_back(m.vertices[t[c]] + Eigen::Vector3d::Constant(1e-7 * (k++ % 3)));
  EXPECT_GT(weld(corners, 0.0).vertices.size(), 8u);
  const Mesh welded = weld(corners, 1e-5);
  EXPECT_EQ(welded.vertices.size(), 8u);
  EXPECT_TRUE(analyze_mesh(welded).closed);
}

// The bug this pins: the grid kept one vertex per cell (the first), so a second vertex made in
// the same cell (more than the tolerance from the first, which a cell's diagonal allows) was
// invisible to later corners, and a corner bit-identical to it became a third vertex.
TEST(Weld, IdenticalCornersShareAVertexWhateverTheCell) {
  const Eigen::Vector3d first(0.05, 0.05, 0.05);   // cell (0,0,0) at a 1 mm tolerance
  const Eigen::Vector3d second(0.95, 0.95, 0.95);  // same cell, 1.56 mm from `first`
  const std::vector<Eigen::Vector3d> corners{first, {10, 0, 0}, {0, 10, 0},    //
                                             second, {20, 0, 0}, {0, 20, 0},   //
                                             second, {30, 0, 0}, {0, 30, 0}};
  const Mesh m = weld(corners, 1.0);
  EXPECT_EQ(m.triangles[1][0], m.triangles[2][0]);
  EXPECT_NE(m.triangles[0][0], m.triangles[1][0]);
  EXPECT_EQ(m.vertices.size(), 8u);
}

// The contract on random clouds: identical corners share a vertex, every corner lies within
// the tolerance of its vertex, and a corner becomes a new vertex only when no earlier vertex
// lies within the tolerance (checked by brute force).
TEST(Weld, ContractOnRandomCorners) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-3.0, 3.0);
  for (const double tol : {0.0, 0.3, 1.0}) {
    std::vector<Eigen::Vector3d> corners;
    for (int k = 0; k < 600; ++k) {
      if (k > 10 && k % 4 == 0)
        corners.push_back(corners[rng() % corners.size()]);  // a repeat, bit for bit
      else
        corners.emplace_back(coord(rng), coord(rng), coord(rng));
    }
    const Mesh m = weld(corners, tol);
    std::vector<int> index;
    for (const auto& t : m.triangles) index.insert(index.end(), {t[0], t[1], t[2]});
    ASSERT_EQ(index.size(), corners.size());
    int made = 0;
    for (std::size_t c = 0; c < corners.size(); ++c) {
      EXPECT_LE((m.vertices[index[c]] - corners[c]).norm(), tol) << "corner " << c << " tol " << tol;
      for (std::size_t d = 0; d < c; ++d)
        if (corners[d] == corners[c]) { EXPECT_EQ(index[d], index[c]) << "corners " << d << ", " << c << " tol " << tol; }
      if (index[c] == made) {  // a new vertex: nothing earlier was close enough
        for (int v = 0; v < made; ++v)
          EXPECT_GT((m.vertices[v] - corners[c]).norm(), tol) << "corner " << c << " vertex " << v;
        ++made;
      }
    }
    EXPECT_EQ(made, static_cast<int>(m.vertices.size()));
  }
}

// ASCII numbers are kept at double precision now that the reader does not go through float.
TEST(Stl, AsciiKeepsDoublePrecision) {
  TempDir dir;
  const std::string path = dir.write("fine.stl",
                                     "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0.1 0 0\n"
                                     "vertex 1.0000001 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
  const Mesh m = read_stl(path);
  ASSERT_EQ(m.vertices.size(), 3u);
  EXPECT_EQ(m.vertices[0].x(), 0.1);
  EXPECT_EQ(m.vertices[1].x(), 1.0000001);
}

TEST(Stl, AsciiCube) {
  TempDir dir;
  MeshReport r;
  const Mesh m = read_stl(dir.write("cube.stl", to_ascii_stl(cube())), &r);
  EXPECT_EQ(m.vertices.size(), 8u);
  expect_closed_cube(r);
}

TEST(Stl, BinaryCube) {
  TempDir dir;
  MeshReport r;
  read_stl(dir.write("cube.stl", to_binary_stl(cube())), &r);
  expect_closed_cube(r);
}

TEST(Stl, BinaryWithSolidInItsHeader) {
  std::string bytes = to_binary_stl(cube());
  bytes.replace(0, 12, "solid cube  ");
  MeshReport r;
  read_stl_bytes(bytes, "solid_header.stl", &r);
  expect_closed_cube(r);
}

TEST(Stl, UpperCaseAsciiAndSeveralSolids) {
  const Mesh a = make_box_mesh({0, 0, 0}, {1, 1, 1});
  const Mesh b = make_box_mesh({5, 0, 0}, {6, 2, 1});
  std::string text = to_ascii_stl(a, "first") + to_ascii_stl(b, "second");
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  MeshReport r;
  read_stl_bytes(text, "two.stl", &r);
  EXPECT_EQ(r.vertices, 16u);
  EXPECT_EQ(r.triangles, 24u);
  EXPECT_TRUE(r.closed);
  EXPECT_NEAR(r.volume_mm3, 1.0 + 2.0, 1e-9);
}

// Layouts the grammar allows but assimp's own ASCII parser does not (it needs the numbers on
// the keyword's line and reads words in a solid's name as keywords); found by the fuzzer,
// where assimp threw and leaked. The reader must read them all the same.
TEST(Stl, AsciiLayoutsAssimpWouldMisread) {
  const std::string text =
      "\n\n  solid part vertex 1 2 3 facet normal\n"
      "facet\nnormal 0 0\n-1 outer loop vertex 0 0 0 vertex\n0 1 0\n vertex 1 0 0 endloop endfacet\n"
      "facet normal 0 0 1 outer loop vertex 12345678901234567890123 0 0 vertex 0 1 0 vertex 0 0 1 endloop endfacet\n"
      "endsolid part\n";
  MeshReport r;
  const Mesh m = read_stl_bytes(text, "layout.stl", &r);
  EXPECT_EQ(r.triangles, 2u);
  EXPECT_EQ(r.vertices, 5u);
  EXPECT_NEAR(r.bounds.max().x(), 12345678901234567890123.0, 1e16);  // float precision
}

TEST(Stl, BinaryHeaderThatLooksLikeAByteOrderMark) {
  for (const std::string& bom : {std::string("\xEF\xBB\xBF"), std::string("\xFF\xFE"), std::string("\xFE\xFF"),
                                std::string("\x00\x00\xFE\xFF", 4)}) {
    std::string bytes = to_binary_stl(cube());
    bytes.replace(0, bom.size(), bom);
    MeshReport r;
    read_stl_bytes(bytes, "bom.stl", &r);
    expect_closed_cube(r);
  }
}

TEST(Stl, ScaleOption) {
  StlReadOptions o;
  o.scale_to_mm = 25.4;
  MeshReport r;
  read_stl_bytes(to_binary_stl(make_box_mesh({0, 0, 0}, {1, 2, 3})), "inch.stl", &r, o);
  EXPECT_TRUE(r.bounds.max().isApprox(Eigen::Vector3d(25.4, 50.8, 76.2)));
  o.scale_to_mm = 0;
  EXPECT_THAT(error_of([&] { read_stl_bytes("solid", "x.stl", nullptr, o); }),
              HasSubstr("scale_to_mm: is 0; it must be finite and positive"));
}

TEST(Stl, OpenBoxAndNonManifoldFromFiles) {
  Mesh open = cube();
  open.triangles.pop_back();
  MeshReport r;
  read_stl_bytes(to_ascii_stl(open), "open.stl", &r);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.boundary_edges, 3u);
  read_stl_bytes(to_binary_stl(three_fins()), "fins.stl", &r);
  EXPECT_EQ(r.non_manifold_edges, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
}

TEST(Stl, TruncatedBinaryNamesBothCounts) {
  const std::string bytes = to_binary_stl(cube());
  EXPECT_EQ(error_of([&] { read_stl_bytes(bytes.substr(0, bytes.size() - 50), "cut.stl"); }),
            "cut.stl: binary STL declares 12 triangles but the file holds 11 (634 bytes; a binary STL is 84 bytes "
            "plus 50 per triangle)");
  EXPECT_THAT(error_of([&] { read_stl_bytes(bytes.substr(0, bytes.size() - 7), "cut.stl"); }),
              StartsWith("cut.stl: binary STL declares 12 triangles but the file holds 11 and 43 bytes more"));
  EXPECT_THAT(error_of([&] { read_stl_bytes(bytes + "xx", "long.stl"); }),
              StartsWith("long.stl: binary STL declares 12 triangles but the file holds 12 and 2 bytes more"));
  EXPECT_THAT(error_of([&] { read_stl_bytes(bytes.substr(0, 40), "head.stl"); }),
              HasSubstr("head.stl: not an STL file: 40 bytes, too short"));
}

TEST(Stl, BinaryRefusals) {
  std::string empty = to_binary_stl(Mesh{});
  EXPECT_EQ(error_of([&] { read_stl_bytes(empty, "empty.stl"); }), "empty.stl: binary STL holds no triangle");
  std::string nan = to_binary_stl(cube());
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + 84 + 50 * 4 + 12 + 4, &q, 4);
  EXPECT_EQ(error_of([&] { read_stl_bytes(nan, "nan.stl"); }), "nan.stl: binary STL triangle 5 has a non-finite coordinate");
  StlReadOptions o;
  o.max_triangles = 10;
  EXPECT_THAT(error_of([&] { read_stl_bytes(to_binary_stl(cube()), "big.stl", nullptr, o); }),
              HasSubstr("big.stl: binary STL holds 12 triangles, more than the limit of 10"));
}

TEST(Stl, AsciiStructureErrorsNameTheLine) {
  const std::string good = to_ascii_stl(cube());
  auto broken = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return error_of([&] { read_stl_bytes(s, "part.stl"); });
  };
  // Line 1 "solid", facet k starts at line 2 + 7 k: facet, outer loop, 3 vertices, endloop, endfacet.
  EXPECT_EQ(broken("    endloop\n", ""), "part.stl:7: expected 'endloop', found 'endfacet'");
  EXPECT_EQ(broken("      vertex", "      vortex"), "part.stl:4: expected 'vertex', found 'vortex'");
  EXPECT_THAT(broken("facet normal 0 0 -1", "facet normal 0 0 x"), HasSubstr("part.stl:2: expected a number, found 'x'"));
  EXPECT_THAT(broken("    endloop\n", "      vertex 1 2 3\n    endloop\n"),
              HasSubstr("part.stl:7: facet with more than three vertices"));
  EXPECT_THAT(broken("      vertex", "      vertex 1e999 1 1\n      vertex"), HasSubstr("part.stl:4: number '1e999'"));
  EXPECT_THAT(error_of([&] { read_stl_bytes(good.substr(0, good.rfind("endsolid")), "cut.stl"); }),
              HasSubstr("cut.stl:86: the file ends before 'endsolid'"));
  EXPECT_THAT(error_of([&] { read_stl_bytes("solid empty\nendsolid empty\n", "e.stl"); }),
              HasSubstr("e.stl: ASCII STL holds no facet"));
  EXPECT_THAT(error_of([&] { read_stl_bytes(good + "junk\n", "tail.stl"); }),
              HasSubstr("tail.stl:87: expected 'solid' or the end of the file, found 'junk'"));
}

TEST(Stl, GarbageIsRefused) {
  TempDir dir;
  const std::string text = dir.write("notes.stl", "these are not triangles\n");
  EXPECT_EQ(error_of([&] { read_stl(text); }), text + ": not an STL file: plain text that does not start with 'solid'");
  std::string noise(1000, '\0');
  for (std::size_t k = 0; k < noise.size(); ++k) noise[k] = static_cast<char>((k * 7919) % 251);
  const std::string bin = dir.write("noise.stl", noise);
  EXPECT_THAT(error_of([&] { read_stl(bin); }), StartsWith(bin + ": binary STL declares"));
  const std::string empty = dir.write("empty.stl", "");
  EXPECT_THAT(error_of([&] { read_stl(empty); }), StartsWith(empty + ": "));
  EXPECT_THAT(error_of([] { read_stl("/nonexistent/x.stl"); }), StartsWith("/nonexistent/x.stl: "));
  // An OBJ file is text without 'solid': refused, not guessed at.
  const std::string obj = dir.write("box.stl", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_THAT(error_of([&] { read_stl(obj); }), HasSubstr("does not start with 'solid'"));
}

TEST(Cli, MeshCommand) {
  test::Cli cli;
  const std::string good = cli.write("cube.stl", to_binary_stl(cube()));
  const test::CliResult ok = cli.run({"mesh", good, "--json"});
  EXPECT_EQ(ok.code, 0);
  EXPECT_THAT(ok.out, HasSubstr("\"closed\": true"));
  EXPECT_THAT(ok.out, HasSubstr(fmt::format("\"volume_mm3\": {}", kCubeVolume)));

  EXPECT_THAT(ok.out, HasSubstr("\"sound\": true"));
  const test::CliResult text = cli.run({"mesh", good});
  EXPECT_EQ(text.code, 0);
  EXPECT_THAT(text.out, HasSubstr("verdict: sound: a closed solid"));

  // An open or inside-out mesh is not a sound solid: said in a verdict line, exit 3.
  Mesh open = cube();
  open.triangles.erase(open.triangles.begin() + 2, open.triangles.begin() + 4);
  const test::CliResult o = cli.run({"mesh", cli.write("open.stl", to_binary_stl(open))});
  EXPECT_EQ(o.code, 3);
  EXPECT_THAT(o.out, HasSubstr("verdict: not a sound solid: open: 4 boundary edges\n"));
  Mesh flipped = cube();
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  const test::CliResult f = cli.run({"mesh", cli.write("flipped.stl", to_binary_stl(flipped)), "--json"});
  EXPECT_EQ(f.code, 3);
  EXPECT_THAT(f.out, HasSubstr("\"sound\": false"));
  EXPECT_THAT(f.out, HasSubstr("faces point inwards"));

  const std::string bad = cli.write("bad.stl", "solid x\nfacet normal 0 0 1\nendsolid\n");
  const test::CliResult r = cli.run({"mesh", bad});
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.err, HasSubstr(bad + ":3: expected 'outer', found 'endsolid'"));
}

}  // namespace
}  // namespace machplan
