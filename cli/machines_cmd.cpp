// `machplan machines [--json]`: the machines `--machine NAME` can find, the folders searched,
// and what each machine is for (the commands that take it).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/output.h"
#include "models/cutting/machine_config.h"

namespace {

using machplan::cutting::MachineUse;

// The commands a machine of this use serves.
std::vector<std::string> commands_for(MachineUse use) {
  switch (use) {
    case MachineUse::cutting: return {"run", "tune", "guard", "calibrate", "serve"};
    case MachineUse::placement: return {"place", "check"};
    case MachineUse::unreadable: break;
  }
  return {};
}

std::string use_text(const machplan::cutting::MachineEntry& m) {
  if (m.use == MachineUse::unreadable) return "unreadable";
  std::string s = machplan::cutting::to_string(m.use);
  const char* sep = ": ";
  for (const std::string& c : commands_for(m.use)) s += sep + c, sep = ", ";
  return s;
}

void add_machines(CLI::App& app) {
  auto json = std::make_shared<bool>(false);
  auto* cmd = app.add_subcommand("machines",
                                 "List the machines --machine NAME finds, what each is for, and the folders searched, in order");
  cmd->add_flag("--json", *json, "machine-readable output");
  cmd->callback([json] {
    using namespace machplan::cutting;
    const auto folders = machine_folders();
    const auto machines = list_machines();
    if (*json) {
      nlohmann::json j{{"folders", nlohmann::json::array()}, {"machines", nlohmann::json::array()}};
      for (const auto& f : folders) j["folders"].push_back({{"path", f.path}, {"kind", f.kind}, {"exists", f.exists}});
      for (const auto& m : machines)
        j["machines"].push_back({{"name", m.name},
                                 {"path", m.path},
                                 {"kind", m.kind},
                                 {"shadowed", m.shadowed},
                                 {"use", to_string(m.use)},
                                 {"commands", commands_for(m.use)},
                                 {"problem", m.problem.empty() ? nlohmann::json() : nlohmann::json(m.problem)}});
      machplan::cli::print_json(j);
      return;
    }
    std::printf("folders searched by --machine NAME, in order:\n");
    for (const auto& f : folders)
      std::printf("  %-9s %s%s\n", f.kind.c_str(), f.path.c_str(), f.exists ? "" : "  (does not exist)");
    std::printf("machines (name, folder, use: the commands that take it, file):\n");
    if (machines.empty()) std::printf("  none\n");
    for (const auto& m : machines) {
      std::printf("  %-20s %-9s %-45s %s%s\n", m.name.c_str(), m.kind.c_str(), use_text(m).c_str(), m.path.c_str(),
                  m.shadowed ? "  (hidden by an earlier folder)" : "");
      if (!m.problem.empty()) std::printf("      %s\n", m.problem.c_str());
    }
    std::printf("cutting machines run programs (--machine NAME); placement machines are named by a scene's "
                "`machine:`\n");
  });
}

const machplan::cli::Registration reg_machines(65, add_machines);

}  // namespace
