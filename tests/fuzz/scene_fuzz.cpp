// Fuzz target: the placement scene reader (solvers/placement/scene/scene.h), YAML plus machplan's
// checks and bounds. The scene text comes from the fuzzer; the files it names are found in
// tests/fuzz/scene_files/ (the bundled HexaM machine through a link, a small tool path, a CL
// file that changes tools), so
// that seeds load completely and mutations reach every key. Any input must end in a scene
// within the documented bounds or in machplan::InputError; anything else is a bug.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "engine/common/error.h"
#include "solvers/placement/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 16 * 1024) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Seeds name only files beside them; a mutation could name any file on the machine (the
  // 123k-pose bundled tool path, a device): keep each run to the fixture folder.
  if (text.find('/') != std::string::npos) return 0;
  using namespace machplan::placement;
  try {
    const Scene s = load_scene_text(text, std::string(MACHPLAN_SOURCE_DIR) + "/tests/fuzz/scene_files/fuzz.yaml");
    // The reader's promises to the checker.
    if (!(s.safe_distance_mm >= 0 && s.safe_distance_mm <= 1000)) std::abort();
    if (s.peripherals.size() > kMaxPeripherals) std::abort();
    if (s.tips_mm.empty() || s.tips_mm.size() != s.axes.size() || s.feeds_mm_per_min.size() != s.tips_mm.size()) std::abort();
    for (double f : s.feeds_mm_per_min)
      if (!(f >= 0 && std::isfinite(f))) std::abort();
    if (!(s.search.max_pose_queries >= 1)) std::abort();
    if (!(s.search.pad_max_mm >= 0 && s.search.pad_max_mm <= kMaxSceneSizeMm)) std::abort();
    for (const auto& p : s.peripherals)
      if (!p.bounds.min().allFinite() || !p.bounds.max().allFinite()) std::abort();
    // Every pose in one run, in order, each run's tool with its model.
    if (s.tools.empty() || s.runs.empty() || s.runs.front().first != 0 || s.runs.back().end != s.tips_mm.size()) std::abort();
    for (std::size_t k = 0; k < s.runs.size(); ++k) {
      const ToolRun& r = s.runs[k];
      if (r.tool < 0 || r.tool >= static_cast<int>(s.tools.size()) || r.end <= r.first) std::abort();
      if (k > 0 && s.runs[k - 1].end != r.first) std::abort();
    }
    for (const SceneTool& t : s.tools)
      if (!t.model || !(t.tooling.flute_length_mm <= t.tooling.stick_out_mm)) std::abort();
  } catch (const machplan::InputError&) {
  }
  return 0;
}
