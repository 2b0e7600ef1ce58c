#include "solvers/tuning/optimizer.h"

#include <nlopt.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "engine/common/error.h"

namespace machplan::tuning {
namespace {

using Clock = std::chrono::steady_clock;

const char* stop_words(nlopt_result r) {
  switch (r) {
    case NLOPT_SUCCESS: return "converged";
    case NLOPT_STOPVAL_REACHED: return "objective target reached";
    case NLOPT_FTOL_REACHED: return "objective tolerance reached";
    case NLOPT_XTOL_REACHED: return "x tolerance reached";
    case NLOPT_MAXEVAL_REACHED: return "evaluation budget reached";
    case NLOPT_MAXTIME_REACHED: return "time limit reached";
    case NLOPT_FAILURE: return "NLopt failure";
    case NLOPT_INVALID_ARGS: return "NLopt: invalid arguments";
    case NLOPT_OUT_OF_MEMORY: return "NLopt: out of memory";
    case NLOPT_ROUNDOFF_LIMITED: return "round-off limited";
    case NLOPT_FORCED_STOP: return "stopped";
    default: return "unknown";
  }
}

// The state both stages share: the mapping, the counting, the cache and the best points.
struct Run {
  const Problem& p;
  const OptimizerOptions& o;
  Termination& termination;
  Clock::time_point t0;
  std::size_t n;
  int evaluations = 0;
  bool stopped = false, budget_hit = false;
  // Cache of the last point (NLopt asks for f and g at the same x in two calls).
  std::vector<double> last_u;
  double last_f = 0.0;
  std::vector<double> last_g;
  // Best feasible, and least violating.
  std::vector<double> best_u, best_g, least_u, least_g;
  double best_f = std::numeric_limits<double>::infinity();
  double least_violation = std::numeric_limits<double>::infinity(), least_f = 0.0;
  nlopt_opt current = nullptr;

  Run(const Problem& p, const OptimizerOptions& o, Termination& t) : p(p), o(o), termination(t), n(p.parameters.size()) {}
  bool ended() const { return termination.should_end(); }

  std::vector<double> to_x(const double* u) const {
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Parameter& q = p.parameters[i];
      const double t = std::clamp(u[i], 0.0, 1.0);
      x[i] = q.log_scale ? q.lo * std::pow(q.hi / q.lo, t) : q.lo + t * (q.hi - q.lo);
    }
    return x;
  }
  double to_u(std::size_t i, double x) const {
    const Parameter& q = p.parameters[i];
    return q.log_scale ? std::log(x / q.lo) / std::log(q.hi / q.lo) : (x - q.lo) / (q.hi - q.lo);
  }

  void eval(const double* u) {
    if (!last_u.empty() && std::equal(u, u + n, last_u.begin())) return;
    if (evaluations >= o.max_evaluations) {
      // The budget is spent (DIRECT samples a whole division before it looks at maxeval): no
      // more evaluations; a point no stage will keep, and the stage stops.
      budget_hit = true;
      last_u.assign(u, u + n);
      last_g.assign(static_cast<std::size_t>(p.constraint_count), 1e6);
      last_f = 1e9;
      if (current) nlopt_force_stop(current);
      return;
    }
    last_u.assign(u, u + n);
    last_g.assign(static_cast<std::size_t>(p.constraint_count), 0.0);
    last_f = p.evaluate(to_x(u), last_g);
    ++evaluations;
    double violation = 0.0;
    for (double& g : last_g) {
      if (!std::isfinite(g)) g = 1e6;
      violation += std::max(0.0, g);
    }
    if (!std::isfinite(last_f)) {
      last_f = 1e9;
      violation += 1e6;
    }
    if (violation <= 0.0 && last_f < best_f) {
      best_f = last_f;
      best_u = last_u;
      best_g = last_g;
    }
    if (violation < least_violation || (violation == least_violation && last_f < least_f)) {
      least_violation = violation;
      least_f = last_f;
      least_u = last_u;
      least_g = last_g;
    }
    if (current && ended()) {
      stopped = true;
      nlopt_force_stop(current);
    }
  }
  double penalised() const {
    double v = 0.0;
    for (double g : last_g) v += std::max(0.0, g);
    return last_f + o.penalty * v;
  }
  double elapsed_s() const { return std::chrono::duration<double>(Clock::now() - t0).count(); }
};

double penalised_f(unsigned, const double* u, double*, void* data) {
  auto* r = static_cast<Run*>(data);
  r->eval(u);
  return r->penalised();
}
double plain_f(unsigned, const double* u, double*, void* data) {
  auto* r = static_cast<Run*>(data);
  r->eval(u);
  return r->last_f;
}
void constraints_f(unsigned m, double* result, unsigned, const double* u, double*, void* data) {
  auto* r = static_cast<Run*>(data);
  r->eval(u);
  for (unsigned i = 0; i < m; ++i) result[i] = r->last_g[i];
}

StageReport run_stage(Run& r, nlopt_algorithm alg, const char* name, bool constrained, std::vector<double>& u, int budget) {
  StageReport s;
  s.algorithm = name;
  const int before = r.evaluations;
  const auto t = Clock::now();
  nlopt_opt opt = nlopt_create(alg, static_cast<unsigned>(r.n));
  std::vector<double> lo(r.n, 0.0), hi(r.n, 1.0);
  nlopt_set_lower_bounds(opt, lo.data());
  nlopt_set_upper_bounds(opt, hi.data());
  nlopt_set_maxeval(opt, std::max(1, budget));
  if (constrained) {
    nlopt_set_min_objective(opt, plain_f, &r);
    if (r.p.constraint_count > 0) {
      std::vector<double> tol(static_cast<std::size_t>(r.p.constraint_count), 1e-6);
      nlopt_add_inequality_mconstraint(opt, static_cast<unsigned>(r.p.constraint_count), constraints_f, &r, tol.data());
    }
  } else {
    nlopt_set_min_objective(opt, penalised_f, &r);
  }
  if (alg == NLOPT_LN_COBYLA || alg == NLOPT_LN_BOBYQA) {
    nlopt_set_xtol_rel(opt, r.o.xtol_rel);
    nlopt_set_initial_step1(opt, 0.1);
  }
  r.current = opt;
  double f = 0.0;
  const nlopt_result res = nlopt_optimize(opt, u.data(), &f);
  r.current = nullptr;
  nlopt_destroy(opt);
  s.evaluations = r.evaluations - before;
  s.time_s = std::chrono::duration<double>(Clock::now() - t).count();
  s.stop_reason = r.stopped ? r.termination.describe() : r.budget_hit ? "evaluation budget reached" : stop_words(res);
  s.best_objective = r.best_f;
  return s;
}

}  // namespace

const char* to_string(OptimizerOptions::Global g) {
  switch (g) {
    case OptimizerOptions::Global::direct_l: return "DIRECT-L";
    case OptimizerOptions::Global::crs2: return "CRS2";
    case OptimizerOptions::Global::isres: return "ISRES";
    case OptimizerOptions::Global::none: return "none";
  }
  return "?";
}
const char* to_string(OptimizerOptions::Local l) {
  switch (l) {
    case OptimizerOptions::Local::cobyla: return "COBYLA";
    case OptimizerOptions::Local::bobyqa: return "BOBYQA";
    case OptimizerOptions::Local::none: return "none";
  }
  return "?";
}

void OptimizerOptions::validate() const {
  if (max_evaluations < 1 || max_evaluations > 10'000'000)
    throw InputError::field("max_evaluations", fmt::format("{} is out of range: must be in [1, 10000000]", max_evaluations));
  if (!(global_share > 0.0 && global_share <= 1.0))
    throw InputError::field("global_share", fmt::format("{} is out of range: must be in (0, 1]", global_share));
  if (!(xtol_rel > 0.0 && xtol_rel < 1.0)) throw InputError::field("xtol_rel", fmt::format("{} must be in (0, 1)", xtol_rel));
  if (!(std::isfinite(penalty) && penalty > 0.0)) throw InputError::field("penalty", fmt::format("{} must be > 0", penalty));
}

OptimizerResult optimize(const Problem& p, const OptimizerOptions& o, Termination& termination) {
  o.validate();
  // The problem is the caller's construction (tune() builds it from the gain specs), not the
  // user's input: a malformed one is a bug.
  MACHPLAN_ASSERT(!p.parameters.empty(), "optimize: no parameters");
  MACHPLAN_ASSERT(static_cast<bool>(p.evaluate), "optimize: no evaluate function");
  MACHPLAN_ASSERT(p.constraint_count >= 0, "optimize: negative constraint count {}", p.constraint_count);
  for (const Parameter& q : p.parameters) {
    MACHPLAN_ASSERT(std::isfinite(q.lo) && std::isfinite(q.hi) && q.lo < q.hi,
                    "optimize: parameter {}: bounds [{}, {}] are not an interval", q.name, q.lo, q.hi);
    MACHPLAN_ASSERT(!q.log_scale || q.lo > 0, "optimize: parameter {}: log scale needs lo > 0, got {}", q.name, q.lo);
    MACHPLAN_ASSERT(q.start >= q.lo && q.start <= q.hi, "optimize: parameter {}: start {} outside [{}, {}]", q.name,
                    q.start, q.lo, q.hi);
  }
  Run r(p, o, termination);
  r.t0 = Clock::now();
  nlopt_srand(o.seed);

  std::vector<double> u(r.n);
  for (std::size_t i = 0; i < r.n; ++i) u[i] = std::clamp(r.to_u(i, p.parameters[i].start), 0.0, 1.0);
  r.eval(u.data());  // the start point, so the answer is never worse than it

  OptimizerResult out;
  const bool local = o.local != OptimizerOptions::Local::none;
  const bool global = o.global != OptimizerOptions::Global::none;
  int budget = o.max_evaluations - 1;
  if (global && budget > 0 && !r.ended()) {
    const int b = local ? std::max(1, static_cast<int>(std::lround(budget * o.global_share))) : budget;
    std::vector<double> ug = u;
    nlopt_algorithm alg = NLOPT_GN_DIRECT_L;
    bool constrained = false;
    if (o.global == OptimizerOptions::Global::crs2) alg = NLOPT_GN_CRS2_LM;
    if (o.global == OptimizerOptions::Global::isres) {
      alg = NLOPT_GN_ISRES;
      constrained = true;
    }
    out.global = run_stage(r, alg, to_string(o.global), constrained, ug, b);
    budget = o.max_evaluations - r.evaluations;
  } else {
    out.global.algorithm = "none";
  }
  if (local && budget > 0 && !r.stopped && !r.ended()) {
    std::vector<double> ul = !r.best_u.empty() ? r.best_u : r.least_u;
    const bool cobyla = o.local == OptimizerOptions::Local::cobyla;
    const nlopt_algorithm alg = cobyla ? NLOPT_LN_COBYLA : NLOPT_LN_BOBYQA;
    // From the global stage's best point, then, with what that leaves of half the budget
    // and more, from the start (when it was not already the best).
    const bool two = global && ul != u;
    out.local = run_stage(r, alg, to_string(o.local), cobyla, ul, two ? (budget + 1) / 2 : budget);
    budget = o.max_evaluations - r.evaluations;
    if (two && budget > 0 && !r.stopped && !r.ended()) {
      const StageReport first = out.local;
      std::vector<double> us = u;
      const StageReport second = run_stage(r, alg, to_string(o.local), cobyla, us, budget);
      out.local.evaluations += second.evaluations;
      out.local.time_s += second.time_s;
      out.local.best_objective = second.best_objective;
      out.local.stop_reason = fmt::format("from the global best: {}; from the start: {}", first.stop_reason, second.stop_reason);
    }
  } else {
    out.local.algorithm = to_string(o.local);
    out.local.stop_reason = local ? (r.ended() ? termination.describe() : "no budget left") : "";
  }

  out.feasible = !r.best_u.empty();
  const std::vector<double>& ub = out.feasible ? r.best_u : r.least_u;
  out.x = r.to_x(ub.data());
  out.objective = out.feasible ? r.best_f : r.least_f;
  out.constraints = out.feasible ? r.best_g : r.least_g;
  out.evaluations = r.evaluations;
  out.time_s = r.elapsed_s();
  if (r.ended()) out.ended_by = termination.reason();
  return out;
}

bool usable_when_ended(const OptimizerResult& r, Status status) {
  return r.stopped() && r.feasible && (status == Status::deadline || status == Status::budget);
}

std::string stop_message(const std::string& reason, bool usable, const std::string& what) {
  return usable ? fmt::format("{}; the best {} found by then meet every constraint and are usable", reason, what) : reason;
}

std::string OptimizerResult::report() const {
  std::string s;
  s += fmt::format("  optimiser        {} evaluations in {:.2f} s, {}\n", evaluations, time_s,
                   feasible ? "feasible" : "NO FEASIBLE POINT FOUND (least violating shown)");
  for (const StageReport* st : {&global, &local})
    if (st->algorithm != "none")
      s += fmt::format("    {:<10} {:>6} evaluations {:>7.2f} s  stop: {}\n", st->algorithm, st->evaluations, st->time_s,
                       st->stop_reason);
  return s;
}

}  // namespace machplan::tuning
