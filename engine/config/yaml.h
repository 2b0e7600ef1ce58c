// Validated access to YAML configuration files (machines, scenes, jobs).
//
// A `Yaml` value wraps a yaml-cpp node together with the file it came from and its key path
// ("workpiece.size[1]"), so every complaint names the file, the line and the key:
//
//   scene.yaml:14: key 'workpiece.size' must be a list of 3 numbers, got a map
//
// Typical use:
//
//   Yaml root = Yaml::load_file("scene.yaml");
//   double clearance = root.optional<double>("safe_distance_mm", 5.0, {.min = 0.0});
//   Eigen::Vector3d size = root.at("workpiece").vec3("size_mm");
//   root.reject_unknown_keys({"safe_distance_mm", "workpiece"});
//
// Unknown keys are errors (a typo must not be a silent guess), which is why readers call
// reject_unknown_keys() on every map they read.
//
// yaml-cpp parses the text; it stays in yaml.cpp, behind Yaml::Node. A Yaml value is cheap to
// copy: copies share the parsed node.
#pragma once

#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/common/error.h"

namespace machplan {

struct NumberRule {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_exclusive = false;
};

class Yaml {
 public:
  // Parses a file; syntax errors become InputError with the file and line.
  static Yaml load_file(const std::string& path);
  // Parses text that came from `name` (used in messages).
  static Yaml load_string(const std::string& text, const std::string& name);

  bool has(const std::string& key) const;
  Yaml at(const std::string& key) const;         // required key of a map
  std::optional<Yaml> get(const std::string& key) const;  // optional key of a map
  std::vector<Yaml> items() const;               // elements of a sequence
  std::vector<std::string> keys() const;         // keys of a map, in the file's order
  bool is_map() const;
  bool is_sequence() const;
  bool is_scalar() const;

  double number(const NumberRule& rule = {}) const;
  int integer(int min = std::numeric_limits<int>::min(), int max = std::numeric_limits<int>::max()) const;
  bool boolean() const;
  std::string string() const;
  std::vector<double> numbers(std::size_t count, const NumberRule& rule = {}) const;  // count 0: any
  Eigen::Vector2d vec2() const;
  Eigen::Vector3d vec3() const;

  // Shorthands for a key of this map.
  double number(const std::string& key, const NumberRule& rule = {}) const { return at(key).number(rule); }
  double number_or(const std::string& key, double fallback, const NumberRule& rule = {}) const;
  std::string string(const std::string& key) const { return at(key).string(); }
  std::string string_or(const std::string& key, const std::string& fallback) const;
  bool boolean_or(const std::string& key, bool fallback) const;
  Eigen::Vector3d vec3(const std::string& key) const { return at(key).vec3(); }

  // Throws naming the first key of this map that is not in `known`.
  void reject_unknown_keys(std::initializer_list<const char*> known) const;
  void reject_unknown_keys(const std::vector<const char*>& known) const;

  // Throws InputError at this node's line with "key 'path' " + message.
  [[noreturn]] void fail(const std::string& message) const;

  const std::string& file() const { return file_; }
  const std::string& key_path() const { return key_path_; }
  int line() const;  // 1-based
  // Resolves a path written in this file relative to the file's folder.
  std::string resolve_path(const std::string& relative) const;

 private:
  struct Node;  // the parsed yaml-cpp node (yaml.cpp)
  Yaml(std::shared_ptr<const Node> node, std::string file, std::string key_path);
  std::string kind_name() const;
  std::shared_ptr<const Node> node_;
  std::string file_;
  std::string key_path_;
};

}  // namespace machplan
