// Fuzz target: the nesting job file (solvers/nesting/nest_job.h). Any input must end in a request
// or in machplan::InputError; anything else is a bug. The part files it names are looked for in
// a folder that does not exist.
#include <cstdint>
#include <string>

#include "engine/common/error.h"
#include "solvers/nesting/nest_job.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    machplan::nesting::read_nest_job(machplan::Yaml::load_string(text, "fuzz.yaml"), "/nonexistent-machplan-fuzz");
  } catch (const machplan::InputError&) {
  }
  return 0;
}
