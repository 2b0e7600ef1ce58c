// Binary DXF into the pairs an ASCII DXF holds (stage 1 of the DXF reader,
// engine/programs/internal/dxf_stages.h).
//
// The format, as Autodesk documents it ("Binary DXF Files" in the DXF reference): the sentinel
// "AutoCAD Binary DXF\r\n\x1a\0", then group code / value pairs. A group code is 2 bytes,
// little-endian, in files of release 13 and later; 1 byte in older ones, where 255 announces
// a 2-byte code that follows. The value's form follows from the code's range: strings end with
// a NUL byte, reals are 8-byte IEEE doubles, integers 2, 4 or 8 bytes, flags (290-299) 1
// byte, binary chunks (310-319, 1004) a length byte and that many bytes; all little-endian.
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/programs/internal/dxf_stages.h"

namespace machplan::dxf {
namespace {

constexpr std::string_view kSentinel("AutoCAD Binary DXF\r\n\x1a\0", 22);

enum class Kind { text, real, int16, int32, int64, flag, chunk, invalid };

Kind kind_of(int code) {
  const auto in = [code](int lo, int hi) { return code >= lo && code <= hi; };
  if (in(0, 9) || code == 100 || code == 102 || code == 105 || in(300, 309) || in(320, 369) || in(390, 399) ||
      in(410, 419) || in(430, 439) || in(470, 481) || code == 999 || (in(1000, 1009) && code != 1004))
    return Kind::text;
  if (in(10, 59) || in(110, 149) || in(210, 239) || in(460, 469) || in(1010, 1059)) return Kind::real;
  if (in(60, 79) || in(170, 179) || in(270, 289) || in(370, 389) || in(400, 409) || in(1060, 1070)) return Kind::int16;
  if (in(90, 99) || in(420, 429) || in(440, 459) || code == 1071) return Kind::int32;
  if (in(160, 169)) return Kind::int64;
  if (in(290, 299)) return Kind::flag;
  if (in(310, 319) || code == 1004) return Kind::chunk;
  return Kind::invalid;
}

// Little-endian integer of `n` bytes at `p`, sign-extended.
std::int64_t little_endian(const char* p, int n) {
  std::uint64_t v = 0;
  for (int k = n - 1; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(p[k]);
  if (n < 8 && (v >> (8 * n - 1)) != 0) v |= ~std::uint64_t{0} << (8 * n);
  return static_cast<std::int64_t>(v);
}

}  // namespace

bool is_binary_dxf(std::string_view text) { return text.substr(0, 18) == kSentinel.substr(0, 18); }

std::vector<Pair> binary_pairs(std::string_view text, const std::string& source) {
  if (text.substr(0, kSentinel.size()) != kSentinel)
    throw InputError(source, 1, "binary DXF whose sentinel (\"AutoCAD Binary DXF\", CR LF, 0x1a, NUL) is damaged");
  std::size_t at = kSentinel.size();
  // Release 13 and later write 2-byte group codes: the first code, 0, is then two NUL bytes.
  const bool two_byte_codes = text.size() > at + 1 && text[at] == '\0' && text[at + 1] == '\0';
  std::vector<Pair> pairs;
  while (at < text.size()) {
    const int line = 2 * static_cast<int>(pairs.size()) + 1;
    const auto need = [&](std::size_t n, const char* what) {
      if (text.size() - at < n)
        throw InputError(source, line,
                         fmt::format("binary DXF ends inside {} (byte {}): the file is truncated", what, at));
    };
    int code = 0;
    if (two_byte_codes) {
      need(2, "a group code");
      code = static_cast<int>(little_endian(text.data() + at, 2));
      at += 2;
    } else {
      need(1, "a group code");
      code = static_cast<unsigned char>(text[at++]);
      if (code == 255) {
        need(2, "a group code");
        code = static_cast<int>(little_endian(text.data() + at, 2));
        at += 2;
      }
    }
    const Kind kind = kind_of(code);
    if (kind == Kind::invalid)
      throw InputError(source, line, fmt::format("binary DXF: {} is not a DXF group code (byte {})", code, at));
    const auto value_of = [&]() -> std::string {
      const std::string what = fmt::format("the value of group code {}", code);
      switch (kind) {
        case Kind::text: {
          const std::size_t end = text.find('\0', at);
          if (end == std::string_view::npos) need(text.size() - at + 1, what.c_str());
          std::string v(text.substr(at, end - at));
          at = end + 1;
          return v;
        }
        case Kind::real: {
          need(8, what.c_str());
          std::uint64_t bits = static_cast<std::uint64_t>(little_endian(text.data() + at, 8));
          at += 8;
          return fmt::format("{}", std::bit_cast<double>(bits));
        }
        case Kind::int16: case Kind::int32: case Kind::int64: case Kind::flag: {
          const int n = kind == Kind::int16 ? 2 : kind == Kind::int32 ? 4 : kind == Kind::int64 ? 8 : 1;
          need(static_cast<std::size_t>(n), what.c_str());
          const std::int64_t v = little_endian(text.data() + at, n);
          at += static_cast<std::size_t>(n);
          return std::to_string(kind == Kind::flag ? static_cast<unsigned char>(v) : v);
        }
        case Kind::chunk: {
          need(1, what.c_str());
          const std::size_t n = static_cast<unsigned char>(text[at++]);
          need(n, what.c_str());
          std::string hex;
          for (std::size_t k = 0; k < n; ++k) hex += fmt::format("{:02X}", static_cast<unsigned char>(text[at + k]));
          at += n;
          return hex;
        }
        case Kind::invalid: break;
      }
      return {};
    };
    std::string value = value_of();
    if (value.size() > 2049)
      throw InputError(source, line + 1,
                       fmt::format("value of group code {} is {} characters long; DXF allows 2049", code, value.size()));
    const bool eof = code == 0 && value == "EOF";
    pairs.push_back({code, std::move(value), line});
    if (eof) break;  // whatever follows the end marker is not ours
  }
  return pairs;
}

}  // namespace machplan::dxf
