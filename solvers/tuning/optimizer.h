// Two-stage box-constrained optimisation with inequality constraints, NLopt behind our types.
//
//     minimise f(x)   over lo <= x <= hi   subject to g_i(x) <= 0,  i = 1 .. m
//
// x is searched in a normalised cube u in [0, 1]^n: x = lo + u (hi - lo), or geometrically
// between lo and hi for a log-scale parameter (gains spanning decades).
//
// Stage 1, global: DIRECT-L (Gablonsky's locally biased DIRECT) by default. Why DIRECT: the
// problems here have 1 to 8 gains, a simulated objective that is deterministic but not smooth
// (quantised encoders, friction sticking, saturation), and a budget of a few hundred to a few
// thousand evaluations. DIRECT divides the box systematically, needs no gradient, no
// population and no random seed, and in such low dimension covers the box far better per
// evaluation than CRS or ISRES (whose populations of 10 (n + 1) and 20 (n + 1) points spend
// the budget on the first generations). DIRECT has no constraint handling, so this stage
// minimises the penalised f + penalty * sum_i max(0, g_i) (the caller scales g to O(1)).
// CRS2 and ISRES (which handles the constraints itself) can be chosen instead.
// Stage 2, local: COBYLA from the best point of stage 1, then from the start point with the
// rest of the budget (at least half of it) when the two differ: the callers' starts carry a
// model (the drive's own feed-forward), whose basin the global stage's coarse division may
// well miss. Both with the constraints as NLopt
// inequality constraints (BOBYQA on the penalised objective can be chosen: faster when no
// constraint is active, blind to them otherwise).
//
// The result is the best FEASIBLE point seen in either stage (and never worse than the
// start point when that is feasible); when no feasible point was seen, the least-violating
// one, with feasible = false. Each evaluation of the caller's function is counted once:
// NLopt's separate calls for the objective and the constraints at the same x share it.
//
// Stopping: the evaluation budget (shared: global_share of it to stage 1), xtol_rel in stage 2,
// or the caller's Termination (a stop request, or a deadline or budget the caller's evaluate
// charges), polled after every evaluation. The stop reason of each stage is NLopt's, in words.
// No wall clock decides anything: the same problem gives the same answer on any machine.
//
// Threading: optimize() calls `evaluate` from the calling thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "engine/common/summary.h"
#include "engine/common/termination.h"

namespace machplan::tuning {

struct Parameter {
  std::string name;
  double lo = 0.0, hi = 1.0;
  double start = 0.5;  // inside [lo, hi]
  bool log_scale = false;
};

struct Problem {
  std::vector<Parameter> parameters;
  int constraint_count = 0;
  // f(x); fills g (sized constraint_count) with g_i(x), feasible when all <= 0. A non-finite
  // f (a run that diverged) is treated as infeasible and very bad.
  std::function<double(const std::vector<double>& x, std::vector<double>& g)> evaluate;
};

struct OptimizerOptions {
  enum class Global { direct_l, crs2, isres, none };
  enum class Local { cobyla, bobyqa, none };
  Global global = Global::direct_l;
  Local local = Local::cobyla;
  int max_evaluations = 600;   // both stages together
  double global_share = 0.6;   // of max_evaluations for stage 1 (when a local stage follows)
  double xtol_rel = 1e-3;      // stage 2, in the normalised cube
  double penalty = 100.0;      // stage 1 (and BOBYQA): weight of the summed violations
  std::uint64_t seed = 1;      // CRS2 and ISRES are randomised
  // Throws InputError naming the field.
  void validate() const;
};
const char* to_string(OptimizerOptions::Global g);
const char* to_string(OptimizerOptions::Local l);

struct StageReport {
  std::string algorithm;      // "DIRECT-L", "COBYLA", ...; "none"
  int evaluations = 0;
  double time_s = 0.0;
  std::string stop_reason;    // e.g. "evaluation budget reached", "x tolerance reached"
  double best_objective = 0.0;
};

struct OptimizerResult {
  std::vector<double> x;
  double objective = 0.0;
  std::vector<double> constraints;
  bool feasible = false;
  int evaluations = 0;
  double time_s = 0.0;
  // The caller's Termination ended the search (none: it ran to its budget or tolerance).
  Termination::Reason ended_by = Termination::Reason::none;
  bool stopped() const { return ended_by != Termination::Reason::none; }
  StageReport global, local;
  std::string report() const;  // a few lines for people
};

// Whether a search the caller's Termination ended with `status` still holds a usable answer
// (engine/common/summary.h): ended by its deadline or budget, with a feasible best point.
bool usable_when_ended(const OptimizerResult& result, Status status);
// Why the search ended early, for a summary's message: `reason` (what ended it), and when
// usable that the best `what` found so far meet every constraint.
std::string stop_message(const std::string& reason, bool usable, const std::string& what);

// Throws InternalError (MACHPLAN_ASSERT) when the problem is malformed (empty, lo >= hi, start outside,
// non-positive bound of a log-scale parameter) and InputError when options do not validate.
OptimizerResult optimize(const Problem& problem, const OptimizerOptions& options, Termination& termination);

}  // namespace machplan::tuning
