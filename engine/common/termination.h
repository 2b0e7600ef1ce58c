// When long work ends: a stop request, a deadline or a budget, whichever comes first, and which
// of them it was. Every long computation (placement, checks, rapid planning, runs, guard
// sessions, tuning, fits, calibration recording) takes one `Termination&` the same way, in
// the spirit of OMPL's PlannerTerminationCondition.
//
//   stop request  a StopToken (the CLI sets it on SIGINT, SIGTERM and SIGHUP; the panel on its
//                 stop button). Reason::stop_requested.
//   deadline      seconds of *work*, as the worker charges them: machine time for a run or a
//                 guard session (the servo period per tick), simulated time for a tuning
//                 evaluation, a nominal cost per sample for planners. Never the wall clock: a
//                 deadline that decides an answer must give the same answer on any machine.
//                 Reason::deadline.
//   budget        a count of work units (samples, evaluations, pose queries, periods), named
//                 by the worker that sets it. Reason::budget.
//
// The worker charges what it did and polls should_end() at points where stopping is safe;
// the first reason seen is kept, so a report can say what ended the work. Work made of parts
// gives each part a child with limits of its own:
//
//     Termination run(stop_token);                 // the caller's: a stop request
//     Termination rapid(run);                      // one rapid: ends with `run`, or ...
//     rapid.set_budget(20000, "samples");          // ... after 20000 samples of its own
//     while (!rapid.should_end()) { sample(); rapid.charge(1, 20e-6); }
//     if (rapid.reason() == Termination::Reason::budget) ...   // the rapid's own limit
//
// A child forwards its charges to its parent (so the parent's budget counts all of them) and
// ends when its parent has ended; the parent does not learn the child's own limits.
//
// Threading and real time: charge(), should_end() and reason() take no lock and allocate
// nothing (atomics, relaxed order), so the executor polls once per servo period and several
// threads may charge one object. Limits are set before the work starts, from one thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <string>

#include "engine/common/stop.h"

namespace machplan {

class Termination {
 public:
  enum class Reason { none, stop_requested, deadline, budget };

  // Never ends by itself.
  Termination() = default;
  explicit Termination(StopToken stop) : stop_(stop) {}
  // A part of `parent`'s work (not owned; must outlive this). Not a copy: the child starts
  // with no limits of its own and nothing spent.
  explicit Termination(Termination& parent) : parent_(&parent) {}
  Termination(const Termination&) = delete;
  Termination& operator=(const Termination&) = delete;

  // At most `units` units of work, named for messages ("samples", "evaluations"). > 0.
  Termination& set_budget(std::int64_t units, std::string unit_name);
  // At most `work_s` seconds of work as charged (> 0, finite), named for messages ("machine
  // time", "simulated time").
  Termination& set_deadline(double work_s, std::string clock_name = "work");

  // The worker did `units` units of work worth `work_s` seconds.
  void charge(std::int64_t units, double work_s = 0.0) noexcept;
  // Whether the work must end now; records the reason the first time it is true.
  bool should_end() noexcept;
  // Ends the work as if by a stop request (the executor's own stop button).
  void request_stop() noexcept { end(Reason::stop_requested); }

  // The stop request this work obeys (its own, else its parent's), for an API that takes a
  // StopToken.
  StopToken stop_token() const noexcept { return parent_ && !stop_.bound() ? parent_->stop_token() : stop_; }

  Reason reason() const noexcept { return static_cast<Reason>(reason_.load(std::memory_order_relaxed)); }
  bool ended() const noexcept { return reason() != Reason::none; }
  std::int64_t units_spent() const noexcept { return units_.load(std::memory_order_relaxed); }
  double work_s_spent() const noexcept { return work_s_.load(std::memory_order_relaxed); }
  std::int64_t budget() const noexcept { return budget_; }
  double deadline_s() const noexcept { return deadline_s_; }

  // What ended the work, for a report: "stopped on request", "the budget of 20000 samples
  // was spent", "the deadline of 5 s of machine time was reached"; "" while it runs.
  std::string describe() const;

 private:
  void end(Reason r) noexcept;

  StopToken stop_;
  Termination* parent_ = nullptr;
  std::int64_t budget_ = std::numeric_limits<std::int64_t>::max();
  double deadline_s_ = std::numeric_limits<double>::infinity();
  std::string unit_name_ = "units", clock_name_ = "work";
  std::atomic<std::int64_t> units_{0};
  std::atomic<double> work_s_{0.0};
  std::atomic<int> reason_{0};
  std::atomic<bool> from_parent_{false};  // the parent ended first: describe() is its
};

const char* to_string(Termination::Reason r);

}  // namespace machplan
