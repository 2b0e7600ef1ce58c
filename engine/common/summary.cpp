#include "engine/common/summary.h"

namespace machplan {

const char* to_string(Status s) {
  switch (s) {
    case Status::done: return "done";
    case Status::infeasible: return "infeasible";
    case Status::faulted: return "faulted";
    case Status::cancelled: return "cancelled";
    case Status::deadline: return "deadline";
    case Status::budget: return "budget";
  }
  return "?";
}

std::string status_text(const Summary& s) {
  return std::string(to_string(s.status)) + (s.usable_answer() && !s.done() ? " (usable)" : "");
}

Status status_of(Termination::Reason r) {
  switch (r) {
    case Termination::Reason::none: return Status::done;
    case Termination::Reason::stop_requested: return Status::cancelled;
    case Termination::Reason::deadline: return Status::deadline;
    case Termination::Reason::budget: return Status::budget;
  }
  return Status::done;
}

}  // namespace machplan
