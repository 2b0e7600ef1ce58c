// How a solve ended, in one shape for every solver (placement, rapids, run, guard, tune, fit),
// after Ceres' Solver::Summary: a status, a message, and a brief and a full report.
//
//   done        the work ran to its end and the answer is in the result
//   infeasible  the input is well formed but has no answer (no placement is free, a fit the
//               log does not determine, a rapid with no clear route)
//   faulted     a run on a machine ended in a fault (torch off, controlled stop)
//   cancelled   a stop request ended the work (signals, the panel's stop)
//   deadline    the work's deadline (seconds of work, engine/common/termination.h) ran out
//   budget      the work's budget (samples, evaluations, pose queries) was spent
//
// Anything but `done` is not a measurement: a result whose summary is not done never reports
// an error figure or a ratio as if it had been measured (it reports what it has, labelled).
//
// A usable answer (Ceres' "usable solution"): a search that improves an answer it already
// holds (a tuning, say) may be ended by its deadline or budget with an answer that meets every
// constraint, only not the best it could have found. Its status stays deadline or budget, so
// that the report says what ended it, and `usable` is set: usable_answer() is then true and
// exit_code() 0. Only deadline and budget may be usable; a stop request (cancelled) never is,
// and nor is work that has no answer yet when it ends (a placement, a fit, a run).
//
// The solver fills the reports once, at the end, from its result: brief_report() is one line
// for a list or a log, full_report() what `machplan` prints for people. The CLI prints them and
// does not format results itself; exit_code() is what the CLI returns for it (0 done or a
// usable answer, 3 any other ending: the job could not be done as asked).
#pragma once

#include <string>

#include "engine/common/termination.h"

namespace machplan {

enum class Status { done, infeasible, faulted, cancelled, deadline, budget };

// "done", "infeasible", "faulted", "cancelled", "deadline", "budget".
const char* to_string(Status s);
// The status for work a Termination ended: stop_requested -> cancelled, deadline, budget;
// none -> done.
Status status_of(Termination::Reason r);

struct Summary {
  Status status = Status::done;
  // Why it ended so, one sentence (empty for done with nothing to add).
  std::string message;
  // deadline or budget only: the answer in the result is usable (see the file comment).
  bool usable = false;
  // Filled by the solver when the work is over.
  std::string brief;
  std::string full;

  bool done() const { return status == Status::done; }
  // The result holds an answer to use: done, or ended early with a usable one.
  bool usable_answer() const { return done() || (usable && (status == Status::deadline || status == Status::budget)); }
  const std::string& brief_report() const { return brief; }
  const std::string& full_report() const { return full; }
  int exit_code() const { return usable_answer() ? 0 : 3; }
};

// The status as a report's headline shows it: to_string(status), and " (usable)" after a
// deadline or budget that left a usable answer.
std::string status_text(const Summary& summary);

}  // namespace machplan
