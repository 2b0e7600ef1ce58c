#include "engine/hardware/backend.h"

namespace machplan::hardware {

const char* to_string(CommandKind k) {
  switch (k) {
    case CommandKind::speed_dac: return "speed_dac";
    case CommandKind::position: return "position";
  }
  return "?";
}

}  // namespace machplan::hardware
