#include "engine/programs/mesh.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <unordered_map>

#include "engine/common/error.h"
#include "engine/common/text_file.h"
#include "engine/common/internal/text_scan.h"

namespace machplan {
namespace {

using text_scan::iequals;
using text_scan::printable;

constexpr std::size_t kBinaryHeaderBytes = 84;
constexpr std::size_t kBinaryRecordBytes = 50;

// ---------------------------------------------------------------------------------------------
// Reading: one pass that checks the structure and collects the corners.

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

// No control bytes other than whitespace. A binary STL is never plain text: its triangle
// count at byte 80 would need four printable bytes, that is more than 539 million triangles.
bool is_plain_text(std::string_view bytes) {
  for (const char ch : bytes) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c < 0x20 && !is_space(ch)) || c == 0x7f) return false;
  }
  return true;
}

bool starts_with_solid(std::string_view bytes) {
  std::size_t k = 0;
  while (k < bytes.size() && is_space(bytes[k])) ++k;
  return bytes.size() - k >= 5 && iequals(bytes.substr(k, 5), "solid");
}

class AsciiScanner {
 public:
  AsciiScanner(std::string_view text, const std::string& source, std::size_t max_triangles)
      : text_(text), source_(source), max_triangles_(max_triangles) {}

  // Appends three corners per facet to `corners` (file units); throws InputError at the first
  // break in the structure.
  void scan(std::vector<Eigen::Vector3d>& corners) {
    std::string_view tok;
    if (!next(tok) || !iequals(tok, "solid")) fail("expected 'solid' at the start of an ASCII STL");
    skip_rest_of_line();
    std::size_t facets = 0;
    while (true) {
      if (!next(tok)) fail(line_, "the file ends before 'endsolid'");
      if (iequals(tok, "endsolid")) {
        skip_rest_of_line();
        if (!next(tok)) break;  // end of file: done
        if (!iequals(tok, "solid")) fail(tok_line_, fmt::format("expected 'solid' or the end of the file, found '{}'", printable(tok)));
        skip_rest_of_line();
        continue;
      }
      if (!iequals(tok, "facet")) fail(tok_line_, fmt::format("expected 'facet' or 'endsolid', found '{}'", printable(tok)));
      if (++facets > max_triangles_)
        fail(tok_line_, fmt::format("more than {} triangles (StlReadOptions::max_triangles)", max_triangles_));
      expect("normal");
      number();  // the stored normal is checked for form and ignored
      number();
      number();
      expect("outer");
      expect("loop");
      for (int v = 0; v < 3; ++v) {
        expect("vertex");
        const double x = number(), y = number(), z = number();
        corners.emplace_back(x, y, z);
      }
      if (!next(tok)) fail(line_, "the file ends inside a facet");
      if (iequals(tok, "vertex"))
        fail(tok_line_, "facet with more than three vertices; only triangles are supported");
      if (!iequals(tok, "endloop")) fail(tok_line_, fmt::format("expected 'endloop', found '{}'", printable(tok)));
      expect("endfacet");
    }
    if (facets == 0) fail(0, "ASCII STL holds no facet");
  }

 private:
  [[noreturn]] void fail(int line, const std::string& message) const { throw InputError(source_, line, message); }
  [[noreturn]] void fail(const std::string& message) const { fail(tok_line_, message); }

  bool next(std::string_view& tok) {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= text_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    tok = text_.substr(start, pos_ - start);
    tok_line_ = line_;
    return true;
  }

  void skip_rest_of_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  }

  void expect(const char* word) {
    std::string_view tok;
    if (!next(tok)) fail(line_, fmt::format("the file ends where '{}' was expected", word));
    if (!iequals(tok, word)) fail(tok_line_, fmt::format("expected '{}', found '{}'", word, printable(tok)));
  }

  // STL numbers are single precision: beyond float's range a value is refused, not rounded
  // to infinity.
  double number() {
    std::string_view tok;
    if (!next(tok)) fail(line_, "the file ends where a number was expected");
    std::string_view s = tok;
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double value = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (s.empty() || ec == std::errc::invalid_argument || end != s.data() + s.size())
      fail(tok_line_, fmt::format("expected a number, found '{}'", printable(tok)));
    if (ec == std::errc::result_out_of_range || !std::isfinite(value) || std::abs(value) > 3.4e38)
      fail(tok_line_, fmt::format("number '{}' is out of range or not finite", printable(tok)));
    return value;
  }

  std::string_view text_;
  const std::string& source_;
  std::size_t max_triangles_;
  std::size_t pos_ = 0;
  int line_ = 1;
  int tok_line_ = 1;
};

std::uint32_t read_u32_le(const char* p) {
  const auto* b = reinterpret_cast<const unsigned char*>(p);
  return std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
}

float read_f32_le(const char* p) {
  const std::uint32_t u = read_u32_le(p);
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

// Checks the declared triangle count against the size and appends three corners per triangle
// (file units) to `corners`.
void read_binary(std::string_view bytes, const std::string& source, std::size_t max_triangles,
                 std::vector<Eigen::Vector3d>& corners) {
  if (bytes.size() < kBinaryHeaderBytes)
    throw InputError(source, 0, fmt::format("not an STL file: {} bytes, too short for a binary STL (84-byte header) "
                                            "and not text starting with 'solid'",
                                            bytes.size()));
  const std::size_t declared = read_u32_le(bytes.data() + 80);
  const std::size_t held = (bytes.size() - kBinaryHeaderBytes) / kBinaryRecordBytes;
  const std::size_t extra = (bytes.size() - kBinaryHeaderBytes) % kBinaryRecordBytes;
  if (declared != held || extra != 0)
    throw InputError(source, 0,
                     fmt::format("binary STL declares {} triangles but the file holds {}{} ({} bytes; a binary STL is "
                                 "84 bytes plus 50 per triangle)",
                                 declared, held, extra ? fmt::format(" and {} bytes more", extra) : std::string(),
                                 bytes.size()));
  if (declared == 0) throw InputError(source, 0, "binary STL holds no triangle");
  if (declared > max_triangles)
    throw InputError(source, 0,
                     fmt::format("binary STL holds {} triangles, more than the limit of {} "
                                 "(StlReadOptions::max_triangles)",
                                 declared, max_triangles));
  corners.reserve(corners.size() + 3 * declared);
  for (std::size_t t = 0; t < declared; ++t) {
    const char* rec = bytes.data() + kBinaryHeaderBytes + t * kBinaryRecordBytes;
    for (int k = 3; k < 12; k += 3) {  // the three vertices; the stored normal is ignored
      const Eigen::Vector3d p(read_f32_le(rec + 4 * k), read_f32_le(rec + 4 * k + 4), read_f32_le(rec + 4 * k + 8));
      if (!p.allFinite())
        throw InputError(source, 0, fmt::format("binary STL triangle {} has a non-finite coordinate", t + 1));
      corners.push_back(p);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Welding

struct KeyHash {
  std::size_t operator()(const std::array<std::int64_t, 3>& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (const std::int64_t v : k) {
      h ^= static_cast<std::uint64_t>(v);
      h *= 1099511628211ull;
      h ^= h >> 29;
    }
    return static_cast<std::size_t>(h);
  }
};

std::int64_t bits_of(double v) {
  if (v == 0.0) v = 0.0;  // -0 and +0 weld
  std::int64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

}  // namespace

Mesh weld(const std::vector<Eigen::Vector3d>& corners, double tolerance_mm) {
  MACHPLAN_ASSERT(corners.size() % 3 == 0, "weld() takes three corners per triangle, got {}", corners.size());
  MACHPLAN_ASSERT(tolerance_mm >= 0.0 && std::isfinite(tolerance_mm), "weld tolerance {}", tolerance_mm);
  Mesh mesh;
  mesh.triangles.resize(corners.size() / 3);
  std::vector<int> index(corners.size());
  using Key = std::array<std::int64_t, 3>;
  // A corner seen before (bit for bit) takes the vertex it was given: identical corners always
  // share a vertex, whatever was created between them.
  std::unordered_map<Key, int, KeyHash> seen;
  seen.reserve(corners.size() / 2 + 1);
  // With a tolerance, a grid of cells `tolerance` wide: any vertex within the tolerance of a
  // corner lies in the corner's own cell or one of the 26 around it. A cell holds every vertex
  // created in it (a chain through `next_in_cell`), not only the first: two vertices of one
  // cell can be up to sqrt(3) tolerances apart.
  std::unordered_map<Key, int, KeyHash> cells;
  std::vector<int> next_in_cell;
  const double limit = 1e15;

  for (std::size_t c = 0; c < corners.size(); ++c) {
    const Eigen::Vector3d& p = corners[c];
    const auto [exact, first_time] =
        seen.try_emplace(Key{bits_of(p.x()), bits_of(p.y()), bits_of(p.z())}, -1);
    if (!first_time) {
      index[c] = exact->second;
      continue;
    }
    int found = -1;
    if (tolerance_mm > 0.0) {
      const Eigen::Vector3d q = p / tolerance_mm;
      if (!(q.cwiseAbs().maxCoeff() < limit))
        throw InputError("", 0, fmt::format("weld tolerance {} mm is too small for coordinate magnitude {}",
                                            tolerance_mm, p.cwiseAbs().maxCoeff()));
      const Key key{static_cast<std::int64_t>(std::floor(q.x())), static_cast<std::int64_t>(std::floor(q.y())),
                    static_cast<std::int64_t>(std::floor(q.z()))};
      // The nearest vertex within the tolerance, so that the answer does not depend on the
      // order the cells are visited in.
      double best = tolerance_mm;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = cells.find({key[0] + dx, key[1] + dy, key[2] + dz});
            if (it == cells.end()) continue;
            for (int v = it->second; v >= 0; v = next_in_cell[v]) {
              const double d = (mesh.vertices[v] - p).norm();
              if (d <= best) {
                best = d;
                found = v;
              }
            }
          }
      if (found < 0) {
        found = static_cast<int>(mesh.vertices.size());
        const auto [it, inserted] = cells.try_emplace(key, found);
        next_in_cell.push_back(inserted ? -1 : it->second);
        it->second = found;
      }
    }
    if (found < 0) found = static_cast<int>(mesh.vertices.size());
    if (found == static_cast<int>(mesh.vertices.size())) mesh.vertices.push_back(p);
    exact->second = found;
    index[c] = found;
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    mesh.triangles[t] = {index[3 * t], index[3 * t + 1], index[3 * t + 2]};
  return mesh;
}

MeshReport analyze_mesh(const Mesh& mesh) {
  MeshReport r;
  r.vertices = mesh.vertices.size();
  r.triangles = mesh.triangles.size();
  for (const auto& v : mesh.vertices) r.bounds.extend(v);

  struct EdgeUse {
    int count = 0;
    int direction_sum = 0;  // +1 for each walk low->high, -1 for high->low
  };
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(mesh.triangles.size() * 2);
  double signed_volume6 = 0.0;
  for (const auto& t : mesh.triangles) {
    const bool repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    if (repeated) {
      ++r.degenerate_triangles;
      continue;
    }
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    const Eigen::Vector3d& b = mesh.vertices[t[1]];
    const Eigen::Vector3d& c = mesh.vertices[t[2]];
    const double longest2 = std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
    if ((b - a).cross(c - a).norm() <= 1e-12 * longest2) ++r.degenerate_triangles;
    signed_volume6 += a.dot(b.cross(c));
    for (int k = 0; k < 3; ++k) {
      const auto u = static_cast<std::uint32_t>(t[k]);
      const auto v = static_cast<std::uint32_t>(t[(k + 1) % 3]);
      const std::uint64_t key = (std::uint64_t{std::min(u, v)} << 32) | std::max(u, v);
      EdgeUse& e = edges[key];
      ++e.count;
      e.direction_sum += u < v ? 1 : -1;
    }
  }
  r.edges = edges.size();
  bool oriented = true;
  for (const auto& [key, e] : edges) {
    if (e.count == 1) ++r.boundary_edges;
    if (e.count > 2) ++r.non_manifold_edges;
    if (e.count == 2 && e.direction_sum != 0) oriented = false;
  }
  r.consistently_oriented = oriented && r.non_manifold_edges == 0 && !edges.empty();
  r.closed = r.triangles > 0 && r.boundary_edges == 0 && r.non_manifold_edges == 0 && !edges.empty();
  if (r.closed && r.consistently_oriented) {
    r.volume_mm3 = std::abs(signed_volume6) / 6.0;
    r.outward = signed_volume6 > 0.0;
  }
  return r;
}

std::string MeshReport::verdict() const {
  if (sound()) return "sound: a closed solid, consistently oriented, faces outwards";
  std::string faults;
  const auto add = [&](const std::string& f) { faults += (faults.empty() ? "" : "; ") + f; };
  if (triangles == 0) add("no triangles");
  if (boundary_edges > 0) add(fmt::format("open: {} boundary edges", boundary_edges));
  if (non_manifold_edges > 0) add(fmt::format("{} non-manifold edges (more than two triangles on one edge)", non_manifold_edges));
  if (!consistently_oriented && non_manifold_edges == 0)
    add("not consistently oriented: neighbouring triangles walk a shared edge the same way");
  if (closed && consistently_oriented && !outward)
    add(volume_mm3 > 0 ? "faces point inwards (the triangles' corners run clockwise seen from outside)"
                       : "encloses no volume");
  return "not a sound solid: " + faults;
}

std::string MeshReport::brief() const {
  std::string s = fmt::format("{} vertices, {} triangles, {} edges\n", vertices, triangles, edges);
  s += fmt::format("closed: {}  (boundary edges {}, non-manifold edges {})\n", closed ? "yes" : "no", boundary_edges,
                   non_manifold_edges);
  s += fmt::format("consistently oriented: {}\n", consistently_oriented ? "yes" : "no");
  s += fmt::format("degenerate triangles: {}\n", degenerate_triangles);
  if (closed && consistently_oriented)
    s += fmt::format("volume: {:.6g} mm^3, faces point {}\n", volume_mm3, outward ? "outwards" : "inwards");
  else
    s += "volume: unknown (mesh not closed and consistently oriented)\n";
  if (!bounds.isEmpty())
    s += fmt::format("bounds: x {:.6g} .. {:.6g}, y {:.6g} .. {:.6g}, z {:.6g} .. {:.6g} mm\n", bounds.min().x(),
                     bounds.max().x(), bounds.min().y(), bounds.max().y(), bounds.min().z(), bounds.max().z());
  s += "verdict: " + verdict() + "\n";
  return s;
}

void StlReadOptions::validate() const {
  if (!(std::isfinite(scale_to_mm) && scale_to_mm > 0.0))
    throw InputError::field("scale_to_mm", fmt::format("is {}; it must be finite and positive", scale_to_mm));
  if (!(std::isfinite(weld_tolerance_mm) && weld_tolerance_mm >= 0.0 && weld_tolerance_mm <= kMaxWeldToleranceMm))
    throw InputError::field("weld_tolerance_mm",
                            fmt::format("is {}; it must be within 0 .. {} mm", weld_tolerance_mm, kMaxWeldToleranceMm));
  if (max_triangles == 0) throw InputError::field("max_triangles", "is 0; it must be positive");
}

Mesh read_stl_bytes(std::string_view bytes, const std::string& source, MeshReport* report,
                    const StlReadOptions& options) {
  options.validate();
  // 1. Decide the format, check the structure and collect the corners in one pass.
  std::vector<Eigen::Vector3d> corners;
  const bool text = is_plain_text(bytes);
  if (text && !starts_with_solid(bytes))
    throw InputError(source, 0, "not an STL file: plain text that does not start with 'solid'");
  if (text)
    AsciiScanner(bytes, source, options.max_triangles).scan(corners);
  else
    read_binary(bytes, source, options.max_triangles, corners);

  // 2. Scale; a finite file coordinate times a large scale can overflow.
  if (options.scale_to_mm != 1.0)
    for (Eigen::Vector3d& p : corners) {
      p *= options.scale_to_mm;
      if (!p.allFinite())
        throw InputError(source, 0,
                         fmt::format("a vertex times StlReadOptions::scale_to_mm {} is not finite", options.scale_to_mm));
    }

  // 3. Weld and report.
  Mesh mesh;
  try {
    mesh = weld(corners, options.weld_tolerance_mm);
  } catch (const InputError& e) {
    throw InputError(source, 0, e.message());
  }
  if (report != nullptr) *report = analyze_mesh(mesh);
  return mesh;
}

Mesh read_stl(const std::string& path, MeshReport* report, const StlReadOptions& options) {
  options.validate();
  const std::string bytes = read_text_file(path, options.max_file_bytes);
  return read_stl_bytes(bytes, path, report, options);
}

Mesh make_box_mesh(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  Mesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(k & 1 ? max.x() : min.x(), k & 2 ? max.y() : min.y(), k & 4 ? max.z() : min.z());
  // Each face as two triangles, counter-clockwise seen from outside.
  m.triangles = {{0, 2, 1}, {1, 2, 3},   // z = min
                 {4, 5, 6}, {5, 7, 6},   // z = max
                 {0, 1, 4}, {1, 5, 4},   // y = min
                 {2, 6, 3}, {3, 6, 7},   // y = max
                 {0, 4, 2}, {2, 4, 6},   // x = min
                 {1, 3, 5}, {3, 7, 5}};  // x = max
  return m;
}

namespace {
Eigen::Vector3d facet_normal(const Mesh& mesh, const Eigen::Vector3i& t) {
  const Eigen::Vector3d n =
      (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
  const double len = n.norm();
  return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}
}  // namespace

std::string to_ascii_stl(const Mesh& mesh, std::string_view solid_name) {
  std::string s = fmt::format("solid {}\n", solid_name);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d n = facet_normal(mesh, t);
    s += fmt::format("  facet normal {} {} {}\n    outer loop\n", n.x(), n.y(), n.z());
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& v = mesh.vertices[t[k]];
      s += fmt::format("      vertex {} {} {}\n", v.x(), v.y(), v.z());
    }
    s += "    endloop\n  endfacet\n";
  }
  s += fmt::format("endsolid {}\n", solid_name);
  return s;
}

std::string to_binary_stl(const Mesh& mesh) {
  std::string s(kBinaryHeaderBytes + kBinaryRecordBytes * mesh.triangles.size(), '\0');
  const char header[] = "binary STL written by machplan";
  std::memcpy(s.data(), header, sizeof header - 1);
  auto put_u32 = [&](std::size_t at, std::uint32_t u) {
    for (int k = 0; k < 4; ++k) s[at + k] = static_cast<char>((u >> (8 * k)) & 0xff);
  };
  auto put_f32 = [&](std::size_t at, double v) {
    const float f = static_cast<float>(v);
    std::uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    put_u32(at, u);
  };
  put_u32(80, static_cast<std::uint32_t>(mesh.triangles.size()));
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::size_t at = kBinaryHeaderBytes + kBinaryRecordBytes * t;
    const Eigen::Vector3d n = facet_normal(mesh, mesh.triangles[t]);
    for (int k = 0; k < 3; ++k) put_f32(at + 4 * k, n[k]);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) put_f32(at + 12 + 12 * c + 4 * k, mesh.vertices[mesh.triangles[t][c]][k]);
  }
  return s;
}

}  // namespace machplan
