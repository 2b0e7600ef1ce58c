// The command's documentation against the command itself: every subcommand `machplan --help`
// lists (and theirs, for one with subcommands) has its section in docs/cli.md, headed
// "### `machplan SUBCOMMAND`", whose table has one row per flag of `machplan SUBCOMMAND
// --help` (the flag in backticks at the start of the first cell) and no row for a flag the
// command does not have; and the README's command table has one short row per subcommand.
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/cli_run.h"

namespace machplan {
namespace {

std::string source_file(const std::string& name) {
  std::ifstream in(std::string(MACHPLAN_SOURCE_DIR) + "/" + name);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> v;
  std::stringstream ss(text);
  for (std::string l; std::getline(ss, l);) v.push_back(l);
  return v;
}

// CLI11's help: the long flags of the "Options:" section (one option per line that starts
// with two spaces and a dash; wrapped descriptions are indented further), and the names of
// the "Subcommands:" section.
struct Help {
  std::set<std::string> flags;
  std::vector<std::string> subcommands;
};

Help parse_help(const std::string& text) {
  static const std::regex option(R"(^  (?:-[A-Za-z0-9],)?(--[A-Za-z0-9][A-Za-z0-9-]*))");
  static const std::regex subcommand(R"(^  ([a-z][a-z0-9-]*)\s)");
  Help h;
  enum { other, options, subcommands } section = other;
  for (const std::string& l : lines_of(text)) {
    if (l.rfind("Options:", 0) == 0) section = options;
    else if (l.rfind("Subcommands:", 0) == 0) section = subcommands;
    else if (!l.empty() && l[0] != ' ') section = other;
    std::smatch m;
    if (section == options && std::regex_search(l, m, option) && m[1] != "--help") h.flags.insert(m[1]);
    if (section == subcommands && std::regex_search(l, m, subcommand)) h.subcommands.push_back(m[1]);
  }
  return h;
}

// docs/cli.md: per "### `machplan NAME`" section, the flags its table rows start with.
std::map<std::string, std::set<std::string>> parse_docs(const std::string& text) {
  static const std::regex heading(R"(^#{1,3} )");
  static const std::regex section(R"(^### `machplan ([a-z][a-z0-9 -]*)`\s*$)");
  static const std::regex row(R"(^\| *`(--[A-Za-z0-9][A-Za-z0-9-]*))");
  std::map<std::string, std::set<std::string>> docs;
  std::string current;
  for (const std::string& l : lines_of(text)) {
    std::smatch m;
    if (std::regex_search(l, m, section)) {
      current = m[1];
      EXPECT_FALSE(docs.count(current)) << "docs/cli.md: two sections for `machplan " << current << "`";
      docs[current];
    } else if (std::regex_search(l, heading)) {
      current.clear();
    } else if (!current.empty() && std::regex_search(l, m, row)) {
      docs[current].insert(m[1]);
    }
  }
  return docs;
}

// Every subcommand path ("run", "calibrate fit") with its help.
std::map<std::string, Help> every_help() {
  test::Cli cli;
  std::map<std::string, Help> all;
  std::vector<std::string> todo;
  const test::CliResult top = cli.run({"--help"});
  EXPECT_EQ(top.code, 0) << top.err;
  for (const std::string& s : parse_help(top.out).subcommands) todo.push_back(s);
  while (!todo.empty()) {
    const std::string path = todo.back();
    todo.pop_back();
    const test::CliResult r = cli.run(path + " --help");
    EXPECT_EQ(r.code, 0) << path << ": " << r.err;
    Help h = parse_help(r.out);
    for (const std::string& s : h.subcommands) todo.push_back(path + " " + s);
    all[path] = std::move(h);
  }
  return all;
}

TEST(CliDocs, EverySubcommandAndEveryFlagIsDocumented) {
  const auto helps = every_help();
  ASSERT_GE(helps.size(), 15u);  // the subcommands of today, calibrate's included
  ASSERT_TRUE(helps.count("run"));
  ASSERT_TRUE(helps.at("run").flags.count("--machine"));  // the parser reads CLI11's help
  const auto docs = parse_docs(source_file("docs/cli.md"));
  for (const auto& [path, help] : helps) {
    const auto d = docs.find(path);
    if (d == docs.end()) {
      ADD_FAILURE() << "docs/cli.md has no section \"### `machplan " << path << "`\"";
      continue;
    }
    for (const std::string& f : help.flags)
      EXPECT_TRUE(d->second.count(f)) << "docs/cli.md, `machplan " << path << "`: no row for " << f;
    for (const std::string& f : d->second)
      EXPECT_TRUE(help.flags.count(f)) << "docs/cli.md, `machplan " << path << "`: " << f
                                       << " is documented but `machplan " << path << " --help` has no such flag";
  }
  for (const auto& [path, flags] : docs)
    EXPECT_TRUE(helps.count(path)) << "docs/cli.md documents `machplan " << path << "`, which is no subcommand";
}

TEST(CliDocs, TheReadmeHasOneShortLinePerCommand) {
  const auto helps = every_help();
  std::set<std::string> top;
  for (const auto& [path, help] : helps)
    if (path.find(' ') == std::string::npos) top.insert(path);
  static const std::regex row(R"(^\| `machplan ([a-z][a-z0-9-]*)[^`]*` \|)");
  std::set<std::string> listed;
  for (const std::string& l : lines_of(source_file("README.md"))) {
    std::smatch m;
    if (!std::regex_search(l, m, row)) continue;
    listed.insert(m[1]);
    EXPECT_LE(l.size(), 160u) << "README.md: the row of `machplan " << m[1] << "` does not fit a screen: " << l;
  }
  for (const std::string& c : top) EXPECT_TRUE(listed.count(c)) << "README.md: no row for `machplan " << c << "`";
  for (const std::string& c : listed) EXPECT_TRUE(top.count(c)) << "README.md: a row for `machplan " << c << "`, no such subcommand";
}

}  // namespace
}  // namespace machplan
