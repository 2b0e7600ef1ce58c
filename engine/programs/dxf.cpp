// DXF profile reader. Three stages:
//   1. scan():    our own pass over the text: split into group-code / value pairs, check every
//                 pair, follow SECTION / ENDSEC / EOF, collect the header's $INSUNITS and the
//                 model-space entities with their line numbers, handles and layers.
//   2. dxflib:    the supported entities are re-written as clean pairs (numbers re-printed,
//                 our entity index in place of the handle) and parsed by DL_Dxf into pieces.
//   3. assemble:  drop zero-length and duplicate pieces, chain open pieces into contours,
//                 check each contour and each pair, nest them.
#include "engine/programs/dxf.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include <dl_creationadapter.h>
#include <dl_dxf.h>
#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/text_file.h"

namespace machplan {
namespace {

using Eigen::Vector2d;
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

struct Scan {
  double mm_per_unit = 1.0;
  std::vector<Entity> entities;
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
    throw InputError(source, p.line + 1, fmt::format("group code {}: '{}' is not a number", p.code, v));
  if (!std::isfinite(x) || std::abs(x) > kMaxCoordinateMm)
    throw InputError(source, p.line + 1,
                     fmt::format("group code {}: {} is not finite or beyond {:g}", p.code, v, kMaxCoordinateMm));
  return x;
}

long parse_int(const std::string& source, const Pair& p) {
  const std::string_view v = trim(p.value);
  long x = 0;
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (v.empty() || ec != std::errc() || ptr != v.data() + v.size() || x < -2147483648L || x > 2147483647L)
    throw InputError(source, p.line + 1, fmt::format("group code {}: '{}' is not an integer", p.code, v));
  return x;
}

// mm per drawing unit for $INSUNITS; 0 (unitless) reads as mm.
double insunits_scale(const std::string& source, const Pair& p) {
  switch (parse_int(source, p)) {
    case 0: return 1.0;         // unitless
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
                                   code_text.substr(0, 40)));
    if (k + 1 >= lines.size())
      throw InputError(source, line, fmt::format("group code {} has no value: the file is truncated", code));
    std::string_view value = lines[k + 1];
    if (!value.empty() && value.back() == '\r') value.remove_suffix(1);
    if (code != 1 && code != 3) value = trim(value);  // text values keep their spaces
    if (value.size() > 2049)
      throw InputError(source, line + 1, fmt::format("value of group code {} is {} characters long; DXF allows 2049",
                                                     code, value.size()));
    pairs.push_back({code, std::string(value), line});
  }
  return pairs;
}

const std::set<std::string>& annotation_types() {
  static const std::set<std::string> t = {"TEXT", "MTEXT", "DIMENSION", "ARC_DIMENSION",
                                          "LARGE_RADIAL_DIMENSION", "LEADER", "MLEADER",
                                          "MULTILEADER", "ATTDEF", "ATTRIB", "HATCH", "POINT",
                                          "VIEWPORT", "TOLERANCE", "IMAGE", "WIPEOUT",
                                          "OLEFRAME", "OLE2FRAME"};
  return t;
}

bool is_supported(const std::string& type) {
  return type == "LINE" || type == "ARC" || type == "CIRCLE" || type == "LWPOLYLINE" || type == "POLYLINE";
}

Scan scan(std::string_view text, const std::string& source) {
  const std::vector<Pair> pairs = split_pairs(text, source);
  Scan out;
  std::map<std::string, int> type_count;
  std::string section;  // empty: between sections
  bool seen_eof = false;
  std::size_t i = 0;
  auto finish_entity = [&](Entity& e) {
    for (const auto& p : e.pairs) {
      if (p.code == 5) e.handle = p.value;
      if (p.code == 8) e.layer = p.value;
      if (p.code == 67) e.paper_space = parse_int(source, p) == 1;
    }
    if (e.handle.empty()) e.handle = fmt::format("{}#{}", e.type, ++type_count[e.type]);
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
      if (section.empty()) section = "?";
      i += 2;
      continue;
    }
    if (p.code == 0 && p.value == "ENDSEC") { section.clear(); ++i; continue; }
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
    if (section != "ENTITIES") { ++i; continue; }
    if (p.code != 0)
      throw InputError(source, p.line, fmt::format("expected an entity (group code 0), found group code {}", p.code));
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
    finish_entity(e);
    out.entities.push_back(std::move(e));
  }
  if (!seen_eof) {
    const int last = pairs.empty() ? 1 : pairs.back().line + 1;
    throw InputError(source, last, pairs.empty() ? "empty file: not a DXF drawing"
                                                 : "the file ends without 0/EOF: it is truncated");
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Stage 2: dxflib on re-written pairs.

// What dxflib gives back, per entity index.
struct RawEntity {
  enum class Kind { none, line, arc, circle, polyline } kind = Kind::none;
  Vector2d p1 = Vector2d::Zero(), p2 = Vector2d::Zero();
  double z1 = 0, z2 = 0;
  double radius = 0, angle1_deg = 0, angle2_deg = 0;
  int flags = 0;
  std::vector<Vector2d> vertices;
  std::vector<double> bulges;
  std::vector<double> vertex_z;
};

class Collector : public DL_CreationAdapter {
 public:
  explicit Collector(std::vector<RawEntity>& out) : out_(out) {}
  void addLine(const DL_LineData& d) override {
    RawEntity* e = slot();
    if (!e) return;
    e->kind = RawEntity::Kind::line;
    e->p1 = {d.x1, d.y1};
    e->p2 = {d.x2, d.y2};
    e->z1 = d.z1;
    e->z2 = d.z2;
  }
  void addArc(const DL_ArcData& d) override {
    RawEntity* e = slot();
    if (!e) return;
    e->kind = RawEntity::Kind::arc;
    e->p1 = {d.cx, d.cy};
    e->radius = d.radius;
    e->angle1_deg = d.angle1;
    e->angle2_deg = d.angle2;
  }
  void addCircle(const DL_CircleData& d) override {
    RawEntity* e = slot();
    if (!e) return;
    e->kind = RawEntity::Kind::circle;
    e->p1 = {d.cx, d.cy};
    e->radius = d.radius;
  }
  void addPolyline(const DL_PolylineData& d) override {
    current_ = slot();
    if (!current_) return;
    current_->kind = RawEntity::Kind::polyline;
    current_->flags = d.flags;
  }
  void addVertex(const DL_VertexData& d) override {
    if (!current_) return;
    current_->vertices.emplace_back(d.x, d.y);
    current_->bulges.push_back(d.bulge);
    current_->vertex_z.push_back(d.z);
  }

 private:
  // The entity dxflib is reporting, from the handle we wrote (our index, in hex).
  RawEntity* slot() {
    const int h = getAttributes().getHandle();
    if (h < 0 || static_cast<std::size_t>(h) >= out_.size()) return nullptr;
    return &out_[static_cast<std::size_t>(h)];
  }
  std::vector<RawEntity>& out_;
  RawEntity* current_ = nullptr;
};

void emit(std::string& s, int code, const std::string& value) { s += fmt::format("{}\n{}\n", code, value); }
void emit_real(std::string& s, int code, double v) { s += fmt::format("{}\n{:.17g}\n", code, v); }

// Values of the given real codes in `pairs`, default 0; each code used at most once.
double real_of(const std::string& source, const std::vector<Pair>& pairs, int code, double dflt = 0.0) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_real(source, p);
  return dflt;
}
long int_of(const std::string& source, const std::vector<Pair>& pairs, int code, long dflt = 0) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_int(source, p);
  return dflt;
}

// Writes entity `index` as clean pairs for dxflib. Validates every number it writes.
void rewrite(const std::string& source, const Entity& e, std::size_t index, std::string& s) {
  const std::string handle = fmt::format("{:X}", index);
  const auto& P = e.pairs;
  if (e.type == "LINE") {
    emit(s, 0, "LINE");
    emit(s, 5, handle);
    for (int c : {10, 20, 30, 11, 21, 31}) emit_real(s, c, real_of(source, P, c));
  } else if (e.type == "ARC" || e.type == "CIRCLE") {
    emit(s, 0, e.type);
    emit(s, 5, handle);
    for (int c : {10, 20, 30, 40}) emit_real(s, c, real_of(source, P, c));
    if (e.type == "ARC")
      for (int c : {50, 51}) emit_real(s, c, real_of(source, P, c));
  } else if (e.type == "LWPOLYLINE") {
    // Vertices in order: each 10 starts one, 20 and 42 belong to the latest.
    struct V { double x = 0, y = 0, b = 0; };
    std::vector<V> vs;
    long declared = -1;
    for (const auto& p : P) {
      if (p.code == 90) declared = parse_int(source, p);
      if (p.code == 10) vs.push_back({parse_real(source, p), 0, 0});
      if ((p.code == 20 || p.code == 42) && vs.empty())
        throw InputError(source, p.line, fmt::format("LWPOLYLINE: group code {} before the first vertex (10)", p.code));
      if (p.code == 20) vs.back().y = parse_real(source, p);
      if (p.code == 42) vs.back().b = parse_real(source, p);
    }
    if (declared >= 0 && static_cast<std::size_t>(declared) != vs.size())
      throw InputError(source, e.line, fmt::format("LWPOLYLINE declares {} vertices (group code 90) but lists {}",
                                                   declared, vs.size()));
    emit(s, 0, "LWPOLYLINE");
    emit(s, 5, handle);
    emit(s, 90, std::to_string(vs.size()));
    emit(s, 70, std::to_string(int_of(source, P, 70) & 1));
    for (const auto& v : vs) {
      emit_real(s, 10, v.x);
      emit_real(s, 20, v.y);
      emit_real(s, 42, v.b);
    }
  } else if (e.type == "POLYLINE") {
    emit(s, 0, "POLYLINE");
    emit(s, 5, handle);
    emit(s, 66, "1");
    emit(s, 70, std::to_string(int_of(source, P, 70) & 1));
    emit_real(s, 10, 0);
    emit_real(s, 20, 0);
    emit_real(s, 30, real_of(source, P, 30));
    for (std::size_t k = 0; k < e.vertices.size(); ++k) {
      const auto& V = e.vertices[k];
      if (int_of(source, V, 70) & 16) continue;  // spline frame control point: not on the curve
      emit(s, 0, "VERTEX");
      emit(s, 5, handle);
      for (int c : {10, 20, 30, 42}) emit_real(s, c, real_of(source, V, c));
    }
    emit(s, 0, "SEQEND");
  }
}

// ---------------------------------------------------------------------------------------
// Stage 3: assembling contours.

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
  }
  double length() const {
    double sum = 0;
    for (std::size_t i = 0; i < b.size(); ++i) sum += machplan::length(make_segment(v[i], v[(i + 1) % v.size()], b[i]));
    return sum;
  }
};

std::string fmt_pt(const Vector2d& p) { return fmt::format("({:.4f}, {:.4f})", p.x(), p.y()); }

class Assembler {
 public:
  Assembler(const std::string& source, const Scan& scan, const DxfOptions& opt, ProfileReadResult& out)
      : source_(source), scan_(scan), tol_(opt.chain_tolerance_mm), out_(out) {}

  std::string label(std::size_t entity) const { return scan_.entities[entity].handle; }
  std::string where(std::size_t entity) const {
    const auto& e = scan_.entities[entity];
    return fmt::format("{} {} (layer {}, line {})", e.type, e.handle, e.layer, e.line);
  }

  void problem(ProfileProblem::Severity s, std::string kind, std::vector<std::size_t> ents, std::string message,
               std::optional<Vector2d> at = std::nullopt) {
    ProfileProblem p{s, std::move(kind), {}, std::move(message), at};
    for (auto e : ents) p.handles.push_back(label(e));
    out_.problems.push_back(std::move(p));
  }

  Vector2d to_mm(const Vector2d& ocs, bool mirror, std::size_t entity) const {
    Vector2d w = ocs * scan_.mm_per_unit;
    if (mirror) w.x() = -w.x();
    if (!w.allFinite() || std::abs(w.x()) > kMaxCoordinateMm || std::abs(w.y()) > kMaxCoordinateMm)
      throw InputError(source_, scan_.entities[entity].line,
                       fmt::format("{}: coordinate {} mm is beyond {:g} mm", where(entity), fmt_pt(w), kMaxCoordinateMm));
    return w;
  }

  // Turns dxflib's entity into a piece, or reports why not.
  void add(std::size_t idx, const RawEntity& r, double ex, double ey, double ez) {
    const auto W = ProfileProblem::Severity::warning;
    const auto E = ProfileProblem::Severity::error;
    const double en = std::sqrt(ex * ex + ey * ey + ez * ez);
    const bool ocs = r.kind != RawEntity::Kind::line;
    if (ocs && (en == 0 || std::hypot(ex, ey) > 1e-9 * en)) {
      problem(E, "not_planar", {idx}, fmt::format("{} lies outside the XY plane (extrusion {:g} {:g} {:g})", where(idx), ex, ey, ez));
      return;
    }
    const bool mirror = ocs && ez < 0;
    Piece pc;
    pc.entities = {idx};
    switch (r.kind) {
      case RawEntity::Kind::none:
        MACHPLAN_ASSERT(false, "dxflib did not report {}", where(idx));
      case RawEntity::Kind::line:
        if (std::abs(r.z1 - r.z2) > tol_) {
          problem(E, "not_planar", {idx}, fmt::format("{} runs from z {:g} to z {:g}", where(idx), r.z1, r.z2));
          return;
        }
        pc.v = {to_mm(r.p1, false, idx), to_mm(r.p2, false, idx)};
        pc.b = {0.0};
        break;
      case RawEntity::Kind::circle:
      case RawEntity::Kind::arc: {
        const double radius = r.radius * scan_.mm_per_unit;
        const Vector2d c = to_mm(r.p1, mirror, idx);
        double sweep = 360.0;
        if (r.kind == RawEntity::Kind::arc) {
          sweep = std::fmod(r.angle2_deg - r.angle1_deg, 360.0);
          if (sweep < 0) sweep += 360.0;
        }
        if (!(radius > 0.5 * tol_) || radius * sweep * kPi / 180 <= tol_ ||
            std::abs(c.x()) + radius > kMaxCoordinateMm || std::abs(c.y()) + radius > kMaxCoordinateMm) {
          if (!(radius <= kMaxCoordinateMm))
            throw InputError(source_, scan_.entities[idx].line, fmt::format("{}: radius {:g} mm is too large", where(idx), radius));
          problem(W, "zero_length", {idx}, fmt::format("{} has zero length (radius {:g} mm); dropped", where(idx), radius), c);
          return;
        }
        if (sweep >= 360.0 - 1e-9) {
          pc.v = {c + Vector2d(radius, 0), c - Vector2d(radius, 0)};
          pc.b = {1.0, 1.0};
          pc.closed = true;
          if (mirror) pc.reverse();
          break;
        }
        const double a1 = r.angle1_deg * kPi / 180, a2 = a1 + sweep * kPi / 180;
        const Vector2d c_ocs = r.p1 * scan_.mm_per_unit;
        Vector2d s = c_ocs + radius * Vector2d(std::cos(a1), std::sin(a1));
        Vector2d e = c_ocs + radius * Vector2d(std::cos(a2), std::sin(a2));
        double bulge = std::tan(sweep * kPi / 180 / 4);
        if (mirror) { s.x() = -s.x(); e.x() = -e.x(); bulge = -bulge; }
        pc.v = {s, e};
        pc.b = {bulge};
        break;
      }
      case RawEntity::Kind::polyline: {
        pc.closed = (r.flags & 1) != 0;
        for (std::size_t k = 0; k < r.vertices.size(); ++k) {
          const Vector2d p = to_mm(r.vertices[k], mirror, idx);
          const double bulge = mirror ? -r.bulges[k] : r.bulges[k];
          if (!std::isfinite(bulge) || std::abs(bulge) > kMaxBulge)
            throw InputError(source_, scan_.entities[idx].line, fmt::format("{}: bulge {:g} is out of range", where(idx), bulge));
          if (!pc.v.empty() && (p - pc.v.back()).norm() <= tol_) {
            ++dropped_spans_;
            continue;  // zero-length span: keep the earlier vertex and its bulge
          }
          pc.v.push_back(p);
          pc.b.push_back(bulge);
        }
        if (pc.v.size() >= 2 && (pc.v.back() - pc.v.front()).norm() <= tol_) {
          // Last vertex repeats the first: the polyline is closed whatever its flag says.
          pc.v.pop_back();
          pc.b.pop_back();
          pc.closed = true;
          ++dropped_spans_;
        }
        if (dropped_spans_ > 0 && pc.v.size() >= 2) {
          problem(W, "zero_length", {idx}, fmt::format("{} has {} span(s) shorter than {:g} mm; dropped", where(idx), dropped_spans_, tol_));
        }
        dropped_spans_ = 0;
        if (!pc.closed && !pc.b.empty()) pc.b.pop_back();  // open: n - 1 spans
        if (pc.v.size() < 2 || pc.length() <= tol_) {
          problem(W, "zero_length", {idx}, fmt::format("{} has zero length; dropped", where(idx)), pc.v.empty() ? std::nullopt : std::optional<Vector2d>(pc.v.front()));
          return;
        }
        if (std::any_of(r.vertex_z.begin(), r.vertex_z.end(), [&](double z) { return std::abs(z - r.vertex_z.front()) > tol_; })) {
          problem(E, "not_planar", {idx}, fmt::format("{} has vertices at different z", where(idx)));
          return;
        }
        break;
      }
    }
    if (r.kind == RawEntity::Kind::line && pc.length() <= tol_) {
      problem(W, "zero_length", {idx}, fmt::format("{} has zero length; dropped", where(idx)), pc.v.front());
      return;
    }
    pieces_.push_back(std::move(pc));
  }

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

  // Joins `next` onto the end of `chain` (next.front() is at chain.back()).
  static void append(Piece& chain, const Piece& next) {
    chain.v.insert(chain.v.end(), next.v.begin() + 1, next.v.end());
    chain.b.insert(chain.b.end(), next.b.begin(), next.b.end());
    chain.entities.insert(chain.entities.end(), next.entities.begin(), next.entities.end());
  }

  // Nearest free end among unused open pieces to p: (piece, at_end, distance).
  std::tuple<std::size_t, bool, double> nearest_end(const Vector2d& p, const std::vector<bool>& used) const {
    std::tuple<std::size_t, bool, double> best{pieces_.size(), false, std::numeric_limits<double>::infinity()};
    for (std::size_t j = 0; j < pieces_.size(); ++j) {
      if (used[j] || pieces_[j].closed) continue;
      const double ds = (pieces_[j].front() - p).norm(), de = (pieces_[j].back() - p).norm();
      if (ds < std::get<2>(best)) best = {j, false, ds};
      if (de < std::get<2>(best)) best = {j, true, de};
    }
    return best;
  }

  void chain() {
    std::vector<bool> used(pieces_.size(), false);
    for (std::size_t i = 0; i < pieces_.size(); ++i) {
      if (used[i]) continue;
      used[i] = true;
      Piece c = pieces_[i];
      if (c.closed) {
        closed_.push_back(std::move(c));
        continue;
      }
      bool closed = false;
      for (int pass = 0; pass < 2 && !closed; ++pass) {  // forward from the end, then from the start
        while (true) {
          const double to_start = (c.back() - c.front()).norm();
          auto [j, at_end, d] = nearest_end(c.back(), used);
          if (to_start <= tol_ && to_start <= d && c.b.size() >= 2) {  // one span cannot close
            closed = true;
            if (pass == 1) c.reverse();  // back to the first entity's direction
            break;
          }
          if (j == pieces_.size() || d > tol_) break;
          used[j] = true;
          Piece n = pieces_[j];
          if (at_end) n.reverse();
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
      // Open: report the gap between the chain's two ends and the nearest other end.
      c.reverse();  // back to the drawn direction of the first entity where possible
      const double gap = (c.back() - c.front()).norm();
      auto [j, at_end, d] = nearest_end(c.back(), used);
      std::string near = j < pieces_.size() ? fmt::format("; nearest free end elsewhere is {:.4f} mm away", d) : "";
      problem(ProfileProblem::Severity::error, "open_chain", c.entities,
              fmt::format("open chain of {} entit{} starting at {}: its ends {} and {} are {:.4f} mm apart, more than "
                          "the tolerance {:g} mm{}",
                          c.entities.size(), c.entities.size() == 1 ? "y" : "ies", where(c.entities.front()),
                          fmt_pt(c.front()), fmt_pt(c.back()), gap, tol_, near),
              c.back());
    }
  }

  void finish() {
    const auto E = ProfileProblem::Severity::error;
    for (auto& pc : closed_) {
      ProfileContour pcn;
      try {
        pcn.contour = Contour(pc.v, pc.b);
      } catch (const std::invalid_argument& e) {
        throw InputError(source_, scan_.entities[pc.entities.front()].line, fmt::format("{}: {}", where(pc.entities.front()), e.what()));
      }
      pcn.area_mm2 = signed_area(pcn.contour);
      pcn.perimeter_mm = perimeter(pcn.contour);
      for (auto e : pc.entities) pcn.handles.push_back(label(e));
      pcn.layer = scan_.entities[pc.entities.front()].layer;
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
    // Pairs of contours that cross or touch.
    auto& cs = out_.contours;
    std::vector<Eigen::AlignedBox2d> boxes;
    for (const auto& c : cs) boxes.push_back(bounding_box(c.contour));
    std::vector<std::vector<bool>> overlapping(cs.size(), std::vector<bool>(cs.size(), false));
    for (std::size_t a = 0; a < cs.size(); ++a)
      for (std::size_t b = a + 1; b < cs.size(); ++b) {
        Eigen::AlignedBox2d grown(boxes[a].min() - Vector2d::Constant(tol_), boxes[a].max() + Vector2d::Constant(tol_));
        if (!grown.intersects(boxes[b])) continue;
        const auto pts = contour_intersections(cs[a].contour, cs[b].contour, 0.1 * tol_);
        if (pts.empty()) continue;
        overlapping[a][b] = overlapping[b][a] = true;
        std::vector<std::size_t> ents = {contour_entities_[a].front(), contour_entities_[b].front()};
        problem(E, "overlap", ents,
                fmt::format("contours {} and {} cross or touch at {}{}", a, b, fmt_pt(pts.front()),
                            pts.size() > 1 ? fmt::format(" and {} more place(s)", pts.size() - 1) : ""),
                pts.front());
        auto& h = out_.problems.back().handles;
        h.clear();
        for (auto e : contour_entities_[a]) h.push_back(label(e));
        for (auto e : contour_entities_[b]) h.push_back(label(e));
      }
    // Nesting: the smallest contour that holds this one's first vertex.
    for (std::size_t i = 0; i < cs.size(); ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < cs.size(); ++j) {
        if (i == j || overlapping[i][j]) continue;
        const double aj = std::abs(cs[j].area_mm2), ai = std::abs(cs[i].area_mm2);
        if (aj <= ai || aj >= best) continue;
        if (!boxes[j].contains(boxes[i])) continue;
        if (contains(cs[j].contour, cs[i].contour.vertices().front())) {
          best = aj;
          cs[i].parent = static_cast<int>(j);
        }
      }
    }
    for (std::size_t i = 0; i < cs.size(); ++i) {
      if (cs[i].parent >= 0) cs[static_cast<std::size_t>(cs[i].parent)].children.push_back(static_cast<int>(i));
      int depth = 0;
      for (int p = cs[i].parent; p >= 0 && depth <= static_cast<int>(cs.size()); p = cs[static_cast<std::size_t>(p)].parent) ++depth;
      cs[i].depth = depth;
    }
    if (cs.empty()) problem(E, "no_contours", {}, "the drawing holds no closed contour");
  }

  std::vector<Piece> pieces_;

 private:
  const std::string& source_;
  const Scan& scan_;
  double tol_;
  ProfileReadResult& out_;
  std::vector<Piece> closed_;
  std::vector<std::vector<std::size_t>> contour_entities_;
  int dropped_spans_ = 0;
};

}  // namespace

void DxfOptions::validate() const {
  if (!std::isfinite(chain_tolerance_mm) || !(chain_tolerance_mm > 0.0) || chain_tolerance_mm > 10.0)
    throw InputError("chain_tolerance_mm", 0,
                     fmt::format("is {}, must be finite, > 0 and <= 10 mm", chain_tolerance_mm));
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
  out.mm_per_unit = sc.mm_per_unit;
  Assembler as(source, sc, options, out);

  std::string clean;
  std::vector<std::size_t> sent;
  for (std::size_t i = 0; i < sc.entities.size(); ++i) {
    const Entity& e = sc.entities[i];
    if (e.paper_space) {
      as.problem(ProfileProblem::Severity::warning, "paper_space", {i}, fmt::format("{} is on a paper-space layout; ignored", as.where(i)));
      continue;
    }
    if (!is_supported(e.type)) {
      if (annotation_types().count(e.type))
        as.problem(ProfileProblem::Severity::warning, "annotation_ignored", {i}, fmt::format("{} is drawing annotation; ignored", as.where(i)));
      else
        as.problem(ProfileProblem::Severity::error, "unsupported_entity", {i},
                   fmt::format("{} is not supported: its geometry is missing from the profile", as.where(i)));
      continue;
    }
    if (e.type == "POLYLINE" && (int_of(source, e.pairs, 70) & (4 | 8 | 16 | 64))) {
      as.problem(ProfileProblem::Severity::error, "unsupported_entity", {i},
                 fmt::format("{} is a 3-D, mesh or spline-fit polyline (flags {}), which is not supported", as.where(i),
                             int_of(source, e.pairs, 70)));
      continue;
    }
    rewrite(source, e, i, clean);
    sent.push_back(i);
  }
  std::vector<RawEntity> raw(sc.entities.size());
  if (!sent.empty()) {
    std::string stream_text = "0\nSECTION\n2\nENTITIES\n" + clean + "0\nENDSEC\n0\nEOF\n";
    std::istringstream in(stream_text);
    Collector collector(raw);
    DL_Dxf dxf;
    dxf.in(in, &collector);
  }
  for (auto i : sent) {
    const auto& P = sc.entities[i].pairs;
    as.add(i, raw[i], real_of(source, P, 210, 0.0), real_of(source, P, 220, 0.0), real_of(source, P, 230, 1.0));
  }
  as.drop_duplicates();
  as.chain();
  as.finish();
  return out;
}

ProfileReadResult read_dxf_profile(const std::string& path, const DxfOptions& options) {
  options.validate();
  const std::string text = read_text_file(path);
  return read_dxf_profile_text(text, path, options);
}

}  // namespace machplan
