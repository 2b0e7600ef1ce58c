// Fuzz target for the G-code reader: any input must either give a Program or throw
// machplan::InputError. Any other exception, a crash, a hang or unbounded memory is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  machplan::GcodeOptions options;
  options.max_moves = 100'000;  // keep each run small; the limit itself is exercised
  options.max_arc_turns = 1000;
  options.max_executed_lines = 100'000;  // loops and calls: keep each run short
  options.spindle_count = 3;
  options.params["_hal[plasmac.cut-feed-rate]"] = 2000;
  for (bool require_end : {true, false}) {
    options.require_program_end = require_end;
    try {
      const machplan::Program p = machplan::read_gcode(text, "fuzz.ngc", options);
      (void)machplan::summarize(p);
    } catch (const machplan::InputError&) {
    }
  }
  // The other dialects: GRBL, and the detection between the two.
  options.require_program_end = true;
  for (machplan::GcodeDialect d : {machplan::GcodeDialect::grbl, machplan::GcodeDialect::automatic}) {
    options.dialect = d;
    try {
      (void)machplan::read_gcode(text, "fuzz.ngc", options);
    } catch (const machplan::InputError&) {
    }
  }
  return 0;
}
