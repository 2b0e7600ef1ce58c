#include "cli/json/json_stream.h"

#include "engine/common/error.h"

namespace machplan::cli {

std::string json_dump_utf8(const nlohmann::json& j, int indent, bool* replaced) {
  // Strict first: valid text (nearly always) costs one dump and no scan of our own.
  try {
    return j.dump(indent);
  } catch (const nlohmann::json::type_error& e) {
    if (e.id != 316) throw;  // 316: a string that is not valid UTF-8
  }
  if (replaced) *replaced = true;
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

JsonStream::JsonStream(std::FILE* out, int indent) : out_(out), indent_(indent) {}

std::string JsonStream::newline(std::size_t depth) const {
  if (indent_ < 0) return {};
  std::string s(1 + depth * static_cast<std::size_t>(indent_), ' ');
  s.front() = '\n';
  return s;
}

void JsonStream::write(std::string_view text) {
  if (failed_ || text.empty()) return;
  if (std::fwrite(text.data(), 1, text.size(), out_) != text.size() || std::ferror(out_)) failed_ = true;
}

void JsonStream::before_item(bool is_key) {
  if (levels_.empty()) {
    MACHPLAN_ASSERT(!is_key, "JsonStream: a key outside any object");
    return;
  }
  Level& level = levels_.back();
  if (level.object && !is_key) {
    MACHPLAN_ASSERT(after_key_, "JsonStream: a value inside an object needs its key first");
    after_key_ = false;
    return;
  }
  MACHPLAN_ASSERT(level.object == is_key && !after_key_, "JsonStream: {} where {} is due", is_key ? "a key" : "a value",
                  level.object ? "a key" : "a value");
  if (!level.empty) write(",");
  write(newline(levels_.size()));
  level.empty = false;
}

void JsonStream::begin_object() {
  before_item(false);
  write("{");
  levels_.push_back({true});
}

void JsonStream::begin_array() {
  before_item(false);
  write("[");
  levels_.push_back({false});
}

void JsonStream::end_object() {
  MACHPLAN_ASSERT(!levels_.empty() && levels_.back().object && !after_key_, "JsonStream: unbalanced end_object");
  const bool empty = levels_.back().empty;
  levels_.pop_back();
  write(empty ? "}" : newline(levels_.size()) + "}");
  if (levels_.empty()) finish();
}

void JsonStream::end_array() {
  MACHPLAN_ASSERT(!levels_.empty() && !levels_.back().object, "JsonStream: unbalanced end_array");
  const bool empty = levels_.back().empty;
  levels_.pop_back();
  write(empty ? "]" : newline(levels_.size()) + "]");
  if (levels_.empty()) finish();
}

void JsonStream::finish() {
  write("\n");
  if (!failed_ && (std::fflush(out_) != 0 || std::ferror(out_))) failed_ = true;
}

void JsonStream::key(std::string_view name) {
  before_item(true);
  write(json_dump_utf8(nlohmann::json(std::string(name)), -1, &replaced_));
  write(indent_ < 0 ? ":" : ": ");
  after_key_ = true;
}

void JsonStream::value(const nlohmann::json& j) {
  before_item(false);
  std::string text = json_dump_utf8(j, indent_, &replaced_);
  if (indent_ >= 0 && !levels_.empty()) {
    // A pretty nested value starts at the current depth: indent its inner lines to match.
    // A newline inside the text is always layout (JSON strings escape theirs).
    const std::string pad = newline(levels_.size());
    std::string shifted;
    shifted.reserve(text.size());
    for (const char c : text) {
      if (c == '\n') shifted += pad;
      else shifted += c;
    }
    text = std::move(shifted);
  }
  write(text);
  if (levels_.empty()) finish();
}

}  // namespace machplan::cli
