// The DXF profile reader's inside, shared by its files (not part of the installed interface).
// Our own pass from the file to contours (no third-party DXF parser: the group-code structure
// is checked here anyway, and the geometry needs our own types), in three stages:
//   1. scan (dxf_scan.cpp, dxf_binary.cpp): split the file into group-code / value pairs up
//      to 0/EOF (ASCII, or binary DXF turned into the same pairs), check every pair, follow
//      SECTION / ENDSEC, collect the header's $INSUNITS, the blocks of the BLOCKS section and
//      the entities of the ENTITIES section with their line numbers, handles and layers.
//   2. expand (dxf_expand.cpp): every model-space entity, and through INSERT every entity of
//      the inserted blocks (nested, arrays), becomes a piece of lines and arcs in mm. Each
//      entity is read in its own coordinates and mapped by one 2-D affine map (the inserts'
//      placements, the object coordinate system's projection onto XY, the units); arcs that
//      map to ellipses and all smooth curves (SPLINE, ELLIPSE) are fitted with biarcs
//      (engine/geometry/curve_fit.h).
//   3. assemble (dxf_assemble.cpp): drop zero-length and duplicate pieces, chain open pieces
//      into contours (engine/geometry/chaining.h), check each contour and the pairs of
//      contours whose boxes meet (sweep and prune), nest them (engine/geometry/nesting.h).
// dxf.cpp runs the stages and holds the public functions.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "engine/geometry/chaining.h"
#include "engine/programs/dxf.h"

namespace machplan::dxf {

// ---------------------------------------------------------------------------------------
// Stage 1: scanning.

struct Pair {
  int code = 0;
  std::string value;
  int line = 0;  // 1-based line of the group code (binary DXF: as in the file's ASCII form)
};

struct Entity {
  std::string type;
  int line = 0;
  std::string handle;  // code 5 as written, or "TYPE#n"
  std::string layer = "0";
  bool paper_space = false;
  std::vector<Pair> pairs;                 // the entity's own pairs (after the 0/TYPE)
  std::vector<std::vector<Pair>> vertices; // POLYLINE: each VERTEX's pairs
  std::vector<int> vertex_lines;
};

struct Block {
  std::string name;
  int line = 0;
  Eigen::Vector2d base = Eigen::Vector2d::Zero();
  bool external = false;  // an xref: its geometry lives in another file
  std::vector<Entity> entities;
};

struct Scan {
  double mm_per_unit = 0.0;  // from $INSUNITS; 0 when absent or unitless
  std::vector<Entity> entities;
  std::map<std::string, Block> blocks;  // by upper-case name (DXF names are case-insensitive)
};

Scan scan(std::string_view text, const std::string& source);

// Binary DXF (dxf_binary.cpp): whether the text opens with its sentinel, and its pairs, each
// value written as an ASCII DXF would hold it and each pair numbered with the line it would
// have there (pair k at line 2k + 1), up to 0/EOF.
bool is_binary_dxf(std::string_view text);
std::vector<Pair> binary_pairs(std::string_view text, const std::string& source);

// Values of pairs; InputError naming the value's line when it does not parse.
double parse_real(const std::string& source, const Pair& p);
long parse_int(const std::string& source, const Pair& p);
// The value of the first pair with `code` in `pairs`, or `dflt`.
double real_of(const std::string& source, const std::vector<Pair>& pairs, int code, double dflt = 0.0);
long int_of(const std::string& source, const std::vector<Pair>& pairs, int code, long dflt = 0);
// Points given as runs of x, y, z codes (10/20/30, 11/21/31, ...): each x code starts a point.
std::vector<Eigen::Vector3d> points_of(const std::string& source, const std::vector<Pair>& pairs, int xcode,
                                       const char* what);
std::string upper(std::string s);

// ---------------------------------------------------------------------------------------
// What stages 2 and 3 share.

// An oriented run of spans from one entity (or a chain of them); `parts` are instances.
using Piece = SpanRun;

// One drawn entity: a model-space entity, or an entity of a block seen through an INSERT.
struct Instance {
  const Entity* entity = nullptr;
  std::string handle;  // "H" in model space, "INSERT>...>H" through inserts
  std::string layer;
};

std::string fmt_pt(const Eigen::Vector2d& p);

// The drawing being read: its instances and the problems found, named by instance.
class Drawing {
 public:
  Drawing(const std::string& source, const DxfOptions& options, ProfileReadResult& out)
      : source_(source), options_(options), out_(out) {}

  const std::string& source() const { return source_; }
  const DxfOptions& options() const { return options_; }
  ProfileReadResult& out() { return out_; }

  // A new instance of `e`; InputError past DxfOptions::max_entities.
  std::size_t new_instance(const Entity& e, std::string handle, std::string layer);
  const Instance& instance(std::size_t k) const { return instances_[k]; }
  const std::string& label(std::size_t k) const { return instances_[k].handle; }
  // "TYPE HANDLE (layer L, line N)", for messages.
  std::string where(std::size_t k) const;
  int line_of(std::size_t k) const { return instances_[k].entity->line; }

  // Adds a problem naming `insts`; `option`: the DxfOptions field that settles it, if one does.
  void problem(ProfileProblem::Severity s, std::string kind, const std::vector<std::size_t>& insts,
               std::string message, std::optional<Eigen::Vector2d> at = std::nullopt, std::string option = {});

 private:
  const std::string& source_;
  const DxfOptions& options_;
  ProfileReadResult& out_;
  std::vector<Instance> instances_;
};

// Stage 2: the pieces of every drawn entity, in mm, in file order.
std::vector<Piece> expand(Drawing& d, const Scan& scan, double mm_per_unit);

// Stage 3: the pieces into ProfileReadResult::contours, nested, with their problems.
void assemble(Drawing& d, std::vector<Piece> pieces);

}  // namespace machplan::dxf
