// JSON output that is always valid UTF-8 and need not be held in memory.
//
//   * json_dump_utf8(j) is j.dump() that never throws on text: nlohmann's dump() refuses a
//     string that is not valid UTF-8 (a Latin-1 layer name in a DXF, a file name in a legacy
//     encoding); here each invalid byte becomes U+FFFD instead and *replaced is set, so that
//     the caller can say so. Valid text is written byte for byte as dump() writes it.
//   * JsonStream writes one document piece by piece to a FILE: an object's members and an
//     array's elements are written as they come, each element a small nlohmann::json dumped
//     with json_dump_utf8, so memory does not grow with the document (a million program moves
//     are a million small writes, not a 900 MB string). It checks every write: after the
//     first failed write (a full disk, a closed pipe) failed() is true and nothing more is
//     written, so long producers can stop early; the caller turns that into an error.
//
// Example:
//
//     JsonStream out(stdout);
//     out.begin_object();
//     out.member("units", "mm");
//     out.key("moves");
//     out.begin_array();
//     for (const Move& m : moves) {
//       out.value(move_json(m));
//       if (out.failed()) break;
//     }
//     out.end_array();
//     out.end_object();  // also writes the final newline
//
// Misuse (a value where a key is due, unbalanced begin/end) throws InternalError.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace machplan::cli {

std::string json_dump_utf8(const nlohmann::json& j, int indent = -1, bool* replaced = nullptr);

class JsonStream {
 public:
  // `out` is not owned. indent < 0: compact, one line; else pretty, `indent` spaces a level.
  explicit JsonStream(std::FILE* out, int indent = -1);
  JsonStream(const JsonStream&) = delete;
  JsonStream& operator=(const JsonStream&) = delete;

  void begin_object();
  void end_object();
  void begin_array();
  void end_array();
  // Inside an object: the next member's name.
  void key(std::string_view name);
  // A whole value: an array element, or the value after key().
  void value(const nlohmann::json& j);
  void member(std::string_view name, const nlohmann::json& j) {
    key(name);
    value(j);
  }

  // Some text was not valid UTF-8 and had bytes replaced by U+FFFD.
  bool replaced() const { return replaced_; }
  // A write failed; nothing has been written since.
  bool failed() const { return failed_; }

 private:
  struct Level {
    bool object;
    bool empty = true;
  };
  void before_item(bool is_key);
  void write(std::string_view text);
  void finish();  // the document is complete: newline and flush
  std::string newline(std::size_t depth) const;

  std::FILE* out_;
  int indent_;
  std::vector<Level> levels_;
  bool after_key_ = false, replaced_ = false, failed_ = false;
};

}  // namespace machplan::cli
