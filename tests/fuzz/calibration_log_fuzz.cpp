// Fuzz target for the calibration session log reader: any input must give a log or an
// InputError. Anything else (a crash, a sanitizer report, another exception, a hang) is a bug.
// A log that reads is written back and read again: it must give the same samples; a small
// one is also fitted, which must end in a result (any status) or an InputError.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string_view>

#include "engine/calibration/session_log.h"
#include "engine/common/error.h"
#include "models/cutting/machine_config.h"
#include "solvers/calibration/fit.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  using namespace machplan::calibration;
  SessionLog log;
  try {
    log = read_session_log_text(text, "fuzz.csv");
  } catch (const machplan::InputError&) {
    return 0;  // clean rejection of a malformed log
  }
  if (log.samples.size() <= 400) {
    static const auto machine = [] {
      try {
        return machplan::cutting::load_machine(machplan::cutting::find_machine("thermal_gantry"));
      } catch (const machplan::InputError&) {
        return machplan::cutting::MachineConfig{};  // not run from the source tree: no fit
      }
    }();
    if (!machine.name.empty()) {
      try {
        const auto fit = fit_session(log, machine);
        (void)fit.json();
      } catch (const machplan::InputError&) {
      }
    }
  }
  std::ostringstream out;
  write_session_log(out, log);
  try {
    const SessionLog again = read_session_log_text(out.str(), "again.csv");
    if (again.samples.size() != log.samples.size()) __builtin_trap();
    for (std::size_t k = 0; k < log.samples.size(); ++k) {
      const auto &a = log.samples[k], &b = again.samples[k];
      if (a.axis != b.axis || a.dac != b.dac || a.counter != b.counter || a.direction_negative != b.direction_negative ||
          a.has_ref != b.has_ref)
        __builtin_trap();
    }
  } catch (const machplan::InputError&) {
    // Times closer than the written microsecond may collapse into "time stands still";
    // that is the writer's documented precision, not a reader bug.
  }
  return 0;
}
