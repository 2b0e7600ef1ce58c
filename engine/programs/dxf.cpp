// DXF profile reader, our own pass from text to contours (no third-party DXF parser: the
// group-code structure is checked here anyway, and the geometry needs our own types). Stages:
//   1. scan():     split into group-code / value pairs up to 0/EOF, check every pair, follow
//                  SECTION / ENDSEC, collect the header's $INSUNITS, the blocks of the BLOCKS
//                  section and the entities of the ENTITIES section with their line numbers,
//                  handles and layers.
//   2. expand():   every model-space entity, and through INSERT every entity of the inserted
//                  blocks (nested, arrays), becomes a piece of lines and arcs in mm. Each
//                  entity is read in its own coordinates and mapped by one 2-D affine map (the
//                  inserts' placements, the object coordinate system's projection onto XY, the
//                  units); arcs that map to ellipses and all smooth curves (SPLINE, ELLIPSE)
//                  are fitted with biarcs (engine/geometry/curve_fit.h).
//   3. assemble:   drop zero-length and duplicate pieces, chain open pieces into contours
//                  through a grid of end points, check each contour and the pairs of contours
//                  whose boxes meet (sweep and prune), nest them.
#include "engine/programs/dxf.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <unordered_map>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/geometry/curve_fit.h"

namespace machplan {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

// ---------------------------------------------------------------------------------------
// Stage 1: scanning.

struct Pair {
  int code = 0;
  std::string value;
  int line = 0;  // 1-based line of the group code
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
  Vector2d base = Vector2d::Zero();
  bool external = false;  // an xref: its geometry lives in another file
  std::vector<Entity> entities;
};

struct Scan {
  double mm_per_unit = 0.0;  // from $INSUNITS; 0 when absent or unitless
  std::vector<Entity> entities;
  std::map<std::string, Block> blocks;  // by upper-case name (DXF names are case-insensitive)
};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

double parse_real(const std::string& source, const Pair& p) {
  const std::string_view v = trim(p.value);
  double x = 0.0;
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (v.empty() || ec != std::errc() || ptr != v.data() + v.size())
    throw InputError(source, p.line + 1, fmt::format("group code {}: '{}' is not a number", p.code, excerpt(v)));
  if (!std::isfinite(x) || std::abs(x) > kMaxCoordinateMm)
    throw InputError(source, p.line + 1,
                     fmt::format("group code {}: {} is not finite or beyond {:g}", p.code, excerpt(v), kMaxCoordinateMm));
  return x;
}

long parse_int(const std::string& source, const Pair& p) {
  const std::string_view v = trim(p.value);
  long x = 0;
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (v.empty() || ec != std::errc() || ptr != v.data() + v.size() || x < -2147483648L || x > 2147483647L)
    throw InputError(source, p.line + 1, fmt::format("group code {}: '{}' is not an integer", p.code, excerpt(v)));
  return x;
}

// mm per drawing unit for $INSUNITS; 0 for 0 (unitless), which reads as no units given.
double insunits_scale(const std::string& source, const Pair& p) {
  switch (parse_int(source, p)) {
    case 0: return 0.0;         // unitless: as if there were no $INSUNITS
    case 1: return 25.4;        // inches
    case 2: return 304.8;       // feet
    case 4: return 1.0;         // millimetres
    case 5: return 10.0;        // centimetres
    case 6: return 1000.0;      // metres
    case 8: return 25.4e-6;     // microinches
    case 9: return 0.0254;      // mils
    case 10: return 914.4;      // yards
    case 13: return 1e-3;       // microns
    case 14: return 100.0;      // decimetres
    default:
      throw InputError(source, p.line + 1,
                       fmt::format("$INSUNITS {} is not a length unit machplan knows", trim(p.value)));
  }
}

std::vector<Pair> split_pairs(std::string_view text, const std::string& source) {
  if (text.substr(0, 18) == "AutoCAD Binary DXF")
    throw InputError(source, 1, "binary DXF is not supported; save the drawing as ASCII DXF");
  std::vector<std::string_view> lines;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    lines.push_back(text.substr(pos, nl - pos));
    pos = nl + 1;
  }
  std::vector<Pair> pairs;
  pairs.reserve(lines.size() / 2);
  for (std::size_t k = 0; k < lines.size(); k += 2) {
    const int line = static_cast<int>(k) + 1;
    if (lines[k].find('\0') != std::string_view::npos || (k + 1 < lines.size() && lines[k + 1].find('\0') != std::string_view::npos))
      throw InputError(source, lines[k].find('\0') != std::string_view::npos ? line : line + 1,
                       "NUL byte: not an ASCII DXF file");
    const std::string_view code_text = trim(lines[k]);
    int code = 0;
    const auto [ptr, ec] = std::from_chars(code_text.data(), code_text.data() + code_text.size(), code);
    if (code_text.empty() || ec != std::errc() || ptr != code_text.data() + code_text.size() || code < -5 || code > 1071)
      throw InputError(source, line,
                       fmt::format("expected a DXF group code (an integer 0..1071), found '{}'",
                                   excerpt(code_text, 40)));
    if (k + 1 >= lines.size())
      throw InputError(source, line, fmt::format("group code {} has no value: the file is truncated", code));
    std::string_view value = lines[k + 1];
    if (!value.empty() && value.back() == '\r') value.remove_suffix(1);
    if (code != 1 && code != 3) value = trim(value);  // text values keep their spaces
    if (value.size() > 2049)
      throw InputError(source, line + 1, fmt::format("value of group code {} is {} characters long; DXF allows 2049",
                                                     code, value.size()));
    pairs.push_back({code, std::string(value), line});
    if (code == 0 && value == "EOF") break;  // whatever follows the end marker is not ours
  }
  return pairs;
}

const std::set<std::string>& annotation_types() {
  static const std::set<std::string> t = {"TEXT", "MTEXT", "DIMENSION", "ARC_DIMENSION",
                                          "LARGE_RADIAL_DIMENSION", "LEADER", "MLEADER",
                                          "MULTILEADER", "ATTDEF", "ATTRIB", "HATCH", "POINT",
                                          "VIEWPORT", "TOLERANCE", "IMAGE", "WIPEOUT",
                                          "OLEFRAME", "OLE2FRAME", "SOLID", "TRACE", "XLINE",
                                          "RAY", "SHAPE"};
  return t;
}

bool is_supported(const std::string& type) {
  return type == "LINE" || type == "ARC" || type == "CIRCLE" || type == "LWPOLYLINE" || type == "POLYLINE" ||
         type == "SPLINE" || type == "ELLIPSE" || type == "INSERT";
}

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

double real_of(const std::string& source, const std::vector<Pair>& pairs, int code, double dflt = 0.0);

Scan scan(std::string_view text, const std::string& source) {
  const std::vector<Pair> pairs = split_pairs(text, source);
  Scan out;
  std::map<std::string, int> type_count;
  std::string section;  // empty: between sections
  bool seen_eof = false;
  Block* block = nullptr;  // the block being read in the BLOCKS section
  std::size_t i = 0;
  auto finish_entity = [&](Entity& e) {
    for (const auto& p : e.pairs) {
      if (p.code == 5) e.handle = p.value;
      if (p.code == 8) e.layer = p.value;
      if (p.code == 67) e.paper_space = parse_int(source, p) == 1;
    }
    if (e.handle.empty()) e.handle = fmt::format("{}#{}", e.type, ++type_count[e.type]);
  };
  // Reads the entity starting at pairs[i] (a 0/TYPE pair) with its VERTEX / ATTRIB followers.
  auto read_entity = [&]() {
    const Pair& p = pairs[i];
    Entity e;
    e.type = p.value;
    e.line = p.line;
    ++i;
    while (i < pairs.size() && pairs[i].code != 0) e.pairs.push_back(pairs[i++]);
    if (e.type == "VERTEX" || e.type == "SEQEND")
      throw InputError(source, e.line, fmt::format("{} outside a POLYLINE", e.type));
    if (e.type == "POLYLINE") {
      // Its VERTEX entities follow until SEQEND.
      while (i < pairs.size() && pairs[i].code == 0 && pairs[i].value == "VERTEX") {
        e.vertex_lines.push_back(pairs[i].line);
        ++i;
        std::vector<Pair> v;
        while (i < pairs.size() && pairs[i].code != 0) v.push_back(pairs[i++]);
        e.vertices.push_back(std::move(v));
      }
      if (i >= pairs.size() || pairs[i].value != "SEQEND")
        throw InputError(source, i < pairs.size() ? pairs[i].line : pairs.back().line,
                         "POLYLINE is not closed by 0/SEQEND");
      ++i;
      while (i < pairs.size() && pairs[i].code != 0) ++i;  // SEQEND's own pairs
    }
    if (e.type == "INSERT") {
      // Attributes (text) may follow, closed by SEQEND; they carry no geometry.
      bool attributes = false;
      while (i < pairs.size() && pairs[i].code == 0 && pairs[i].value == "ATTRIB") {
        attributes = true;
        ++i;
        while (i < pairs.size() && pairs[i].code != 0) ++i;
      }
      if (attributes || (i < pairs.size() && pairs[i].code == 0 && pairs[i].value == "SEQEND")) {
        if (i >= pairs.size() || pairs[i].value != "SEQEND")
          throw InputError(source, i < pairs.size() ? pairs[i].line : pairs.back().line,
                           "the attributes of an INSERT are not closed by 0/SEQEND");
        ++i;
        while (i < pairs.size() && pairs[i].code != 0) ++i;
      }
    }
    finish_entity(e);
    return e;
  };
  while (i < pairs.size()) {
    const Pair& p = pairs[i];
    if (section.empty()) {
      if (p.code == 999) { ++i; continue; }
      if (p.code != 0)
        throw InputError(source, p.line, fmt::format("expected 0/SECTION or 0/EOF, found group code {}", p.code));
      if (p.value == "EOF") { seen_eof = true; break; }
      if (p.value != "SECTION")
        throw InputError(source, p.line, fmt::format("expected 0/SECTION or 0/EOF, found 0/{}", p.value.substr(0, 40)));
      if (i + 1 >= pairs.size() || pairs[i + 1].code != 2)
        throw InputError(source, p.line, "0/SECTION is not followed by its name (group code 2)");
      section = pairs[i + 1].value;
      if (section.empty()) section.push_back('?');  // not = "?": g++ 12 warns falsely (-Wrestrict)
      i += 2;
      continue;
    }
    if (p.code == 0 && p.value == "ENDSEC") {
      if (block) throw InputError(source, p.line, fmt::format("block {} has no 0/ENDBLK", block->name));
      section.clear();
      ++i;
      continue;
    }
    if (p.code == 0 && (p.value == "EOF" || p.value == "SECTION"))
      throw InputError(source, p.line, fmt::format("section {} has no 0/ENDSEC before 0/{}", section, p.value));
    if (section == "HEADER") {
      if (p.code == 9 && p.value == "$INSUNITS") {
        if (i + 1 >= pairs.size() || pairs[i + 1].code != 70)
          throw InputError(source, p.line, "$INSUNITS is not followed by its value (group code 70)");
        out.mm_per_unit = insunits_scale(source, pairs[i + 1]);
        i += 2;
        continue;
      }
      ++i;
      continue;
    }
    if (section == "BLOCKS") {
      if (p.code != 0)
        throw InputError(source, p.line, fmt::format("expected 0/BLOCK or an entity, found group code {}", p.code));
      if (p.value == "BLOCK") {
        if (block) throw InputError(source, p.line, fmt::format("block {} has no 0/ENDBLK", block->name));
        Block b;
        b.line = p.line;
        ++i;
        std::vector<Pair> own;
        while (i < pairs.size() && pairs[i].code != 0) own.push_back(pairs[i++]);
        for (const auto& q : own) {
          if (q.code == 2) b.name = q.value;
          if (q.code == 70) b.external = (parse_int(source, q) & 4) != 0;
        }
        b.base = {real_of(source, own, 10), real_of(source, own, 20)};
        if (b.name.empty()) throw InputError(source, b.line, "BLOCK without a name (group code 2)");
        const std::string key = upper(b.name);
        block = &(out.blocks[key] = std::move(b));
        continue;
      }
      if (p.value == "ENDBLK") {
        if (!block) throw InputError(source, p.line, "0/ENDBLK without a 0/BLOCK");
        block = nullptr;
        ++i;
        while (i < pairs.size() && pairs[i].code != 0) ++i;
        continue;
      }
      if (!block) throw InputError(source, p.line, fmt::format("entity {} outside a block", p.value.substr(0, 40)));
      block->entities.push_back(read_entity());
      continue;
    }
    if (section != "ENTITIES") { ++i; continue; }
    if (p.code != 0)
      throw InputError(source, p.line, fmt::format("expected an entity (group code 0), found group code {}", p.code));
    out.entities.push_back(read_entity());
  }
  if (!seen_eof) {
    const int last = pairs.empty() ? 1 : pairs.back().line + 1;
    throw InputError(source, last, pairs.empty() ? "empty file: not a DXF drawing"
                                                 : "the file ends without 0/EOF: it is truncated");
  }
  return out;
}

// Values of the given codes in `pairs` (the first occurrence), with a default.
double real_of(const std::string& source, const std::vector<Pair>& pairs, int code, double dflt) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_real(source, p);
  return dflt;
}
long int_of(const std::string& source, const std::vector<Pair>& pairs, int code, long dflt = 0) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_int(source, p);
  return dflt;
}

// Points given as runs of x, y, z codes (10/20/30, 11/21/31, ...): each x code starts a point.
std::vector<Vector3d> points_of(const std::string& source, const std::vector<Pair>& pairs, int xcode,
                                const char* what) {
  std::vector<Vector3d> pts;
  for (const auto& p : pairs) {
    if (p.code == xcode) pts.emplace_back(parse_real(source, p), 0, 0);
    if (p.code == xcode + 10 || p.code == xcode + 20) {
      if (pts.empty())
        throw InputError(source, p.line, fmt::format("{}: group code {} before the first point ({})", what, p.code, xcode));
      pts.back()[p.code == xcode + 10 ? 1 : 2] = parse_real(source, p);
    }
  }
  return pts;
}

// ---------------------------------------------------------------------------------------
// Stage 2: entities to pieces.

// A 2-D affine map x -> A x + b.
struct Affine {
  Eigen::Matrix2d A = Eigen::Matrix2d::Identity();
  Vector2d b = Vector2d::Zero();
  Vector2d operator()(const Vector2d& x) const { return A * x + b; }
  Affine then(const Affine& outer) const { return {outer.A * A, outer.A * b + outer.b}; }
  // True when the map keeps circles circles: A^T A = s^2 I.
  bool similarity() const {
    const Vector2d c0 = A.col(0), c1 = A.col(1);
    const double s2 = 0.5 * (c0.squaredNorm() + c1.squaredNorm());
    return std::abs(c0.dot(c1)) <= 1e-12 * s2 && std::abs(c0.squaredNorm() - c1.squaredNorm()) <= 1e-12 * s2;
  }
};

// An oriented run of spans from one entity (or a chain of them): vertices.size() - 1 bulges
// when open, vertices.size() when closed.
struct Piece {
  std::vector<Vector2d> v;
  std::vector<double> b;
  bool closed = false;
  std::vector<std::size_t> entities;

  Vector2d front() const { return v.front(); }
  Vector2d back() const { return v.back(); }
  void reverse() {
    std::reverse(v.begin(), v.end());
    std::reverse(b.begin(), b.end());
    for (auto& x : b) x = -x;
    if (closed && !b.empty()) std::rotate(b.begin(), b.begin() + 1, b.end());
  }
  double length() const {
    double sum = 0;
    for (std::size_t i = 0; i < b.size(); ++i) sum += machplan::length(make_segment(v[i], v[(i + 1) % v.size()], b[i]));
    return sum;
  }
};

std::string fmt_pt(const Vector2d& p) { return fmt::format("({:.4f}, {:.4f})", p.x(), p.y()); }

// One drawn entity: a model-space entity, or an entity of a block seen through an INSERT.
struct Instance {
  const Entity* entity = nullptr;
  std::string handle;  // "H" in model space, "INSERT>...>H" through inserts
  std::string layer;
};

// Halvings per curve piece when fitting arcs (the arcs of all curves together are bounded by
// DxfOptions::max_fitted_spans).
constexpr int kFitDepth = 18;
// Deepest nesting of INSERT within blocks.
constexpr int kMaxInsertDepth = 32;

class Assembler {
 public:
  Assembler(const std::string& source, const Scan& scan, const DxfOptions& opt, ProfileReadResult& out)
      : source_(source), scan_(scan), opt_(opt), tol_(opt.chain_tolerance_mm), fit_tol_(0.5 * opt.chain_tolerance_mm),
        tan_flat_(std::tan(opt.flatten_tolerance_deg * kPi / 180)), out_(out) {}

  std::string label(std::size_t inst) const { return instances_[inst].handle; }
  std::string where(std::size_t inst) const {
    const auto& in = instances_[inst];
    return fmt::format("{} {} (layer {}, line {})", excerpt(in.entity->type), excerpt(in.handle), excerpt(in.layer),
                       in.entity->line);
  }
  int line_of(std::size_t inst) const { return instances_[inst].entity->line; }

  void problem(ProfileProblem::Severity s, std::string kind, std::vector<std::size_t> insts, std::string message,
               std::optional<Vector2d> at = std::nullopt) {
    ProfileProblem p{s, std::move(kind), {}, std::move(message), at, std::nullopt};
    for (auto e : insts) p.handles.push_back(label(e));
    out_.problems.push_back(std::move(p));
  }

  // Every model-space entity and, through INSERT, every entity of the blocks it places.
  void expand(double mm_per_unit) {
    Affine units;
    units.A *= mm_per_unit;
    // A drawing made entirely on a layout (nothing in model space) is read from the layout.
    const bool layout_only = !scan_.entities.empty() &&
                             std::all_of(scan_.entities.begin(), scan_.entities.end(), [](const Entity& e) { return e.paper_space; });
    if (layout_only)
      problem(ProfileProblem::Severity::warning, "paper_space", {},
              fmt::format("the drawing has nothing in model space; its {} paper-space entities are read as the profile",
                          scan_.entities.size()));
    for (const Entity& e : scan_.entities) {
      if (e.paper_space && !layout_only) {
        const std::size_t k = new_instance(e, e.handle, e.layer);
        problem(ProfileProblem::Severity::warning, "paper_space", {k}, fmt::format("{} is on a paper-space layout; ignored", where(k)));
        continue;
      }
      entity(e, e.handle, e.layer, units, 0, {});
    }
    if (tilted_ > 0)
      problem(ProfileProblem::Severity::warning, "flattened", {},
              fmt::format("{} entit{} lie up to {:.4g} degrees off the XY plane; projected onto it (flatten tolerance "
                          "{:g} degrees)",
                          tilted_, tilted_ == 1 ? "y" : "ies", max_tilt_deg_, opt_.flatten_tolerance_deg));
    if (max_fit_deviation_ > fit_tol_)
      problem(ProfileProblem::Severity::warning, "approximation", {},
              fmt::format("a curve could only be fitted to within {:.3g} mm (asked {:g} mm)", max_fit_deviation_, fit_tol_));
  }

 private:
  std::size_t new_instance(const Entity& e, std::string handle, std::string layer) {
    if (instances_.size() >= opt_.max_entities)
      throw InputError(source_, e.line,
                       fmt::format("the drawing holds more than {} entities (INSERT copies counted); the limit "
                                   "bounds the time and memory a read takes, about 1 s per 100 000: raise it",
                                   opt_.max_entities))
          .with_option("max_entities");
    instances_.push_back({&e, std::move(handle), std::move(layer)});
    return instances_.size() - 1;
  }

  // The object coordinate system of extrusion (ex, ey, ez) seen from above, as a 2-D map
  // of OCS (x, y) at OCS height z (AutoCAD's arbitrary axis algorithm). Reports and returns
  // false when the plane is tilted beyond the flatten tolerance.
  bool ocs(std::size_t k, const std::vector<Pair>& P, double z, Affine& m) {
    Vector3d n(real_of(source_, P, 210, 0.0), real_of(source_, P, 220, 0.0), real_of(source_, P, 230, 1.0));
    const double len = n.norm();
    if (!(len > 0)) {
      problem(ProfileProblem::Severity::error, "not_planar", {k}, fmt::format("{} has a zero extrusion direction", where(k)));
      return false;
    }
    n /= len;
    if (!tilt_ok(k, std::atan2(n.head<2>().norm(), std::abs(n.z())))) return false;
    const Vector3d ax = ((std::abs(n.x()) < 1.0 / 64 && std::abs(n.y()) < 1.0 / 64) ? Vector3d::UnitY().cross(n)
                                                                                      : Vector3d::UnitZ().cross(n))
                            .normalized();
    const Vector3d ay = n.cross(ax);
    m.A.col(0) = ax.head<2>();
    m.A.col(1) = ay.head<2>();
    m.b = z * n.head<2>();
    return true;
  }

  bool tilt_ok(std::size_t k, double tilt_rad) {
    if (tilt_rad <= 1e-9) return true;
    const double deg = tilt_rad * 180 / kPi;
    if (deg > opt_.flatten_tolerance_deg) {
      problem(ProfileProblem::Severity::error, "not_planar", {k},
              fmt::format("{} lies {:.4g} degrees off the XY plane (flatten tolerance {:g} degrees; see "
                          "DxfOptions::flatten_tolerance_deg)",
                          where(k), deg, opt_.flatten_tolerance_deg));
      return false;
    }
    ++tilted_;
    max_tilt_deg_ = std::max(max_tilt_deg_, deg);
    return true;
  }

  // Points given in world coordinates must share one z, up to the tolerance plus the flatten
  // tolerance's slope over their extent.
  bool flat_ok(std::size_t k, const std::vector<Vector3d>& pts) {
    if (pts.empty()) return true;
    double zmin = pts[0].z(), zmax = zmin;
    Eigen::AlignedBox2d box;
    for (const auto& p : pts) {
      zmin = std::min(zmin, p.z());
      zmax = std::max(zmax, p.z());
      box.extend(Vector2d(p.head<2>()));
    }
    const double dz = zmax - zmin, extent = box.diagonal().norm();
    if (dz <= tol_) return true;
    const double deg = std::atan2(dz, extent) * 180 / kPi;
    if (dz <= tol_ + tan_flat_ * extent) {
      ++tilted_;
      max_tilt_deg_ = std::max(max_tilt_deg_, deg);
      return true;
    }
    problem(ProfileProblem::Severity::error, "not_planar", {k},
            fmt::format("{} spans z {:g} to {:g} ({:.4g} degrees over its extent; flatten tolerance {:g} degrees, see "
                        "DxfOptions::flatten_tolerance_deg)",
                        where(k), zmin, zmax, deg, opt_.flatten_tolerance_deg));
    return false;
  }

  void entity(const Entity& e, const std::string& handle, const std::string& layer, const Affine& world, int depth,
              const std::vector<std::string>& open_blocks) {
    const std::size_t k = new_instance(e, handle, layer);
    const auto E = ProfileProblem::Severity::error;
    if (!is_supported(e.type)) {
      if (annotation_types().count(e.type))
        problem(ProfileProblem::Severity::warning, "annotation_ignored", {k}, fmt::format("{} is drawing annotation; ignored", where(k)));
      else
        problem(E, "unsupported_entity", {k}, fmt::format("{} is not supported: its geometry is missing from the profile", where(k)));
      return;
    }
    const auto& P = e.pairs;
    if (e.type == "INSERT") return insert(k, e, world, depth, open_blocks);
    if (e.type == "SPLINE") return spline(k, e, world);
    if (e.type == "ELLIPSE") return ellipse(k, e, world);
    Piece local;
    Affine m;  // local -> world
    if (e.type == "LINE") {
      const Vector3d a(real_of(source_, P, 10), real_of(source_, P, 20), real_of(source_, P, 30));
      const Vector3d b(real_of(source_, P, 11), real_of(source_, P, 21), real_of(source_, P, 31));
      if (!flat_ok(k, {a, b})) return;
      local.v = {a.head<2>(), b.head<2>()};
      local.b = {0.0};
      m = world;
    } else if (e.type == "ARC" || e.type == "CIRCLE") {
      Affine o;
      if (!ocs(k, P, real_of(source_, P, 30), o)) return;
      m = o.then(world);
      const Vector2d c(real_of(source_, P, 10), real_of(source_, P, 20));
      const double r = real_of(source_, P, 40);
      double sweep = 360.0, a1 = 0.0;
      if (e.type == "ARC") {
        a1 = real_of(source_, P, 50);
        sweep = std::fmod(real_of(source_, P, 51) - a1, 360.0);
        if (sweep < 0) sweep += 360.0;
        if (sweep == 0) sweep = 360.0;  // equal angles: AutoCAD draws the full turn
      }
      if (!(r > 0) || std::abs(c.x()) + r > kMaxCoordinateMm || std::abs(c.y()) + r > kMaxCoordinateMm) {
        if (!(r <= kMaxCoordinateMm))
          throw InputError(source_, e.line, fmt::format("{}: radius {:g} is too large", where(k), r));
        problem(ProfileProblem::Severity::warning, "zero_length", {k},
                fmt::format("{} has zero length (radius {:g}); dropped", where(k), r), map_point(m, c, k));
        return;
      }
      if (sweep >= 360.0 - 1e-9) {
        local.v = {c + Vector2d(r, 0), c - Vector2d(r, 0)};
        local.b = {1.0, 1.0};
        local.closed = true;
      } else {
        const double t1 = a1 * kPi / 180, t2 = t1 + sweep * kPi / 180;
        local.v = {c + r * Vector2d(std::cos(t1), std::sin(t1)), c + r * Vector2d(std::cos(t2), std::sin(t2))};
        local.b = {std::tan(sweep * kPi / 180 / 4)};
      }
    } else if (e.type == "LWPOLYLINE") {
      Affine o;
      if (!ocs(k, P, real_of(source_, P, 38), o)) return;
      m = o.then(world);
      long declared = -1;
      for (const auto& p : P) {
        if (p.code == 90) declared = parse_int(source_, p);
        if (p.code == 10) {
          local.v.emplace_back(parse_real(source_, p), 0);
          local.b.push_back(0);
        }
        if ((p.code == 20 || p.code == 42) && local.v.empty())
          throw InputError(source_, p.line, fmt::format("LWPOLYLINE: group code {} before the first vertex (10)", p.code));
        if (p.code == 20) local.v.back().y() = parse_real(source_, p);
        if (p.code == 42) local.b.back() = parse_real(source_, p);
      }
      if (declared >= 0 && static_cast<std::size_t>(declared) != local.v.size())
        throw InputError(source_, e.line, fmt::format("LWPOLYLINE declares {} vertices (group code 90) but lists {}",
                                                      declared, local.v.size()));
      local.closed = (int_of(source_, P, 70) & 1) != 0;
    } else {  // POLYLINE
      const long flags = int_of(source_, P, 70);
      if (flags & (16 | 64)) {
        problem(E, "unsupported_entity", {k},
                fmt::format("{} is a polygon mesh or polyface (flags {}): a surface, not a profile", where(k), flags));
        return;
      }
      const bool three_d = (flags & 8) != 0;
      std::vector<Vector3d> pts;
      for (const auto& V : e.vertices) {
        if (int_of(source_, V, 70) & 16) continue;  // spline frame control point: not on the curve
        pts.emplace_back(real_of(source_, V, 10), real_of(source_, V, 20), real_of(source_, V, 30));
        local.b.push_back(three_d ? 0.0 : real_of(source_, V, 42));
      }
      if (three_d) {
        if (!flat_ok(k, pts)) return;  // world coordinates
        m = world;
      } else {
        Affine o;
        if (!ocs(k, P, real_of(source_, P, 30), o)) return;
        if (std::any_of(pts.begin(), pts.end(), [&](const Vector3d& q) { return std::abs(q.z() - pts.front().z()) > tol_; })) {
          problem(E, "not_planar", {k}, fmt::format("{} has vertices at different z", where(k)));
          return;
        }
        m = o.then(world);
      }
      for (const auto& q : pts) local.v.push_back(q.head<2>());
      local.closed = (flags & 1) != 0;
    }
    for (double bulge : local.b)
      if (!std::isfinite(bulge) || std::abs(bulge) > kMaxBulge)
        throw InputError(source_, e.line, fmt::format("{}: bulge {:g} is out of range", where(k), bulge));
    add(k, map_piece(k, local, m));
  }

  Vector2d map_point(const Affine& m, const Vector2d& p, std::size_t k) const {
    const Vector2d w = m(p);
    if (!w.allFinite() || std::abs(w.x()) > kMaxCoordinateMm || std::abs(w.y()) > kMaxCoordinateMm)
      throw InputError(source_, line_of(k), fmt::format("{}: coordinate {} mm is beyond {:g} mm", where(k), fmt_pt(w), kMaxCoordinateMm));
    return w;
  }

  // Spans the next fit may still append (one more than the limit leaves, so that an exhausted
  // fit is told apart from one that just fits).
  std::size_t fit_budget() const {
    return opt_.max_fitted_spans - std::min(fitted_spans_, opt_.max_fitted_spans) + 1;
  }

  // Keeps the worst deviation, and bounds the work: fitted spans beyond max_fitted_spans mean a
  // drawing whose curves are far too detailed for the tolerance (or absurd).
  void note_fit(const ArcFitResult& r, std::size_t k) {
    max_fit_deviation_ = std::max(max_fit_deviation_, r.max_deviation_mm);
    fitted_spans_ += r.spans;
    if (r.exhausted || fitted_spans_ > opt_.max_fitted_spans)
      throw InputError(source_, line_of(k),
                       fmt::format("{}: the drawing's curves need more than {} arcs at {:g} mm, machplan's limit; "
                                   "a coarser chain tolerance needs fewer: give one",
                                   where(k), opt_.max_fitted_spans, fit_tol_))
          .with_option("chain_tolerance_mm");
  }

  // A local piece (vertices, one bulge per vertex, open or closed) seen through m. Straight
  // spans and, under a similarity, arcs map exactly; other arcs become elliptic and are
  // fitted. The result has n - 1 bulges when open.
  Piece map_piece(std::size_t k, const Piece& local, const Affine& m) {
    Piece out;
    out.closed = local.closed;
    out.entities = {k};
    const std::size_t n = local.v.size();
    if (n == 0) return out;
    const bool similar = m.similarity();
    const double flip = m.A.determinant() < 0 ? -1.0 : 1.0;
    out.v.push_back(map_point(m, local.v[0], k));
    const std::size_t spans = local.closed ? n : n - 1;
    for (std::size_t i = 0; i < spans; ++i) {
      const Vector2d& a = local.v[i];
      const Vector2d& b = local.v[(i + 1) % n];
      const double bulge = local.b[i];
      if (bulge == 0 || similar || (b - a).norm() == 0) {
        out.b.push_back(flip * bulge);
        out.v.push_back(map_point(m, b, k));
        continue;
      }
      const Segment s = make_segment(a, b, bulge);
      for (const Vector2d& q : {Vector2d(s.center + Vector2d(s.radius, s.radius)), Vector2d(s.center - Vector2d(s.radius, s.radius))})
        map_point(m, q, k);
      auto curve = [&](double t) { return m(s.center + s.radius * Vector2d(std::cos(t), std::sin(t))); };
      note_fit(fit_arcs(curve, s.start_angle, s.start_angle + s.sweep, fit_tol_, out.v, out.b, kFitDepth, fit_budget()), k);
      out.v.back() = map_point(m, b, k);
    }
    if (local.closed) out.v.pop_back();  // the last span came back to the first vertex
    return out;
  }

  void insert(std::size_t k, const Entity& e, const Affine& world, int depth, const std::vector<std::string>& open_blocks) {
    const auto& P = e.pairs;
    std::string name;
    for (const auto& p : P)
      if (p.code == 2) name = p.value;
    const auto it = scan_.blocks.find(upper(name));
    if (it == scan_.blocks.end()) {
      problem(ProfileProblem::Severity::error, "missing_block", {k},
              fmt::format("{} places block '{}', which the drawing does not define", where(k), excerpt(name)));
      return;
    }
    const Block& blk = it->second;
    if (blk.external) {
      problem(ProfileProblem::Severity::error, "unsupported_entity", {k},
              fmt::format("{} places block '{}', an external reference to another drawing", where(k), excerpt(name)));
      return;
    }
    if (std::find(open_blocks.begin(), open_blocks.end(), it->first) != open_blocks.end())
      throw InputError(source_, e.line, fmt::format("{}: block '{}' contains itself", where(k), excerpt(name)));
    if (depth >= kMaxInsertDepth)
      throw InputError(source_, e.line, fmt::format("{}: blocks nested deeper than {}", where(k), kMaxInsertDepth));
    const double sx = real_of(source_, P, 41, 1.0), sy = real_of(source_, P, 42, 1.0);
    const double rot = real_of(source_, P, 50) * kPi / 180;
    const long cols = int_of(source_, P, 70, 1), rows = int_of(source_, P, 71, 1);
    const double dc = real_of(source_, P, 44), dr = real_of(source_, P, 45);
    if (sx == 0 || sy == 0) {
      problem(ProfileProblem::Severity::warning, "zero_length", {k}, fmt::format("{} has scale zero; dropped", where(k)));
      return;
    }
    if (cols < 1 || rows < 1 || static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows) > opt_.max_entities)
      throw InputError(source_, e.line,
                       fmt::format("{}: array of {} x {} copies is not between 1 and {}, the limit on entities: raise it",
                                   where(k), cols, rows, opt_.max_entities))
          .with_option("max_entities");
    Affine o;
    if (!ocs(k, P, real_of(source_, P, 30), o)) return;
    const Vector2d ins(real_of(source_, P, 10), real_of(source_, P, 20));
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(rot).toRotationMatrix();
    std::vector<std::string> inner = open_blocks;
    inner.push_back(it->first);
    for (long r = 0; r < rows; ++r)
      for (long c = 0; c < cols; ++c) {
        Affine place;  // block coordinates -> the INSERT's OCS
        place.A = R * Eigen::DiagonalMatrix<double, 2>(sx, sy);
        place.b = ins + R * Vector2d(static_cast<double>(c) * dc, static_cast<double>(r) * dr) - place.A * blk.base;
        const Affine m = place.then(o).then(world);
        const std::string prefix = cols * rows > 1 ? fmt::format("{}[{},{}]>", label(k), c, r) : label(k) + ">";
        for (const Entity& sub : blk.entities) {
          if (sub.type == "ATTDEF") continue;  // attribute templates carry no geometry
          entity(sub, prefix + sub.handle, sub.layer == "0" ? instances_[k].layer : sub.layer, m, depth + 1, inner);
        }
      }
  }

  void spline(std::size_t k, const Entity& e, const Affine& world) {
    const auto& P = e.pairs;
    const long flags = int_of(source_, P, 70);
    Nurbs nurbs;
    nurbs.degree = static_cast<int>(int_of(source_, P, 71, 3));
    const std::vector<Vector3d> ctrl = points_of(source_, P, 10, "SPLINE");
    const std::vector<Vector3d> fit = points_of(source_, P, 11, "SPLINE");
    for (const auto& p : P) {
      if (p.code == 40) nurbs.knots.push_back(parse_real(source_, p));
      if (p.code == 41) nurbs.weights.push_back(parse_real(source_, p));
    }
    const long nk = int_of(source_, P, 72, -1), nc = int_of(source_, P, 73, -1), nf = int_of(source_, P, 74, -1);
    if ((nk >= 0 && static_cast<std::size_t>(nk) != nurbs.knots.size()) ||
        (nc >= 0 && static_cast<std::size_t>(nc) != ctrl.size()) || (nf >= 0 && static_cast<std::size_t>(nf) != fit.size()))
      throw InputError(source_, e.line,
                       fmt::format("SPLINE declares {} knots, {} control and {} fit points (codes 72-74) but lists {}, {} "
                                   "and {}",
                                   nk, nc, nf, nurbs.knots.size(), ctrl.size(), fit.size()));
    if (!flat_ok(k, ctrl.empty() ? fit : ctrl)) return;
    if (flags & 4) {
      if (nurbs.weights.size() != ctrl.size()) nurbs.weights.resize(ctrl.size(), 1.0);
    } else if (!nurbs.weights.empty() && nurbs.weights.size() != ctrl.size()) {
      nurbs.weights.clear();  // weights of a non-rational spline are all 1 whatever is written
    }
    Piece pc;
    pc.entities = {k};
    if (!ctrl.empty()) {
      for (const auto& q : ctrl) nurbs.control.push_back(map_point(world, q.head<2>(), k));
      try {
        nurbs.validate();
      } catch (const InputError& ex) {
        throw InputError(source_, e.line, fmt::format("{}: {}", where(k), ex.what()));
      }
      const std::vector<double> br = nurbs.breaks();
      pc.v.push_back(nurbs.point(br.front(), nurbs.span_of(br.front())));
      for (std::size_t i = 0; i + 1 < br.size(); ++i) {
        const std::size_t span = nurbs.span_of(0.5 * (br[i] + br[i + 1]));
        note_fit(fit_arcs([&](double t) { return nurbs.point(t, span); }, br[i], br[i + 1], fit_tol_, pc.v, pc.b, kFitDepth, fit_budget()), k);
      }
    } else {
      std::vector<Vector2d> pts;
      for (const auto& q : fit) {
        const Vector2d w = map_point(world, q.head<2>(), k);
        if (pts.empty() || (w - pts.back()).norm() > 1e-12) pts.push_back(w);
      }
      if (pts.size() < 2) {
        problem(ProfileProblem::Severity::warning, "zero_length", {k},
                fmt::format("{} has neither control points nor two distinct fit points; dropped", where(k)));
        return;
      }
      auto tangent = [&](int code) {
        const Vector2d t(real_of(source_, P, code), real_of(source_, P, code + 10));
        return Vector2d(world.A * t);
      };
      CubicInterpolant ci;
      try {
        ci = interpolate_cubic(pts, tangent(12), tangent(13));
      } catch (const InputError& ex) {
        throw InputError(source_, e.line, fmt::format("{}: {}", where(k), ex.what()));
      }
      pc.v.push_back(pts.front());
      for (std::size_t i = 0; i + 1 < pts.size(); ++i)
        note_fit(fit_arcs([&](double t) { return ci.point(t, i); }, ci.params[i], ci.params[i + 1], fit_tol_, pc.v, pc.b, kFitDepth, fit_budget()), k);
    }
    add(k, std::move(pc));
  }

  void ellipse(std::size_t k, const Entity& e, const Affine& world) {
    const auto& P = e.pairs;
    Vector3d n(real_of(source_, P, 210, 0.0), real_of(source_, P, 220, 0.0), real_of(source_, P, 230, 1.0));
    if (!(n.norm() > 0)) {
      problem(ProfileProblem::Severity::error, "not_planar", {k}, fmt::format("{} has a zero extrusion direction", where(k)));
      return;
    }
    n.normalize();
    if (!tilt_ok(k, std::atan2(n.head<2>().norm(), std::abs(n.z())))) return;
    const Vector3d c(real_of(source_, P, 10), real_of(source_, P, 20), real_of(source_, P, 30));
    const Vector3d major(real_of(source_, P, 11), real_of(source_, P, 21), real_of(source_, P, 31));
    // The ratio is minor over major; some writers give the longer axis as the "minor" one (a
    // ratio above 1). The curve c + cos t major + sin t minor is the same ellipse either way.
    const double ratio = real_of(source_, P, 40, 1.0);
    if (!(ratio > 0) || !(ratio <= 1e6) || !(major.norm() > 0)) {
      problem(ProfileProblem::Severity::warning, "zero_length", {k},
              fmt::format("{} has axis ratio {:g} and major axis {:g}; dropped", where(k), ratio, major.norm()));
      return;
    }
    const Vector3d minor = ratio * n.cross(major);
    for (const Vector2d& q : {Vector2d(c.head<2>() + minor.head<2>()), Vector2d(c.head<2>() - minor.head<2>())})
      map_point(world, q, k);
    double t0 = real_of(source_, P, 41, 0.0), t1 = real_of(source_, P, 42, 2 * kPi);
    double sweep = std::fmod(t1 - t0, 2 * kPi);
    if (sweep < 0) sweep += 2 * kPi;
    if (sweep < 1e-12) sweep = 2 * kPi;
    const bool full = sweep > 2 * kPi - 1e-9;
    for (const Vector2d& q : {Vector2d(c.head<2>() + major.head<2>()), Vector2d(c.head<2>() - major.head<2>())})
      map_point(world, q, k);
    auto curve = [&](double t) {
      return world(Vector2d(c.head<2>() + std::cos(t) * major.head<2>() + std::sin(t) * minor.head<2>()));
    };
    Piece pc;
    pc.entities = {k};
    pc.v.push_back(curve(t0));
    // Quarters at most per fit, so that no piece starts and ends at one point.
    const int parts = std::max(1, static_cast<int>(std::ceil(sweep / (kPi / 2) - 1e-9)));
    for (int i = 0; i < parts; ++i)
      note_fit(fit_arcs(curve, t0 + sweep * i / parts, t0 + sweep * (i + 1) / parts, fit_tol_, pc.v, pc.b, kFitDepth, fit_budget()), k);
    if (full && pc.v.size() >= 3) {
      pc.v.pop_back();
      pc.closed = true;
    }
    add(k, std::move(pc));
  }

  // Cleans a piece in mm (spans shorter than the tolerance merged away, a repeated first
  // vertex closing it) and keeps it, or reports why not.
  void add(std::size_t k, Piece pc) {
    const auto W = ProfileProblem::Severity::warning;
    const std::size_t n = pc.v.size();
    if (n == 0) return;
    const std::size_t spans = pc.closed ? n : n - 1;
    Piece c;
    c.closed = pc.closed;
    c.entities = std::move(pc.entities);
    c.v.push_back(pc.v[0]);
    int dropped = 0;
    for (std::size_t i = 0; i < spans; ++i) {
      const Vector2d& e = pc.v[(i + 1) % n];
      const bool near = (e - c.v.back()).norm() <= tol_;
      if (pc.closed && i + 1 == spans) {  // the span back to the first vertex
        if (near && c.v.size() > 1) {
          c.v.pop_back();  // the previous span now ends at the first vertex
          ++dropped;
        } else {
          c.b.push_back(pc.b[i]);
        }
        break;
      }
      if (near) {
        ++dropped;
        continue;  // zero-length span: keep the earlier vertex and its bulge
      }
      c.b.push_back(pc.b[i]);
      c.v.push_back(e);
    }
    if (!c.closed && c.v.size() >= 3 && (c.v.back() - c.v.front()).norm() <= tol_) {
      // The last vertex repeats the first: closed whatever its flag says.
      c.v.pop_back();
      c.closed = true;
      ++dropped;
    }
    const std::string& type = instances_[k].entity->type;
    if (dropped > 0 && c.v.size() >= 2 && (type == "LWPOLYLINE" || type == "POLYLINE"))
      problem(W, "zero_length", {k}, fmt::format("{} has {} span(s) shorter than {:g} mm; dropped", where(k), dropped, tol_));
    if (c.v.size() < 2 || c.length() <= tol_) {
      problem(W, "zero_length", {k}, fmt::format("{} has zero length; dropped", where(k)), c.v.front());
      return;
    }
    pieces_.push_back(std::move(c));
  }

 public:
  // Pieces with the same geometry, either direction, within the tolerance.
  bool same(const Piece& a, const Piece& b) const {
    if (a.closed != b.closed || a.v.size() != b.v.size()) return false;
    const std::size_t n = a.v.size();
    for (int dir : {1, -1}) {
      for (std::size_t k = 0; k < (a.closed ? n : 1); ++k) {
        bool ok = true;
        for (std::size_t i = 0; i < n && ok; ++i) {
          const std::size_t j = dir == 1 ? (k + i) % n : (a.closed ? (k + n - i) % n : n - 1 - i);
          ok = (a.v[i] - b.v[j]).norm() <= tol_;
        }
        for (std::size_t i = 0; i < a.b.size() && ok; ++i) {
          const double bj = dir == 1 ? b.b[(k + i) % b.b.size()]
                                     : -b.b[a.closed ? (k + 2 * n - i - 1) % n : b.b.size() - 1 - i];
          ok = std::abs(a.b[i] - bj) <= 1e-6 * (1 + std::abs(bj));
        }
        if (ok) return true;
      }
    }
    return false;
  }

  void drop_duplicates() {
    std::vector<std::size_t> order(pieces_.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    auto minx = [&](std::size_t i) {
      double m = pieces_[i].v.front().x();
      for (const auto& p : pieces_[i].v) m = std::min(m, p.x());
      return m;
    };
    std::vector<double> key(pieces_.size());
    for (std::size_t i = 0; i < key.size(); ++i) key[i] = minx(i);
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return key[a] < key[b] || (key[a] == key[b] && a < b); });
    std::vector<bool> gone(pieces_.size(), false);
    for (std::size_t x = 0; x < order.size(); ++x) {
      if (gone[order[x]]) continue;
      for (std::size_t y = x + 1; y < order.size() && key[order[y]] - key[order[x]] <= tol_; ++y) {
        const std::size_t a = std::min(order[x], order[y]), b = std::max(order[x], order[y]);
        if (gone[b] || gone[a] || !same(pieces_[a], pieces_[b])) continue;
        gone[b] = true;  // keep the one earlier in the file
        problem(ProfileProblem::Severity::warning, "duplicate", {pieces_[a].entities[0], pieces_[b].entities[0]},
                fmt::format("{} repeats {}; the copy is dropped", where(pieces_[b].entities[0]), where(pieces_[a].entities[0])),
                pieces_[b].v.front());
      }
    }
    std::vector<Piece> kept;
    for (std::size_t i = 0; i < pieces_.size(); ++i)
      if (!gone[i]) kept.push_back(std::move(pieces_[i]));
    pieces_ = std::move(kept);
  }

  // Overlapping collinear lines and concentric arcs (single spans, open): a span lying within
  // another is dropped, a line overlapping another line's end is cut back to the part the other
  // does not cover. Pairs are found by their boxes (sweep and prune), in file order.
  void merge_collinear_overlaps() {
    const auto single = [&](const Piece& p) { return !p.closed && p.v.size() == 2; };
    std::vector<Eigen::AlignedBox2d> boxes(pieces_.size());
    for (std::size_t i = 0; i < pieces_.size(); ++i)
      if (single(pieces_[i])) {
        boxes[i] = bounding_box(make_segment(pieces_[i].v[0], pieces_[i].v[1], pieces_[i].b[0]));
        boxes[i].min().array() -= tol_;
        boxes[i].max().array() += tol_;
      }
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) { pairs.emplace_back(std::min(a, b), std::max(a, b)); });
    std::sort(pairs.begin(), pairs.end());
    std::vector<bool> gone(pieces_.size(), false);
    for (const auto& [a, b] : pairs) {
      if (gone[a] || gone[b]) continue;
      const bool arcs = pieces_[a].b[0] != 0.0 && pieces_[b].b[0] != 0.0;
      if (arcs) merge_arcs(a, b, gone);
      else if (pieces_[a].b[0] == 0.0 && pieces_[b].b[0] == 0.0) merge_lines(a, b, gone);
    }
    std::vector<Piece> kept;
    for (std::size_t i = 0; i < pieces_.size(); ++i)
      if (!gone[i]) kept.push_back(std::move(pieces_[i]));
    pieces_ = std::move(kept);
  }

  void note_merged(std::size_t dropped, std::size_t other, const std::string& what) {
    problem(ProfileProblem::Severity::warning, "merged_overlap", {pieces_[other].entities[0], pieces_[dropped].entities[0]},
            fmt::format("{} lies along {} over its whole length{}; it is dropped", where(pieces_[dropped].entities[0]),
                        where(pieces_[other].entities[0]), what),
            pieces_[dropped].v[0]);
  }

  // Two lines, the earlier `a`: see merge_collinear_overlaps.
  void merge_lines(std::size_t a, std::size_t b, std::vector<bool>& gone) {
    const Piece& keep = pieces_[a];
    Piece& later = pieces_[b];
    const Vector2d p0 = keep.v[0], d = keep.v[1] - keep.v[0];
    const double len = d.norm();
    if (!(len > tol_)) return;
    const Vector2d u = d / len;
    // Both ends of the later line on the earlier one's line, within the tolerance.
    const auto off = [&](const Vector2d& q) { return std::abs(cross(u, q - p0)); };
    if (off(later.v[0]) > tol_ || off(later.v[1]) > tol_) return;
    const double t0 = u.dot(later.v[0] - p0), t1 = u.dot(later.v[1] - p0);
    const double lo = std::min(t0, t1), hi = std::max(t0, t1);
    if (hi - tol_ <= 0.0 || lo + tol_ >= len) return;  // they meet at most at an end
    if (lo >= -tol_ && hi <= len + tol_) {
      gone[b] = true;
      note_merged(b, a, "");
      return;
    }
    if (lo < -tol_ && hi > len + tol_) {  // the earlier lies within the later
      gone[a] = true;
      note_merged(a, b, "");
      return;
    }
    // Cut the later line back to the part beyond the earlier one's end it overlaps.
    const bool beyond_end = hi > len + tol_;
    const Vector2d cut = beyond_end ? keep.v[1] : keep.v[0];
    const bool first_inside = beyond_end ? (t0 < t1) : (t0 > t1);  // the later line's start lies on the earlier
    (first_inside ? later.v[0] : later.v[1]) = cut;
    problem(ProfileProblem::Severity::warning, "merged_overlap", {keep.entities[0], later.entities[0]},
            fmt::format("{} overlaps {} by {:.4f} mm; the later line is cut back to {}", where(later.entities[0]),
                        where(keep.entities[0]), beyond_end ? len - lo : hi, fmt_pt(cut)),
            cut);
  }

  // Two arcs, the earlier `a`: one lying on the other's circle within its range is dropped.
  void merge_arcs(std::size_t a, std::size_t b, std::vector<bool>& gone) {
    const Segment sa = make_segment(pieces_[a].v[0], pieces_[a].v[1], pieces_[a].b[0]);
    const Segment sb = make_segment(pieces_[b].v[0], pieces_[b].v[1], pieces_[b].b[0]);
    if (!sa.is_arc() || !sb.is_arc() || (sa.center - sb.center).norm() > tol_ || std::abs(sa.radius - sb.radius) > tol_) return;
    const auto within = [&](const Segment& inner, const Segment& outer) {
      for (double t : {0.0, 0.5, 1.0}) {
        const Vector2d q = point_at(inner, t);
        if ((closest_point(outer, q) - q).norm() > tol_) return false;
      }
      return true;
    };
    if (within(sb, sa)) {
      gone[b] = true;
      note_merged(b, a, " (the same circle)");
    } else if (within(sa, sb)) {
      gone[a] = true;
      note_merged(a, b, " (the same circle)");
    }
  }

  // Closed chains that trace the same outline (every vertex and span middle of each within
  // the tolerance of the other, whatever their split into spans): the later is dropped.
  void drop_coincident_closed() {
    std::vector<Eigen::AlignedBox2d> boxes;
    std::vector<std::optional<Contour>> cs;
    for (const Piece& pc : closed_) {
      std::optional<Contour> c;
      try {
        c = Contour(pc.v, pc.b);
      } catch (const InputError&) {  // no contour (a degenerate chain): nothing to compare it with
      }
      boxes.push_back(c ? bounding_box(*c) : Eigen::AlignedBox2d());
      cs.push_back(std::move(c));
    }
    const auto on = [&](const Contour& a, const Contour& b) {
      for (std::size_t i = 0; i < a.size(); ++i)
        if (distance(b, a.vertices()[i]) > tol_ || distance(b, point_at(a.span(i), 0.5)) > tol_) return false;
      return true;
    };
    std::vector<bool> gone(closed_.size(), false);
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for_each_intersecting_pair(boxes, [&](std::size_t a, std::size_t b) { pairs.emplace_back(std::min(a, b), std::max(a, b)); });
    std::sort(pairs.begin(), pairs.end());
    for (const auto& [a, b] : pairs) {
      if (gone[a] || gone[b] || !cs[a] || !cs[b]) continue;
      if ((boxes[a].min() - boxes[b].min()).cwiseAbs().maxCoeff() > tol_ ||
          (boxes[a].max() - boxes[b].max()).cwiseAbs().maxCoeff() > tol_)
        continue;
      if (!on(*cs[a], *cs[b]) || !on(*cs[b], *cs[a])) continue;
      gone[b] = true;
      problem(ProfileProblem::Severity::warning, "duplicate", {closed_[a].entities.front(), closed_[b].entities.front()},
              fmt::format("the outline of {} ({} entities) repeats the one of {}: drawn twice; the copy is dropped",
                          where(closed_[b].entities.front()), closed_[b].entities.size(), where(closed_[a].entities.front())),
              closed_[b].v.front());
    }
    std::vector<Piece> kept;
    for (std::size_t i = 0; i < closed_.size(); ++i)
      if (!gone[i]) kept.push_back(std::move(closed_[i]));
    closed_ = std::move(kept);
  }

  // Joins `next` onto the end of `chain` (next.front() is at chain.back()).
  static void append(Piece& chain, const Piece& next) {
    chain.v.insert(chain.v.end(), next.v.begin() + 1, next.v.end());
    chain.b.insert(chain.b.end(), next.b.begin(), next.b.end());
    chain.entities.insert(chain.entities.end(), next.entities.begin(), next.entities.end());
  }

  // The free ends of the open pieces in a grid of square cells at least the tolerance wide,
  // so that every end within the tolerance of a point lies in its cell or the eight around
  // it: finding the next piece of a chain costs a few lookups, not a pass over the drawing.
  class EndGrid {
   public:
    EndGrid(const std::vector<Piece>& pieces, double tol) : pieces_(pieces) {
      double extent = 0;
      for (const auto& p : pieces)
        if (!p.closed) extent = std::max({extent, p.front().cwiseAbs().maxCoeff(), p.back().cwiseAbs().maxCoeff()});
      cell_ = std::max(tol, extent / (1 << 28));  // keeps cell indices well inside 32 bits
      for (std::size_t j = 0; j < pieces.size(); ++j) {
        if (pieces[j].closed) continue;
        cells_[key(pieces[j].front())].push_back(2 * j);
        cells_[key(pieces[j].back())].push_back(2 * j + 1);
      }
    }
    // Nearest end within `radius` (<= the tolerance) of p among unused pieces: (piece,
    // at_end, distance); piece = size() when none. Ties go to the lower piece, then its start.
    std::tuple<std::size_t, bool, double> nearest(const Vector2d& p, double radius, const std::vector<bool>& used) const {
      std::tuple<std::size_t, bool, double> best{pieces_.size(), false, std::numeric_limits<double>::infinity()};
      const auto cx = static_cast<std::int64_t>(std::floor(p.x() / cell_)), cy = static_cast<std::int64_t>(std::floor(p.y() / cell_));
      for (std::int64_t dx = -1; dx <= 1; ++dx)
        for (std::int64_t dy = -1; dy <= 1; ++dy) {
          const auto it = cells_.find(pack(cx + dx, cy + dy));
          if (it == cells_.end()) continue;
          for (const std::size_t id : it->second) {
            const std::size_t j = id / 2;
            if (used[j]) continue;
            const bool at_end = id % 2 == 1;
            const double d = ((at_end ? pieces_[j].back() : pieces_[j].front()) - p).norm();
            if (d > radius) continue;
            const auto [bj, bend, bd] = best;
            if (d < bd || (d == bd && (j < bj || (j == bj && !at_end && bend)))) best = {j, at_end, d};
          }
        }
      return best;
    }

   private:
    static std::uint64_t pack(std::int64_t x, std::int64_t y) {
      return (static_cast<std::uint64_t>(x) << 32) ^ (static_cast<std::uint64_t>(y) & 0xffffffffu);
    }
    std::uint64_t key(const Vector2d& p) const {
      return pack(static_cast<std::int64_t>(std::floor(p.x() / cell_)), static_cast<std::int64_t>(std::floor(p.y() / cell_)));
    }
    const std::vector<Piece>& pieces_;
    double cell_ = 1;
    std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells_;
  };

  // A join the healing pass made: the two entities it joined and the gap it closed.
  struct Join {
    std::size_t from = 0, to = 0;  // instances: the end of one chain, the start of the next
    double gap = 0.0;
    Vector2d at = Vector2d::Zero();
  };

  // One chaining pass over `pieces` at tolerance `tol` (see the header): closed chains go to
  // closed_, open ones are returned. When `joins` is given, every gap wider than the chain
  // tolerance that the pass closes is recorded.
  std::vector<Piece> chain_pass(const std::vector<Piece>& pieces, double tol, std::vector<Join>* joins) {
    std::vector<bool> used(pieces.size(), false);
    const EndGrid grid(pieces, tol);
    std::vector<Piece> open;
    const auto note = [&](const Piece& c, const Piece& n, double gap) {
      if (joins && gap > tol_) joins->push_back({c.entities.back(), n.entities.front(), gap, c.back()});
    };
    for (std::size_t i = 0; i < pieces.size(); ++i) {
      if (used[i]) continue;
      used[i] = true;
      Piece c = pieces[i];
      if (c.closed) {
        closed_.push_back(std::move(c));
        continue;
      }
      bool closed = false;
      for (int pass = 0; pass < 2 && !closed; ++pass) {  // forward from the end, then from the start
        while (true) {
          const double to_start = (c.back() - c.front()).norm();
          auto [j, at_end, d] = grid.nearest(c.back(), tol, used);
          if (to_start <= tol && to_start <= d && c.b.size() >= 2) {  // one span cannot close
            closed = true;
            note(c, c, to_start);
            if (pass == 1) c.reverse();  // back to the first entity's direction
            break;
          }
          if (j == pieces.size()) break;
          used[j] = true;
          Piece n = pieces[j];
          if (at_end) n.reverse();
          note(c, n, d);
          append(c, n);
        }
        if (!closed && pass == 0) c.reverse();
      }
      if (closed) {
        c.v.pop_back();  // the last point is the first again
        c.closed = true;
        closed_.push_back(std::move(c));
        continue;
      }
      c.reverse();  // back to the drawn direction of the first entity where possible
      open.push_back(std::move(c));
    }
    return open;
  }

  // Chaining at the chain tolerance, then healing: the chains still open are chained again at
  // the join tolerance, and each join it makes is reported. What stays open is reported.
  void chain() {
    std::vector<Piece> open = chain_pass(pieces_, tol_, nullptr);
    if (!open.empty() && opt_.join_tolerance_mm > tol_) {
      std::vector<Join> joins;
      open = chain_pass(open, opt_.join_tolerance_mm, &joins);
      for (const Join& j : joins)
        problem(ProfileProblem::Severity::warning, "joined", {j.from, j.to},
                fmt::format("{} joined to {} across a gap of {:.4f} mm at {} (join tolerance {:g} mm)", where(j.from),
                            j.from == j.to ? std::string("itself") : where(j.to), j.gap, fmt_pt(j.at),
                            opt_.join_tolerance_mm),
                j.at);
      for (std::size_t k = 0; k < joins.size(); ++k)
        out_.problems[out_.problems.size() - joins.size() + k].gap_mm = joins[k].gap;
    }
    report_open(open);
  }

  // Each open chain with the gap between its own ends (how far it is from closing) and the
  // distance to the nearest end of another open chain. Ends sorted by x; the search around
  // each stops once the x distance alone exceeds the best found.
  void report_open(const std::vector<Piece>& open) {
    struct End { double x, y; std::size_t chain; };
    std::vector<End> ends;
    for (std::size_t i = 0; i < open.size(); ++i)
      for (const Vector2d& p : {open[i].front(), open[i].back()}) ends.push_back({p.x(), p.y(), i});
    std::sort(ends.begin(), ends.end(), [](const End& a, const End& b) { return a.x < b.x || (a.x == b.x && a.chain < b.chain); });
    std::vector<double> nearest(open.size(), std::numeric_limits<double>::infinity());
    for (std::size_t a = 0; a < ends.size(); ++a) {
      double best = nearest[ends[a].chain];
      auto try_end = [&](std::size_t b) {
        if (ends[b].chain != ends[a].chain) best = std::min(best, std::hypot(ends[b].x - ends[a].x, ends[b].y - ends[a].y));
      };
      for (std::size_t b = a + 1; b < ends.size() && ends[b].x - ends[a].x < best; ++b) try_end(b);
      for (std::size_t b = a; b-- > 0 && ends[a].x - ends[b].x < best;) try_end(b);
      nearest[ends[a].chain] = best;
    }
    const bool heal = opt_.join_tolerance_mm > tol_;
    for (std::size_t i = 0; i < open.size(); ++i) {
      const Piece& c = open[i];
      const double gap = (c.back() - c.front()).norm();
      const std::string near =
          std::isfinite(nearest[i]) ? fmt::format("; nearest end of another open chain is {:.4f} mm away", nearest[i]) : "";
      problem(ProfileProblem::Severity::error, "open_chain", c.entities,
              fmt::format("open chain of {} entit{} starting at {}: its ends {} and {} are {:.4f} mm apart, more than "
                          "the {} {:g} mm{}",
                          c.entities.size(), c.entities.size() == 1 ? "y" : "ies", where(c.entities.front()),
                          fmt_pt(c.front()), fmt_pt(c.back()), gap, heal ? "join tolerance" : "tolerance",
                          heal ? opt_.join_tolerance_mm : tol_, near),
              c.back());
      out_.problems.back().gap_mm = gap;
    }
  }

  void finish() {
    const auto E = ProfileProblem::Severity::error;
    for (auto& pc : closed_) {
      ProfileContour pcn;
      try {
        pcn.contour = Contour(pc.v, pc.b);
      } catch (const InputError& e) {
        throw InputError(source_, line_of(pc.entities.front()), fmt::format("{}: {}", where(pc.entities.front()), e.what()));
      }
      pcn.area_mm2 = signed_area(pcn.contour);
      pcn.perimeter_mm = perimeter(pcn.contour);
      for (auto e : pc.entities) pcn.handles.push_back(label(e));
      pcn.layer = instances_[pc.entities.front()].layer;
      const std::size_t ci = out_.contours.size();
      if (std::abs(pcn.area_mm2) <= tol_ * tol_)
        problem(E, "zero_area", pc.entities,
                fmt::format("contour {} starting at {} encloses no area", ci, where(pc.entities.front())), pc.v.front());
      const auto hits = self_intersections(pcn.contour, 0.1 * tol_);
      if (!hits.empty())
        problem(E, "self_intersection", pc.entities,
                fmt::format("contour {} starting at {} crosses itself at {}{}", ci, where(pc.entities.front()),
                            fmt_pt(hits.front().point), hits.size() > 1 ? fmt::format(" and {} more place(s)", hits.size() - 1) : ""),
                hits.front().point);
      out_.contours.push_back(std::move(pcn));
      contour_entities_.push_back(pc.entities);
    }
    // Pairs of contours whose (grown) boxes meet: they may cross, touch or nest. Any other
    // pair is disjoint, so neither check nor nesting needs it.
    auto& cs = out_.contours;
    std::vector<Eigen::AlignedBox2d> boxes, grown;
    for (const auto& c : cs) {
      boxes.push_back(bounding_box(c.contour));
      grown.emplace_back(boxes.back().min() - Vector2d::Constant(tol_), boxes.back().max() + Vector2d::Constant(tol_));
    }
    std::vector<double> parent_area(cs.size(), std::numeric_limits<double>::infinity());
    struct Crossing { std::size_t a, b; std::vector<Vector2d> points; };
    std::vector<Crossing> crossings;
    for_each_intersecting_pair(grown, [&](std::size_t a, std::size_t b) {
      if (a > b) std::swap(a, b);
      auto pts = contour_intersections(cs[a].contour, cs[b].contour, 0.1 * tol_);
      if (!pts.empty()) {
        crossings.push_back({a, b, std::move(pts)});
        return;
      }
      // Nesting: the smallest contour that holds the other's first vertex is its parent.
      const double aa = std::abs(cs[a].area_mm2), ab = std::abs(cs[b].area_mm2);
      if (aa == ab) return;
      const std::size_t outer = aa > ab ? a : b, inner = aa > ab ? b : a;
      const double ao = std::max(aa, ab);
      if (ao >= parent_area[inner] || !boxes[outer].contains(boxes[inner])) return;
      if (contains(cs[outer].contour, cs[inner].contour.vertices().front())) {
        parent_area[inner] = ao;
        cs[inner].parent = static_cast<int>(outer);
      }
    });
    std::sort(crossings.begin(), crossings.end(), [](const Crossing& x, const Crossing& y) {
      return x.a < y.a || (x.a == y.a && x.b < y.b);
    });
    for (const auto& [a, b, pts] : crossings) {
      problem(E, "overlap", {},
              fmt::format("contours {} and {} cross or touch at {}{}", a, b, fmt_pt(pts.front()),
                          pts.size() > 1 ? fmt::format(" and {} more place(s)", pts.size() - 1) : ""),
              pts.front());
      auto& h = out_.problems.back().handles;
      for (auto e : contour_entities_[a]) h.push_back(label(e));
      for (auto e : contour_entities_[b]) h.push_back(label(e));
    }
    for (std::size_t i = 0; i < cs.size(); ++i) {
      if (cs[i].parent >= 0) cs[static_cast<std::size_t>(cs[i].parent)].children.push_back(static_cast<int>(i));
      int depth = 0;
      for (int p = cs[i].parent; p >= 0 && depth <= static_cast<int>(cs.size()); p = cs[static_cast<std::size_t>(p)].parent) ++depth;
      cs[i].depth = depth;
    }
    for (auto& c : cs) std::sort(c.children.begin(), c.children.end());
    if (cs.empty()) problem(E, "no_contours", {}, "the drawing holds no closed contour");
  }

  std::vector<Piece> pieces_;

 private:
  const std::string& source_;
  const Scan& scan_;
  const DxfOptions& opt_;
  double tol_, fit_tol_, tan_flat_;
  ProfileReadResult& out_;
  std::vector<Instance> instances_;
  std::vector<Piece> closed_;
  std::vector<std::vector<std::size_t>> contour_entities_;
  std::size_t tilted_ = 0;
  double max_tilt_deg_ = 0.0;
  double max_fit_deviation_ = 0.0;
  std::size_t fitted_spans_ = 0;
};

}  // namespace

void DxfOptions::validate() const {
  if (!std::isfinite(chain_tolerance_mm) || !(chain_tolerance_mm > 0.0) || chain_tolerance_mm > 10.0)
    throw InputError::field("chain_tolerance_mm", fmt::format("is {}, must be finite, > 0 and <= 10 mm", chain_tolerance_mm));
  if (!std::isfinite(join_tolerance_mm) || join_tolerance_mm < 0.0 || join_tolerance_mm > 10.0)
    throw InputError::field("join_tolerance_mm", fmt::format("is {}, must be finite, >= 0 and <= 10 mm", join_tolerance_mm));
  if (!std::isfinite(assumed_mm_per_unit) || assumed_mm_per_unit < 0.0 || assumed_mm_per_unit > 1e4)
    throw InputError::field("assumed_mm_per_unit",
                            fmt::format("is {}, must be 0 (not given) or a positive scale up to 1e4 mm", assumed_mm_per_unit));
  if (max_entities < 1 || max_entities > 10'000'000)
    throw InputError::field("max_entities", fmt::format("is {}, must lie in 1 .. 10 000 000", max_entities));
  if (max_fitted_spans < 1 || max_fitted_spans > 10'000'000)
    throw InputError::field("max_fitted_spans", fmt::format("is {}, must lie in 1 .. 10 000 000", max_fitted_spans));
  if (!std::isfinite(flatten_tolerance_deg) || flatten_tolerance_deg < 0.0 || flatten_tolerance_deg > 5.0)
    throw InputError::field("flatten_tolerance_deg",
                            fmt::format("is {}, must be finite, >= 0 and <= 5 degrees", flatten_tolerance_deg));
}

double mm_per_drawing_unit(std::string_view name) {
  static const std::map<std::string, double, std::less<>> units = {
      {"mm", 1.0},      {"millimeter", 1.0}, {"millimetre", 1.0}, {"cm", 10.0},      {"m", 1000.0},
      {"dm", 100.0},    {"inch", 25.4},      {"in", 25.4},        {"inches", 25.4},  {"foot", 304.8},
      {"ft", 304.8},    {"feet", 304.8},     {"yard", 914.4},     {"yd", 914.4},     {"mil", 0.0254},
      {"micron", 1e-3}, {"um", 1e-3},        {"microinch", 25.4e-6}};
  const auto it = units.find(name);
  return it == units.end() ? 0.0 : it->second;
}

const char* to_string(ProfileProblem::Severity s) {
  return s == ProfileProblem::Severity::error ? "error" : "warning";
}

bool ProfileReadResult::has_errors() const {
  return std::any_of(problems.begin(), problems.end(),
                     [](const ProfileProblem& p) { return p.severity == ProfileProblem::Severity::error; });
}

std::string ProfileReadResult::report() const {
  std::string s = fmt::format("{}: {} contour(s), units mm", source, contours.size());
  if (mm_per_unit != 1.0) s += fmt::format(" (drawing units scaled by {:g})", mm_per_unit);
  s += fmt::format("; ends joined within {:g} mm, gaps healed up to {:g} mm", chain_tolerance_mm, join_tolerance_mm);
  s += "\n";
  for (std::size_t i = 0; i < contours.size(); ++i) {
    const auto& c = contours[i];
    const auto box = bounding_box(c.contour);
    s += fmt::format("contour {}: {} ({}), {} vertices, area {:.4f} mm2, {}, perimeter {:.4f} mm\n", i,
                     c.depth % 2 == 0 ? "outer" : "hole", c.depth, c.contour.size(), std::abs(c.area_mm2),
                     to_string(orientation(c.contour)), c.perimeter_mm);
    s += fmt::format("  bbox ({:.4f}, {:.4f}) - ({:.4f}, {:.4f}) mm, layer {}\n", box.min().x(), box.min().y(),
                     box.max().x(), box.max().y(), c.layer);
    if (c.parent >= 0) s += fmt::format("  inside contour {}\n", c.parent);
    if (!c.children.empty()) s += fmt::format("  holds contour(s) {}\n", fmt::join(c.children, ", "));
    s += fmt::format("  entities {}\n", fmt::join(c.handles, " "));
    for (std::size_t k = 0; k < c.contour.size(); ++k)
      s += fmt::format("    {:12.4f} {:12.4f}  bulge {:.6g}\n", c.contour.vertices()[k].x(), c.contour.vertices()[k].y(),
                       c.contour.bulges()[k]);
  }
  for (const auto& p : problems) {
    s += fmt::format("{} {}: {}", to_string(p.severity), p.kind, p.message);
    if (!p.handles.empty()) s += fmt::format(" [{}]", fmt::join(p.handles, " "));
    s += "\n";
  }
  return s;
}

ProfileReadResult read_dxf_profile_text(std::string_view text, const std::string& source, const DxfOptions& options) {
  options.validate();
  const Scan sc = scan(text, source);
  ProfileReadResult out;
  out.source = source;
  out.chain_tolerance_mm = options.chain_tolerance_mm;
  out.join_tolerance_mm = options.join_tolerance_mm;
  out.has_insunits = sc.mm_per_unit > 0;
  out.mm_per_unit = out.has_insunits ? sc.mm_per_unit : options.assumed_mm_per_unit > 0 ? options.assumed_mm_per_unit : 1.0;
  Assembler as(source, sc, options, out);
  if (!out.has_insunits)
    out.problems.push_back({ProfileProblem::Severity::warning, "no_units", {},
                            options.assumed_mm_per_unit > 0
                                ? fmt::format("the drawing does not state its units ($INSUNITS); read as {:g} mm per "
                                              "unit as asked",
                                              out.mm_per_unit)
                                : "the drawing does not state its units ($INSUNITS); read as mm (give the unit, "
                                  "DxfOptions::assumed_mm_per_unit, if it is not)",
                            std::nullopt, std::nullopt});
  as.expand(out.mm_per_unit);
  as.drop_duplicates();
  as.merge_collinear_overlaps();
  as.chain();
  as.drop_coincident_closed();
  as.finish();
  return out;
}

ProfileReadResult read_dxf_profile(const std::string& path, const DxfOptions& options) {
  options.validate();
  const std::string text = read_text_file(path);
  return read_dxf_profile_text(text, path, options);
}

}  // namespace machplan
