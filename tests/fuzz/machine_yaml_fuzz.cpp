// Fuzz target: YAML machine configuration (yaml-cpp plus machplan's validation). Any input must
// end in a machine or in machplan::InputError; anything else is a bug.
#include <cstdint>
#include <string>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "models/hexam/hexam.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    machplan::hexam::Machine m = machplan::hexam::machine_from_yaml(machplan::Yaml::load_string(text, "fuzz.yaml"));
    machplan::hexam::attach_tooling(m, machplan::hexam::Tooling{});
  } catch (const machplan::InputError&) {
  }
  return 0;
}
