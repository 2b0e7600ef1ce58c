// Triangle meshes (workpieces, fixtures) read from STL, and a report of their soundness.
//
// Reading
// -------
// read_stl() accepts binary and ASCII STL. Units are millimetres unless
// StlReadOptions::scale_to_mm says otherwise (25.4 for a file in inches). One pass checks the
// structure, naming each problem precisely, and collects the corners:
//
//   * binary: 80-byte header, uint32 triangle count N, then N records of 50 bytes (normal,
//     three vertices as little-endian float32, 2 attribute bytes). The file size must be
//     exactly 84 + 50 N, otherwise: "FILE: binary STL declares N triangles but the file holds M".
//   * ASCII: "solid [name]" then facets, keywords case-insensitive, any whitespace between
//     tokens, several solids one after another allowed:
//         facet normal nx ny nz / outer loop / vertex x y z (three times) / endloop / endfacet
//     ending with "endsolid [name]". A break in that structure is named with its line
//     ("part.stl:12: expected 'vertex', found 'endloop'"); facets with more than three
//     vertices are refused.
//   * A file of plain text (no control bytes but whitespace) is ASCII and must start with
//     "solid"; anything else is taken to be binary (binary headers that start with "solid",
//     as many exporters write, are fine).
//
// ASCII numbers are kept at double precision (binary ones are float32 by definition); an ASCII
// number beyond float32's range (3.4e38) is refused.
//
// Refused, always as InputError naming the file: the cases above, non-finite coordinates
// (also after scaling), an STL with no triangle and more than StlReadOptions::max_triangles
// triangles. Normals stored in the file are ignored: orientation
// comes from the vertex order (counter-clockwise seen from outside), as in every STL consumer.
//
// Vertices are welded: a corner within StlReadOptions::weld_tolerance_mm (0: bit-identical
// after scaling) of an earlier vertex becomes that vertex (the nearest such), and
// bit-identical corners always become one vertex, so that the triangles share indices and the report can see
// the mesh's topology. Triangle indices refer to Mesh::vertices. Degenerate triangles are kept
// (and counted in the report).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace machplan {

struct Mesh {
  std::vector<Eigen::Vector3d> vertices;   // mm
  std::vector<Eigen::Vector3i> triangles;  // indices into vertices, counter-clockwise from outside
};

// Topology and size of a mesh. Edges are unordered vertex pairs of the (welded) triangles;
// triangles with a repeated vertex index have no proper edges and are left out of the edge
// counts.
struct MeshReport {
  std::size_t vertices = 0, triangles = 0;
  std::size_t edges = 0;
  std::size_t non_manifold_edges = 0;  // used by more than two triangles
  std::size_t boundary_edges = 0;      // used by exactly one triangle
  bool closed = false;                 // at least one triangle, no boundary or non-manifold edge
  // A repeated vertex index, or (near) zero area: |(b-a) x (c-a)| <= 1e-12 * (longest edge)^2.
  std::size_t degenerate_triangles = 0;
  // Every edge shared by two triangles is walked in opposite directions by them, and no edge is
  // non-manifold (with three or more triangles on an edge orientation has no meaning).
  bool consistently_oriented = false;
  // Enclosed volume, when closed and consistently oriented; 0 otherwise.
  double volume_mm3 = 0.0;
  // When the volume is known: true if the triangles face outwards (positive signed volume).
  bool outward = false;
  Eigen::AlignedBox3d bounds;  // of all vertices; empty for an empty mesh

  // A sound solid: closed, consistently oriented and facing outwards, so that it has an inside
  // and a volume (degenerate triangles are counted, not held against it: they enclose nothing).
  bool sound() const { return closed && consistently_oriented && outward; }
  // One line: "sound: a closed solid, consistently oriented, faces outwards", or "not a sound
  // solid: " and each fault ("open: 3 boundary edges", "faces point inwards", ...).
  std::string verdict() const;
  std::string brief() const;   // a few lines for a terminal, ending with the verdict
};

MeshReport analyze_mesh(const Mesh& mesh);

struct StlReadOptions {
  double scale_to_mm = 1.0;          // multiply every coordinate; must be finite and > 0
  double weld_tolerance_mm = 0.0;    // 0 .. kMaxWeldToleranceMm; see above
  // Welding merges corners this close; beyond a few millimetres it merges the solid itself.
  static constexpr double kMaxWeldToleranceMm = 10.0;
  std::size_t max_triangles = 20'000'000;
  std::size_t max_file_bytes = std::size_t{1} << 30;  // binary STL of 20 M triangles is 1 GB

  void validate() const;  // throws InputError naming the field
};

// Reads an STL file; fills `report` (when not null) with analyze_mesh() of the result.
Mesh read_stl(const std::string& path, MeshReport* report = nullptr, const StlReadOptions& options = {});

// The same on bytes in memory; `source` names them in messages.
Mesh read_stl_bytes(std::string_view bytes, const std::string& source, MeshReport* report = nullptr,
                    const StlReadOptions& options = {});

// Merges vertices closer than `tolerance_mm` (0: identical) and renumbers the triangles. Corners
// are taken in order: each joins the nearest vertex made so far within the tolerance, or
// becomes a new vertex. So identical corners always share a vertex, every corner lies within
// the tolerance of its vertex, and two vertices may still lie closer than the tolerance to
// each other (welding is not transitive).
Mesh weld(const std::vector<Eigen::Vector3d>& corners, double tolerance_mm);

// An axis-aligned box from `min` to `max` (12 triangles, outward-facing, closed), for tests
// and examples.
Mesh make_box_mesh(const Eigen::Vector3d& min, const Eigen::Vector3d& max);

// STL text / bytes of a mesh, for tests, seeds and exports. Normals are computed.
std::string to_ascii_stl(const Mesh& mesh, std::string_view solid_name = "machplan");
std::string to_binary_stl(const Mesh& mesh);

}  // namespace machplan
