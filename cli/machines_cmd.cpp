// `machplan machines [--json]`: the machines `--machine NAME` can find, and the folders searched.
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/output.h"
#include "models/cutting/machine_config.h"

namespace {

void add_machines(CLI::App& app) {
  auto json = std::make_shared<bool>(false);
  auto* cmd = app.add_subcommand("machines",
                                 "List the machines --machine NAME finds and the folders it searches, in order");
  cmd->add_flag("--json", *json, "machine-readable output");
  cmd->callback([json] {
    using namespace machplan::cutting;
    const auto folders = machine_folders();
    const auto machines = list_machines();
    if (*json) {
      nlohmann::json j{{"folders", nlohmann::json::array()}, {"machines", nlohmann::json::array()}};
      for (const auto& f : folders) j["folders"].push_back({{"path", f.path}, {"kind", f.kind}, {"exists", f.exists}});
      for (const auto& m : machines)
        j["machines"].push_back({{"name", m.name}, {"path", m.path}, {"kind", m.kind}, {"shadowed", m.shadowed}});
      machplan::cli::print_json(j);
      return;
    }
    std::printf("folders searched by --machine NAME, in order:\n");
    for (const auto& f : folders)
      std::printf("  %-9s %s%s\n", f.kind.c_str(), f.path.c_str(), f.exists ? "" : "  (does not exist)");
    std::printf("machines:\n");
    if (machines.empty()) std::printf("  none\n");
    for (const auto& m : machines)
      std::printf("  %-20s %-9s %s%s\n", m.name.c_str(), m.kind.c_str(), m.path.c_str(),
                  m.shadowed ? "  (hidden by an earlier folder)" : "");
  });
}

const machplan::cli::Registration reg(65, add_machines);

}  // namespace
