#include "engine/common/termination.h"

#include <cmath>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan {

Termination& Termination::set_budget(std::int64_t units, std::string unit_name) {
  MACHPLAN_ASSERT(units > 0, "a budget of {} {}", units, unit_name);
  budget_ = units;
  unit_name_ = std::move(unit_name);
  return *this;
}

Termination& Termination::set_deadline(double work_s, std::string clock_name) {
  MACHPLAN_ASSERT(std::isfinite(work_s) && work_s > 0, "a deadline of {} s of {}", work_s, clock_name);
  deadline_s_ = work_s;
  clock_name_ = std::move(clock_name);
  return *this;
}

void Termination::charge(std::int64_t units, double work_s) noexcept {
  units_.fetch_add(units, std::memory_order_relaxed);
  if (work_s != 0.0) work_s_.fetch_add(work_s, std::memory_order_relaxed);
  if (parent_) parent_->charge(units, work_s);
}

void Termination::end(Reason r) noexcept {
  int none = static_cast<int>(Reason::none);
  reason_.compare_exchange_strong(none, static_cast<int>(r), std::memory_order_relaxed);
}

bool Termination::should_end() noexcept {
  if (ended()) return true;
  if (stop_.stop_requested()) end(Reason::stop_requested);
  else if (units_.load(std::memory_order_relaxed) >= budget_) end(Reason::budget);
  else if (work_s_.load(std::memory_order_relaxed) >= deadline_s_) end(Reason::deadline);
  else if (parent_ && parent_->should_end()) {
    from_parent_.store(true, std::memory_order_relaxed);
    end(parent_->reason());
  }
  return ended();
}

std::string Termination::describe() const {
  if (parent_ && from_parent_.load(std::memory_order_relaxed)) return parent_->describe();
  switch (reason()) {
    case Reason::none: return "";
    case Reason::stop_requested: return "stopped on request";
    case Reason::budget: return fmt::format("the budget of {} {} was spent", budget_, unit_name_);
    case Reason::deadline: return fmt::format("the deadline of {:g} s of {} was reached", deadline_s_, clock_name_);
  }
  return "";
}

const char* to_string(Termination::Reason r) {
  switch (r) {
    case Termination::Reason::none: return "none";
    case Termination::Reason::stop_requested: return "stop_requested";
    case Termination::Reason::deadline: return "deadline";
    case Termination::Reason::budget: return "budget";
  }
  return "?";
}

}  // namespace machplan
