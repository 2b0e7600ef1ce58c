// Fuzz target: --json output of arbitrary bytes (cli/json/json_stream.h), as the CLI
// writes names read from files (a DXF layer, a file name) into its documents. Whatever the
// bytes, used as a member name and as string values, compact or pretty, streamed or dumped
// whole: the text must parse as JSON (the parser refuses invalid UTF-8), the replacement flag
// must be set exactly when the bytes are not valid UTF-8 (judged here by a validator of our
// own), and valid text must come back unchanged.
#include <stdio.h>

#include <cstdint>
#include <cstdlib>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/json/json_stream.h"

namespace {

// UTF-8 as RFC 3629 defines it: no overlong forms, no surrogates, nothing above U+10FFFF.
bool valid_utf8(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto b = static_cast<unsigned char>(s[i]);
    int n = 0;
    std::uint32_t cp = 0, min = 0;
    if (b < 0x80) n = 0, cp = b;
    else if ((b & 0xE0) == 0xC0) n = 1, cp = b & 0x1F, min = 0x80;
    else if ((b & 0xF0) == 0xE0) n = 2, cp = b & 0x0F, min = 0x800;
    else if ((b & 0xF8) == 0xF0) n = 3, cp = b & 0x07, min = 0x10000;
    else return false;
    if (i + n >= s.size() + (n == 0)) return false;
    for (int k = 1; k <= n; ++k) {
      const auto c = static_cast<unsigned char>(s[i + k]);
      if ((c & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (c & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += n + 1;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > 4096) return 0;
  const int indent = data[0] % 3 == 0 ? -1 : data[0] % 3;  // compact, 1 or 2 spaces
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  // The first NUL splits a name from a value; without one both are the whole input.
  const std::size_t cut = bytes.find('\0');
  const std::string name = cut == std::string::npos ? bytes : bytes.substr(0, cut);
  const std::string value = cut == std::string::npos ? bytes : bytes.substr(cut + 1);
  const bool valid = valid_utf8(name) && valid_utf8(value);

  char* buffer = nullptr;
  size_t length = 0;
  FILE* out = open_memstream(&buffer, &length);
  if (!out) std::abort();
  bool replaced_stream = false;
  {
    machplan::cli::JsonStream stream(out, indent);
    stream.begin_object();
    stream.member(name, value);
    stream.key("list");
    stream.begin_array();
    stream.value(value);
    stream.value({{"name", name}, {"nested", {value, 1.5, nullptr}}});
    stream.end_array();
    stream.key("empty");
    stream.begin_array();
    stream.end_array();
    stream.end_object();
    if (stream.failed()) std::abort();
    replaced_stream = stream.replaced();
  }
  fclose(out);
  const std::string text(buffer, length);
  free(buffer);

  bool replaced_whole = false;
  const nlohmann::json whole{{name, value}, {"k", {value}}};
  const std::string dumped = machplan::cli::json_dump_utf8(whole, indent, &replaced_whole);

  if (replaced_stream == valid || replaced_whole == valid) std::abort();
  if (text.empty() || text.back() != '\n') std::abort();
  for (const std::string* t : {&text, &dumped}) {
    const nlohmann::json back = nlohmann::json::parse(*t, nullptr, false);
    if (back.is_discarded()) std::abort();
    if (!valid) continue;
    // Valid text round-trips exactly (a repeated member name keeps one of the two values).
    if (!back.contains(name) || (name != "list" && name != "empty" && name != "k" && back[name] != value)) std::abort();
  }
  // Streamed and whole dumps agree on valid input laid out the same way.
  if (valid) {
    const nlohmann::json same{{"a", value}, {"b", {name}}};
    char* b2 = nullptr;
    size_t l2 = 0;
    FILE* o2 = open_memstream(&b2, &l2);
    {
      machplan::cli::JsonStream s2(o2, indent);
      s2.begin_object();
      s2.member("a", value);
      s2.key("b");
      s2.begin_array();
      s2.value(name);
      s2.end_array();
      s2.end_object();
    }
    fclose(o2);
    const std::string streamed(b2, l2);
    free(b2);
    if (streamed != same.dump(indent) + "\n") std::abort();
  }
  return 0;
}
