#include "models/common/tooling.h"

namespace machplan {

std::vector<ToolPart> tool_stack(const Tooling& t) {
  const double r = t.tool_diameter_mm / 2;
  std::vector<ToolPart> parts;
  parts.push_back({"tool flutes", 0.0, t.flute_length_mm, r, t.ball_end(), ToolPart::Class::cutting});
  // All flutes (a drill as long as its stick-out) has no shank out of the chuck.
  if (t.stick_out_mm > t.flute_length_mm)
    parts.push_back({"tool shank", t.flute_length_mm, t.stick_out_mm, r, false, ToolPart::Class::class1});
  parts.push_back({"chuck", t.stick_out_mm, t.stick_out_mm + t.chuck_length_mm, t.chuck_diameter_mm / 2, false,
                   ToolPart::Class::class1});
  return parts;
}

}  // namespace machplan
