#include "engine/config/yaml.h"

#include <cmath>
#include <filesystem>

#include <yaml-cpp/yaml.h>

#include "engine/common/text_file.h"

namespace machplan {

struct Yaml::Node {
  YAML::Node yaml;
};

Yaml Yaml::load_file(const std::string& path) { return load_string(read_text_file(path, 64u << 20), path); }

namespace {
// yaml-cpp parses nesting by recursion; a hostile file could nest deep enough to overflow the
// stack. Configuration files never nest more than a few levels, so refuse deep nesting first.
void check_nesting(const std::string& text, const std::string& name) {
  constexpr int kMaxDepth = 64;
  int depth = 0, line = 1, dashes = 0;
  bool line_start = true;
  for (char ch : text) {
    if (ch == '\n') {
      ++line, dashes = 0, line_start = true;
      continue;
    }
    if (ch == '[' || ch == '{') ++depth;
    if ((ch == ']' || ch == '}') && depth > 0) --depth;
    if (line_start && ch == '-') ++dashes;
    else if (ch != ' ' && ch != '\t') line_start = false;
    if (depth > kMaxDepth || dashes > kMaxDepth)
      throw InputError(name, line, fmt::format("nesting deeper than {} levels", kMaxDepth));
  }
}
}  // namespace

Yaml Yaml::load_string(const std::string& text, const std::string& name) {
  check_nesting(text, name);
  try {
    YAML::Node root = YAML::Load(text);
    if (!root.IsDefined() || root.IsNull()) throw InputError(name, 0, "the file is empty");
    return Yaml(std::make_shared<const Node>(Node{root}), name, "");
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.is_null() ? 0 : e.mark.line + 1, "YAML syntax error: " + e.msg);
  }
}

Yaml::Yaml(std::shared_ptr<const Node> node, std::string file, std::string key_path)
    : node_(std::move(node)), file_(std::move(file)), key_path_(std::move(key_path)) {}

bool Yaml::is_map() const { return node_->yaml.IsMap(); }
bool Yaml::is_sequence() const { return node_->yaml.IsSequence(); }
bool Yaml::is_scalar() const { return node_->yaml.IsScalar(); }

int Yaml::line() const {
  const YAML::Mark m = node_->yaml.Mark();
  return m.is_null() ? 0 : m.line + 1;
}

void Yaml::fail(const std::string& message) const {
  const std::string who = key_path_.empty() ? std::string("the document") : "key '" + key_path_ + "'";
  throw InputError(file_, line(), who + " " + message);
}

std::string Yaml::kind_name() const {
  switch (node_->yaml.Type()) {
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Scalar: return "'" + excerpt(node_->yaml.Scalar()) + "'";
    case YAML::NodeType::Null: return "nothing";
    default: return "an undefined value";
  }
}

bool Yaml::has(const std::string& key) const { return node_->yaml.IsMap() && node_->yaml[key].IsDefined(); }

Yaml Yaml::at(const std::string& key) const {
  const std::string path = key_path_.empty() ? key : key_path_ + "." + key;
  if (!node_->yaml.IsMap()) fail("must be a map with key '" + key + "', got " + kind_name());
  YAML::Node child = node_->yaml[key];
  if (!child.IsDefined()) {
    throw InputError(file_, line(), "missing required key '" + path + "'");
  }
  return Yaml(std::make_shared<const Node>(Node{child}), file_, path);
}

std::optional<Yaml> Yaml::get(const std::string& key) const {
  if (!has(key)) return std::nullopt;
  return at(key);
}

std::vector<Yaml> Yaml::items() const {
  if (!node_->yaml.IsSequence()) fail("must be a list, got " + kind_name());
  std::vector<Yaml> out;
  out.reserve(node_->yaml.size());
  for (std::size_t i = 0; i < node_->yaml.size(); ++i) {
    const std::string path = key_path_ + "[" + std::to_string(i) + "]";
    out.push_back(Yaml(std::make_shared<const Node>(Node{node_->yaml[i]}), file_, path));
  }
  return out;
}

std::vector<std::string> Yaml::keys() const {
  if (!node_->yaml.IsMap()) fail("must be a map, got " + kind_name());
  std::vector<std::string> out;
  for (auto it = node_->yaml.begin(); it != node_->yaml.end(); ++it) {
    if (!it->first.IsScalar()) fail("has a key that is not a name");
    out.push_back(it->first.Scalar());
  }
  return out;
}

double Yaml::number(const NumberRule& rule) const {
  if (!node_->yaml.IsScalar()) fail("must be a number, got " + kind_name());
  const std::string& s = node_->yaml.Scalar();
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;  // no number at all, or one beyond double's range
  }
  if (used == 0 || used != s.size()) fail("must be a number, got '" + excerpt(s) + "'");
  if (!std::isfinite(v)) fail("must be a finite number, got '" + excerpt(s) + "'");
  if (v < rule.min || (rule.min_exclusive && v == rule.min))
    fail(fmt::format("must be {} {}, got {}", rule.min_exclusive ? ">" : ">=", rule.min, v));
  if (v > rule.max) fail(fmt::format("must be <= {}, got {}", rule.max, v));
  return v;
}

int Yaml::integer(int min, int max) const {
  const double v = number();
  if (v != std::floor(v)) fail(fmt::format("must be a whole number, got {}", v));
  if (v < min || v > max) fail(fmt::format("must be between {} and {}, got {}", min, max, v));
  return static_cast<int>(v);
}

bool Yaml::boolean() const {
  if (!node_->yaml.IsScalar()) fail("must be true or false, got " + kind_name());
  const std::string& s = node_->yaml.Scalar();
  if (s == "true" || s == "yes" || s == "on") return true;
  if (s == "false" || s == "no" || s == "off") return false;
  fail("must be true or false, got '" + excerpt(s) + "'");
}

std::string Yaml::string() const {
  if (!node_->yaml.IsScalar()) fail("must be a text value, got " + kind_name());
  return node_->yaml.Scalar();
}

std::vector<double> Yaml::numbers(std::size_t count, const NumberRule& rule) const {
  if (!node_->yaml.IsSequence() || (count != 0 && node_->yaml.size() != count))
    fail(count ? fmt::format("must be a list of {} numbers, got {}", count, kind_name())
               : "must be a list of numbers, got " + kind_name());
  std::vector<double> out;
  for (const Yaml& item : items()) out.push_back(item.number(rule));
  return out;
}

Eigen::Vector2d Yaml::vec2() const {
  const auto v = numbers(2);
  return {v[0], v[1]};
}

Eigen::Vector3d Yaml::vec3() const {
  const auto v = numbers(3);
  return {v[0], v[1], v[2]};
}

double Yaml::number_or(const std::string& key, double fallback, const NumberRule& rule) const {
  return has(key) ? at(key).number(rule) : fallback;
}

std::string Yaml::string_or(const std::string& key, const std::string& fallback) const {
  return has(key) ? at(key).string() : fallback;
}

bool Yaml::boolean_or(const std::string& key, bool fallback) const {
  return has(key) ? at(key).boolean() : fallback;
}

void Yaml::reject_unknown_keys(std::initializer_list<const char*> known) const {
  reject_unknown_keys(std::vector<const char*>(known));
}

void Yaml::reject_unknown_keys(const std::vector<const char*>& known) const {
  if (!node_->yaml.IsMap()) fail("must be a map, got " + kind_name());
  for (auto it = node_->yaml.begin(); it != node_->yaml.end(); ++it) {
    const std::string key = it->first.Scalar();
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok) {
      std::string list;
      for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      const YAML::Mark m = it->first.Mark();
      const std::string path = key_path_.empty() ? key : key_path_ + "." + key;
      throw InputError(file_, m.is_null() ? line() : m.line + 1,
                       "unknown key '" + excerpt(path) + "' (known keys here: " + list + ")");
    }
  }
}

std::string Yaml::resolve_path(const std::string& relative) const {
  std::filesystem::path p(relative);
  if (p.is_absolute()) return p.string();
  return (std::filesystem::path(file_).parent_path() / p).lexically_normal().string();
}

}  // namespace machplan
