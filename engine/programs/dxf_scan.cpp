// Stage 1 of the DXF reader (engine/programs/internal/dxf_stages.h): the file into pairs, the
// pairs into sections, blocks and entities.
#include <charconv>
#include "engine/common/internal/text_scan.h"
#include <cmath>
#include <cstdlib>
#include <map>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/contour.h"
#include "engine/programs/internal/dxf_stages.h"

namespace machplan::dxf {
namespace {

using text_scan::trim;

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
  if (is_binary_dxf(text)) return binary_pairs(text, source);
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

}  // namespace

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

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

double real_of(const std::string& source, const std::vector<Pair>& pairs, int code, double dflt) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_real(source, p);
  return dflt;
}
long int_of(const std::string& source, const std::vector<Pair>& pairs, int code, long dflt) {
  for (const auto& p : pairs)
    if (p.code == code) return parse_int(source, p);
  return dflt;
}

std::vector<Eigen::Vector3d> points_of(const std::string& source, const std::vector<Pair>& pairs, int xcode,
                                const char* what) {
  std::vector<Eigen::Vector3d> pts;
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

namespace {

// Fills an entity's handle (its own, or TYPE#N counted per type), layer and paper-space flag.
void finish_entity(Entity& e, const std::string& source, std::map<std::string, int>& type_count) {
  for (const auto& p : e.pairs) {
    if (p.code == 5) e.handle = p.value;
    if (p.code == 8) e.layer = p.value;
    if (p.code == 67) e.paper_space = parse_int(source, p) == 1;
  }
  if (e.handle.empty()) e.handle = fmt::format("{}#{}", e.type, ++type_count[e.type]);
}

// Reads the entity starting at pairs[i] (a 0/TYPE pair) with its VERTEX / ATTRIB followers,
// leaving i at the pair after it.
Entity read_entity(const std::vector<Pair>& pairs, std::size_t& i, const std::string& source,
                   std::map<std::string, int>& type_count) {
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
  finish_entity(e, source, type_count);
  return e;
}

}  // namespace

Scan scan(std::string_view text, const std::string& source) {
  const std::vector<Pair> pairs = split_pairs(text, source);
  Scan out;
  std::map<std::string, int> type_count;
  std::string section;  // empty: between sections
  bool seen_eof = false;
  Block* block = nullptr;  // the block being read in the BLOCKS section
  std::size_t i = 0;
  // A header variable (9/$NAME at pairs[i]): $INSUNITS is read, the others skipped.
  auto header_variable = [&](const Pair& p) {
    if (p.value == "$INSUNITS") {
      if (i + 1 >= pairs.size() || pairs[i + 1].code != 70)
        throw InputError(source, p.line, "$INSUNITS is not followed by its value (group code 70)");
      out.mm_per_unit = insunits_scale(source, pairs[i + 1]);
      i += 2;
      return;
    }
    ++i;
  };
  bool after_header = false;  // between the header's ENDSEC and the next section
  while (i < pairs.size()) {
    const Pair& p = pairs[i];
    if (section.empty()) {
      if (p.code == 999) { ++i; continue; }
      // Header variables left after the header's ENDSEC (dxflib 2.0, which LibreCAD used to
      // write with, leaves some there): other readers take them as the header's, and so do we.
      if (after_header && p.code == 9) {
        header_variable(p);
        continue;
      }
      if (after_header && p.code != 0) { ++i; continue; }
      if (p.code != 0)
        throw InputError(source, p.line, fmt::format("expected 0/SECTION or 0/EOF, found group code {}", p.code));
      if (p.value == "EOF") { seen_eof = true; break; }
      if (p.value != "SECTION")
        throw InputError(source, p.line, fmt::format("expected 0/SECTION or 0/EOF, found 0/{}", p.value.substr(0, 40)));
      if (i + 1 >= pairs.size() || pairs[i + 1].code != 2)
        throw InputError(source, p.line, "0/SECTION is not followed by its name (group code 2)");
      after_header = false;
      section = pairs[i + 1].value;
      if (section.empty()) section.push_back('?');  // not = "?": g++ 12 warns falsely (-Wrestrict)
      i += 2;
      continue;
    }
    if (p.code == 0 && p.value == "ENDSEC") {
      if (block) throw InputError(source, p.line, fmt::format("block {} has no 0/ENDBLK", block->name));
      after_header = section == "HEADER";
      section.clear();
      ++i;
      continue;
    }
    if (p.code == 0 && (p.value == "EOF" || p.value == "SECTION"))
      throw InputError(source, p.line, fmt::format("section {} has no 0/ENDSEC before 0/{}", section, p.value));
    if (section == "HEADER") {
      if (p.code == 9) header_variable(p);
      else ++i;
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
      block->entities.push_back(read_entity(pairs, i, source, type_count));
      continue;
    }
    if (section != "ENTITIES") { ++i; continue; }
    if (p.code != 0)
      throw InputError(source, p.line, fmt::format("expected an entity (group code 0), found group code {}", p.code));
    out.entities.push_back(read_entity(pairs, i, source, type_count));
  }
  if (!seen_eof) {
    const int last = pairs.empty() ? 1 : pairs.back().line + 1;
    throw InputError(source, last, pairs.empty() ? "empty file: not a DXF drawing"
                                                 : "the file ends without 0/EOF: it is truncated");
  }
  return out;
}

}  // namespace machplan::dxf
