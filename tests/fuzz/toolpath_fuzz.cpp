// Fuzz target for the tool-path readers: the same bytes go through the APT reader, the CSV
// reader, the sniffing reader and the G-code job reader (through the G-code interpreter). Bad input must come back as InputError; anything else (a
// crash, a sanitizer report, another exception) is a finding.
#include <cstddef>
#include <cstdint>
#include <cmath>
#include <string>
#include <string_view>

#include "engine/common/error.h"
#include "engine/programs/gcode.h"
#include "engine/programs/toolpath.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  machplan::ToolPathReadOptions options;
  options.max_poses = 100000;
  options.max_line_bytes = 4096;
  options.max_statement_bytes = 16384;
  auto attempt = [&](auto&& read) {
    try {
      const machplan::ToolPath path = read();
      const machplan::ToolPathSummary s = machplan::summarize(path);
      if (s.poses != path.poses.size()) __builtin_trap();
      for (const auto& pose : path.poses) {
        if (!pose.tip_mm.allFinite() || std::abs(pose.axis.norm() - 1.0) > 1e-9) __builtin_trap();
        if (pose.tool < -1 || pose.tool >= static_cast<int>(path.tools.size())) __builtin_trap();
      }
    } catch (const machplan::InputError&) {
    }
  };
  attempt([&] { return machplan::read_apt(text, "fuzz.cl", options); });
  attempt([&] { return machplan::read_toolpath_csv(text, "fuzz.csv", options); });
  attempt([&] { return machplan::read_toolpath(text, "fuzz", options); });
  attempt([&] { return machplan::toolpath_from_gcode(machplan::read_gcode(std::string(text), "fuzz.ngc"), options); });
  return 0;
}
